"""Show and write tracks and worlds:

    roar track random:7 --plot out/random7.png          the track, its walls and where the car starts
    roar track random:7 --save my.json                  in the project's JSON (one width all round)
    roar track Spielberg_centerline.csv --line --plot out/spielberg.png
                                                        with the ESC car's minimum-curvature racing line
    roar track oval --save maps/oval_map.yaml           as an F1TENTH/ROS map (YAML + PNG, 5 cm cells)
                                                        and its centre line beside it (oval_centerline.csv)
    roar world tunnel:3 --plot out/tunnel3.png          a tunnel course: walls, cones, markers, people,
                                                        start and goal
    roar world tunnel:3 --save maps/tunnel3_map.yaml    its known map (walls only), its route
                                                        (tunnel3_centerline.csv) and tunnel3_course.yaml:
                                                        start and goal, and what the map leaves out

Prints the track's length, widths, tightest bend and walls (and a tunnel's course); with --line,
the racing line's lap limit against the centre line's for --robot. Saving writes by the file's
suffix: .json, .csv (a centre line with a width to each side of every point) or .yaml (a map).

Exit status: 0 done; 1 for a bad name, file or option, with a one-line error.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from roar.cli.sdk import ArgumentParser, ExitStatus, path_option, run_command
from roar.tracks import Track, TrackError, get
from roar.tracks.names import FORMS
from roar.user_files import unwritable
from roar_sim import robots
from roar_sim.world import plotting

MAP_RESOLUTION_M = 0.05  # [m] per cell of a written map


def summary(track: Track) -> str:

    widths = track.half_widths.sum(axis=1)
    radius, along, _ = track.tightest_bend()
    x, y, yaw = track.start_pose
    lines = [f"{track.name}: {track.length_m:.1f} m round, {widths.min():.2f}..{widths.max():.2f} m wide, tightest "
             f"bend of the centre line {radius:.2f} m ({along:.1f} m along); {len(track.walls)} "
             f"wall{'s' if len(track.walls) != 1 else ''}; start ({x:.2f}, {y:.2f}) facing {np.degrees(yaw):.0f} degrees"]
    for kind in map(robots.get, robots.names()):
        problem = kind.too_tight(track)
        if problem:
            lines.append(f"too tight for the {kind.title}, whose races are refused here: it {problem}")
    if track.course is not None:
        from roar.tracks.tunnel import describe

        lines.append(f"tunnel: {describe(track)}")
    return "\n".join(lines)


def plot(track: Track, line=None):
    fig, ax = plotting.subplots(figsize=(9, 7))
    plotting.draw_track(ax, track)
    x, y, yaw = track.start_pose
    ax.annotate("", xy=(x + np.cos(yaw), y + np.sin(yaw)), xytext=(x, y),
                arrowprops={"arrowstyle": "->", "color": "green", "lw": 2})
    ax.plot([x], [y], "o", color="green", label="start")
    course = track.course
    if course is not None:
        if course.cones:
            ax.scatter(*np.array(course.cones).T, s=30, color="darkorange", marker="^", label="cones", zorder=3)
        if course.markers:
            ax.scatter(*np.array(course.markers)[:, :2].T, s=40, color="green", marker="s", label="markers", zorder=3)
        if course.people:
            ax.scatter(*np.array(course.people).T, s=60, color="navy", marker="o", label="people", zorder=3)
        ax.plot(*course.goal[:2], "*", color="red", markersize=14, label="goal")
    if line is not None:
        closed = np.vstack([line.points, line.points[:1]])
        ax.plot(closed[:, 0], closed[:, 1], color="crimson", lw=1.2, label="racing line")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(summary(track).split("\n")[0], fontsize=9)
    return fig


def save(track: Track, path: Path) -> list[Path]:
    """Write the track by the path's suffix; returns the files written."""
    from roar.tracks import occupancy_map, track_files, tunnel

    suffix = path.suffix.lower()
    if suffix == ".json":
        path.write_text(track_files.to_json(track) + "\n", encoding="utf-8")
        return [path]
    if suffix == ".csv":
        if track.extra_area or track.course is not None:
            raise TrackError(f"{path}: a centre line cannot hold {track.name}'s side corridors and halls: save it as "
                             f"a map .yaml")
        path.write_text(track_files.centreline_csv(track), encoding="utf-8")
        return [path]
    if suffix in (".yaml", ".yml"):
        from roar_sim.world.scene import world_map  # the walls where the simulator's stand

        occupancy_map.save_map(path, world_map(track, MAP_RESOLUTION_M))
        name = track_files._stem(path)
        route = path.with_name(f"{name}_centerline.csv")
        route.write_text(track_files.centreline_csv(track), encoding="utf-8")
        written = [path, path.with_suffix(".png"), route]
        if track.course is not None:
            course = path.with_name(f"{name}_course.yaml")
            course.write_text(tunnel.course_yaml(track.course), encoding="utf-8")
            written.append(course)
        return written
    raise TrackError(f"{path}: a track is saved as .json, .csv (a centre line) or .yaml (a map)")


def parser(prog: str = "roar track") -> ArgumentParser:
    p = ArgumentParser(prog=prog, description=__doc__)
    p.add_argument("track", help=FORMS)
    p.add_argument("--plot", type=path_option, metavar="PNG", help="draw it into this PNG")
    p.add_argument("--save", type=path_option, metavar="FILE", help="write it as .json, .csv or .yaml (a map)")
    p.add_argument("--line", action="store_true",
                   help="compute the minimum-curvature racing line for --robot; print its lap limit and draw it")
    p.add_argument("--save-line", type=path_option, metavar="CSV",
                   help="with --line: write the racing line and its speeds in TUM's race-line format")
    p.add_argument("--robot", choices=robots.names(), default="esc",
                   help="whose width and limits the racing line is for (default esc)")
    return p


def main(argv: list[str] | None = None, prog: str = "roar track") -> int:
    p = parser(prog)
    args = p.parse_args(argv)
    plotting.check_png_argument(p, args.plot)
    if args.save_line and not args.line:
        p.error("--save-line needs --line")
    for flag, path in (("--save", args.save), ("--save-line", args.save_line)):
        problem = path is not None and unwritable(path)
        if problem:
            p.error(f"{flag} {problem}")
    track = get(args.track)
    print(summary(track))
    line = None
    if args.line:
        from roar.autopilot.speed_profile import lap_time, speed_profile
        from roar_sim.runs.race import optimal_line

        kind = robots.get(args.robot)
        line = optimal_line(track, args.robot)
        centre = lap_time(track.centerline, speed_profile(track.centerline, kind.limits))
        racing = line.lap_time_s(kind.limits)
        print(f"racing line for the {kind.title}: limit lap {racing:.2f} s ({racing / centre:.3f} x the centre line's "
              f"{centre:.2f} s); widest offset {np.abs(line.offsets_m).max():.2f} m, tightest radius "
              f"{1 / line.max_curvature:.2f} m")
        if args.save_line:
            from roar.tracks.track_files import raceline_csv

            args.save_line.write_text(raceline_csv(line.points, line.speeds(kind.limits)), encoding="utf-8")
            print(f"racing line: {args.save_line}")
    if args.save:
        for written in save(track, args.save):
            print(f"wrote {written}")
    if args.plot and not plotting.save(lambda: plot(track, line), args.plot):
        return ExitStatus.ERROR
    return ExitStatus.OK


def world_parser() -> ArgumentParser:
    return parser("roar world")


def world_main(argv: list[str] | None = None) -> int:
    return main(argv, prog="roar world")


if __name__ == "__main__":
    sys.exit(run_command("roar track", main))
