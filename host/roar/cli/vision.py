"""`roar vision FOLDER|RECORDING.mcap`: the car's perception over recorded frames -- a real car's
or the simulator's. Every image (PNG/JPEG, or an RGB array in NPY) in the folder, in name order
(or every camera frame of an MCAP recording, roar.recorder's, named by its time), goes
through the lane detector (the moving ROIs carry from frame to frame, as live); a depth image
beside it (NAME_depth.npy, metres) goes through the ground-plane occupancy grid too. Writes a
debug view per frame (NAME_lanes.png, NAME_occupancy.png) into --out, optionally a video of the
lane views, and prints one line per frame: the car's offset and heading against the road's
centre, which lines were seen, and the nearest obstacle ahead.

The camera is the simulated car's unless told otherwise: --fov (vertical), --height, --ahead
and --pitch describe a real car's mounting.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from roar.cli.sdk import ArgumentParser, UserError, path_option
from roar.errors import FramesError
from roar.vision.geometry import SIMULATED_CAR_CAMERA, CameraPreset

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
DEPTH_SUFFIX = "_depth.npy"
MIN_FRAME_PX = 16  # [px] the shortest side of a frame the lane detector can look at


def frames_in(folder: Path) -> list[Path]:
    """The RGB frames of a folder, in name order (depth arrays are not frames)."""
    if not folder.exists():
        raise FramesError(f"{folder} does not exist")
    if not folder.is_dir():
        raise FramesError(f"{folder} is not a folder (nor an .mcap recording)")
    found = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES
                   or (p.suffix == ".npy" and not p.name.endswith(DEPTH_SUFFIX)))
    if not found:
        raise FramesError(f"no frames in {folder}: want PNG/JPEG images or RGB arrays in .npy files")
    return found


def load_rgb(path: Path) -> np.ndarray:
    if path.suffix == ".npy":
        try:
            rgb = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as e:
            raise FramesError(f"{path.name}: not a numpy array ({e})") from None
    else:
        from roar.vision.geometry import cv2

        bgr = cv2().imread(str(path), cv2().IMREAD_COLOR)
        if bgr is None:
            raise FramesError(f"{path.name}: not an image OpenCV can read")
        rgb = bgr[:, :, ::-1]
    if rgb.ndim != 3 or rgb.shape[2] < 3 or rgb.dtype != np.uint8:
        raise FramesError(f"{path.name}: want an H x W x 3 RGB image of bytes, got {rgb.dtype} {rgb.shape}")
    if min(rgb.shape[:2]) < MIN_FRAME_PX:
        raise FramesError(f"{path.name} is {rgb.shape[1]}x{rgb.shape[0]}: a frame is at least "
                          f"{MIN_FRAME_PX}x{MIN_FRAME_PX} px")
    return np.ascontiguousarray(rgb[:, :, :3])


def load_depth(path: Path, size: tuple[int, int]) -> tuple[np.ndarray, int]:
    """(depth [m] as float32, how many of its pixels are not finite numbers) from NAME_depth.npy,
    which must be an H x W array of numbers the size (W, H) of its frame."""
    try:
        depth = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as e:
        raise FramesError(f"{path.name}: not a numpy array ({e})") from None
    if depth.ndim != 2 or depth.dtype.kind not in "fiu":
        raise FramesError(f"{path.name}: want an H x W array of depths in metres, got {depth.dtype} {depth.shape}")
    if depth.shape[::-1] != size:
        raise FramesError(f"{path.name} is {depth.shape[1]}x{depth.shape[0]}, its frame {size[0]}x{size[1]}: "
                          f"a depth image is its frame's size")
    depth = depth.astype(np.float32)
    return depth, int(np.count_nonzero(~np.isfinite(depth)))


def _figure_rgb(fig) -> np.ndarray:
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[:, :, :3].copy()


def perceive(folder: Path, out: Path, video: Path | None = None, fps: float = 10.0,
             camera: CameraPreset = SIMULATED_CAR_CAMERA) -> int:
    import matplotlib.pyplot as plt

    from roar.vision.geometry import BirdsEye, cv2
    from roar.vision.lanes import LaneDetector, debug_view
    from roar.vision.occupancy import figure, occupancy

    recording = folder.suffix.lower() == ".mcap" and not folder.is_dir()
    items = _recorded(folder) if recording else \
        ((p.name, p.stem, lambda p=p: load_rgb(p), p) for p in frames_in(folder))
    out.mkdir(parents=True, exist_ok=True)
    detector, size, writer = None, None, None
    count = 0
    for name, stem, load, path in items:
        count += 1
        rgb = load()
        h, w = rgb.shape[:2]
        if size is None:
            size = (w, h)
            detector = LaneDetector(BirdsEye(camera.model(w, h)))
        elif size != (w, h):
            raise FramesError(f"{name} is {w}x{h}, the frames before it {size[0]}x{size[1]}: one camera a folder")
        lanes = detector.detect(rgb)
        fig = debug_view(detector, rgb)
        fig.savefig(out / f"{stem}_lanes.png")
        if video is not None:
            view = _figure_rgb(fig)
            if writer is None:
                writer = cv2().VideoWriter(str(video), cv2().VideoWriter_fourcc(*"mp4v"), fps,
                                           (view.shape[1], view.shape[0]))
                if not writer.isOpened():
                    raise FramesError(f"cannot write the video {video} (OpenCV has no MP4 writer here?)")
            writer.write(np.ascontiguousarray(view[:, :, ::-1]))
        plt.close(fig)
        line = (f"{name}: lines {lanes.source}"
                + (f", offset {lanes.offset_m:+.3f} m, heading {math.degrees(lanes.heading_rad):+.1f} deg"
                   if lanes.centre is not None else ""))
        depth_path = None if path is None else path.with_name(path.stem + DEPTH_SUFFIX)
        if depth_path is not None and depth_path.exists():
            depth, unknown = load_depth(depth_path, size)
            grid = occupancy(depth, camera.model(w, h))
            nearest = grid.nearest_ahead(0.25)
            line += f"; obstacle ahead {'none' if nearest is None else f'{nearest:.2f} m'}"
            if unknown:
                line += f" ({unknown} of {depth.size} depth pixels not a number)"
            occupancy_fig = figure(rgb, grid)
            occupancy_fig.savefig(out / f"{stem}_occupancy.png")
            plt.close(occupancy_fig)
        print(line, flush=True)
    if writer is not None:
        writer.release()
    print(f"{count} frames; debug views in {out}" + (f", video {video}" if video is not None else ""))
    return 0


def _recorded(path: Path):
    """(name, stem, load, None) of each camera frame of a recording (no depth: not recorded)."""
    from roar.dataset import frames

    for k, (t_ns, rgb, _, _) in enumerate(frames(path)):
        stem = f"{k:06d}"
        yield f"{stem} at {t_ns / 1e9:.3f} s", stem, (lambda rgb=rgb: rgb), None


def parser() -> ArgumentParser:
    p = ArgumentParser(prog="roar vision",
                       description="Run the car's perception over recorded frames (a real car's or the "
                                   "simulator's): lane lines in every image (PNG/JPEG, or RGB .npy) in name "
                                   "order, and the ground-plane occupancy grid where a NAME_depth.npy (metres) "
                                   "lies beside it. Writes a debug view per frame, optionally a video, and "
                                   "prints offset, heading and the nearest obstacle per frame. The camera is the "
                                   "simulated car's unless --fov/--height/--ahead/--pitch say otherwise.")
    p.add_argument("folder", type=path_option, metavar="FOLDER|MCAP",
                   help="the recorded frames: a folder (roar race --frames), or a recording's camera frames")
    p.add_argument("--out", type=path_option, default=Path("out/vision"), metavar="DIR",
                   help="where the debug views go (default: out/vision)")
    p.add_argument("--video", type=path_option, default=None, metavar="MP4", help="also write the lane views as a video")
    p.add_argument("--fps", type=float, default=10.0, help="the video's frame rate (default 10)")
    cam = SIMULATED_CAR_CAMERA
    p.add_argument("--fov", type=float, default=cam.fov_deg, metavar="DEG",
                   help=f"vertical field of view (default {cam.fov_deg:g})")
    p.add_argument("--height", type=float, default=cam.z_m, metavar="M",
                   help=f"camera above the floor (default {cam.z_m:g})")
    p.add_argument("--ahead", type=float, default=cam.x_m, metavar="M",
                   help=f"camera ahead of the car's reference point, the rear axle (default {cam.x_m:g})")
    p.add_argument("--pitch", type=float, default=math.degrees(cam.pitch_rad), metavar="DEG",
                   help=f"tilted down from level (default {math.degrees(cam.pitch_rad):.2f})")
    return p


def main(argv: list[str]) -> int:
    from roar.user_files import unusable_folder, unwritable

    args = parser().parse_args(argv)
    if not (1 <= args.fov < 180 and 0 < args.height <= 5 and -5 <= args.ahead <= 5 and -45 <= args.pitch <= 89
            and 0.1 <= args.fps <= 120):
        raise UserError("want --fov 1..179 deg, --height 0..5 m, --ahead -5..5 m, --pitch -45..89 deg, --fps 0.1..120")
    for option, problem in (("--out", unusable_folder(args.out)),
                            ("--video", args.video is not None and unwritable(args.video))):
        if problem:
            raise UserError(f"{option} {problem}")
    try:
        camera = CameraPreset(args.fov, args.ahead, args.height, math.radians(args.pitch))
        return perceive(args.folder, args.out, args.video, args.fps, camera)
    except ImportError as e:
        raise UserError(f"roar vision needs {e.name}: pip install 'roar-platform[vision]'") from None
