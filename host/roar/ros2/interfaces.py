"""The message types ROS 2 nodes drive a car with that no wheel on PyPI provides: ackermann_msgs
(F1TENTH's /drive) and tf2_msgs (/tf). Each is built from its definitions (definitions/: the
upstream packages' field names and types, so each type's hash is the upstream type's hash and a
node built against the real package talks to ours) by the rosidl generators the ROS 2 wheels
bring, and installed into this Python environment's prefix, where those wheels put their own
(lib/, share/, lib/pythonX.Y/site-packages/). Built once; built again when a definition changes.

    python -m roar.ros2.interfaces      (make setup runs it; needs cmake and a C/C++ compiler)
    python -m roar.ros2.interfaces --prefix OTHER_VENV    into another environment (another distribution's)

Without them, /drive and /tf are not offered and everything else works (roar.ros2.bridge)."""

from __future__ import annotations

import hashlib
import importlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from roar.errors import Ros2Error

DEFINITIONS = Path(__file__).parent / "definitions"
PACKAGES = ("ackermann_msgs", "tf2_msgs")
# RIHS01 hashes of the upstream types, as their own definitions give them (ackermann_msgs 2.0.2,
# geometry2 0.39.1); ROS 2 compares them when nodes discover each other. The suite checks ours.
TYPE_HASHES = {
    "ackermann_msgs/msg/AckermannDrive": "RIHS01_acf287a224a947dd1b0b87d6d76cdb73f497b0237b8fc73be2173b2ebbb82c99",
    "ackermann_msgs/msg/AckermannDriveStamped":
        "RIHS01_48ca7612a08d3bb72744fd98b71b7cf2ea24c6ad50fa4e1aa0bbad963c90d8cf",
    "tf2_msgs/msg/TFMessage": "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
}
STAMP = "roar-definitions.sha256"  # in share/<package>/: the definitions it was built from


def fingerprint(package: str) -> str:
    digest = hashlib.sha256()
    for path in sorted((DEFINITIONS / package).rglob("*")) + [DEFINITIONS / "wheel_targets.cmake"]:
        if path.is_file():
            digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def prefix() -> Path:
    """Where the ROS 2 wheels installed themselves: this environment's root."""
    return Path(sys.prefix)


def current(package: str, root: Path | None = None) -> bool:
    stamp = (root or prefix()) / "share" / package / STAMP
    return stamp.is_file() and stamp.read_text().strip() == fingerprint(package)


def available(package: str) -> bool:
    """Whether `package`'s Python messages import (built here, or from the user's ROS install)."""
    try:
        importlib.import_module(f"{package}.msg")
    except ImportError:
        return False
    return True


def build_environment(root: Path) -> dict[str, str]:
    env = dict(os.environ)
    libs = [str(root / "lib"), *map(str, sorted(root.glob("lib/python3*/site-packages/ros_*.libs")))]
    env["LD_LIBRARY_PATH"] = os.pathsep.join([*libs, env.get("LD_LIBRARY_PATH", "")]).rstrip(os.pathsep)
    for name in ("AMENT_PREFIX_PATH", "CMAKE_PREFIX_PATH"):
        env[name] = os.pathsep.join([str(root), env.get(name, "")]).rstrip(os.pathsep)
    env["PATH"] = os.pathsep.join([str(root / "bin"), env.get("PATH", "")])
    return env


def build(package: str, root: Path | None = None, log=print) -> None:
    """Generate, compile and install `package` into `root`: a Python environment with the ROS 2
    wheels (default: this one; another: its own Python runs the generators); Ros2Error
    with the tool to install or the log's last lines."""
    root = root or prefix()
    python = Path(sys.executable) if root == prefix() else root / "bin" / "python"
    missing = [tool for tool in ("cmake", "cc", "c++") if shutil.which(tool) is None]
    if missing:
        raise Ros2Error(f"building {package} needs {', '.join(missing)}: apt install cmake g++")
    ninja = ["-G", "Ninja"] if shutil.which("ninja") else []
    with tempfile.TemporaryDirectory(prefix=f"roar-{package}-") as tmp:
        build_dir, log_path = Path(tmp) / "build", Path(tmp) / "build.log"
        steps = [
            ["cmake", "-S", str(DEFINITIONS / package), "-B", str(build_dir), *ninja, f"-DCMAKE_INSTALL_PREFIX={root}",
             "-DBUILD_TESTING=OFF", "-DCMAKE_BUILD_TYPE=Release", f"-DPython3_EXECUTABLE={python}"],
            ["cmake", "--build", str(build_dir), "--target", "install", "--parallel", str(os.cpu_count() or 1)],
        ]
        log(f"building {package} from its definitions into {root} (once)...")
        with log_path.open("w") as out:
            for step in steps:
                if subprocess.run(step, stdout=out, stderr=subprocess.STDOUT, env=build_environment(root)).returncode:
                    tail = log_path.read_text().strip().splitlines()[-12:]
                    raise Ros2Error(f"building {package} failed; the build's last lines:\n" + "\n".join(tail))
    (root / "share" / package / STAMP).write_text(fingerprint(package) + "\n")


def ensure(log=print) -> list[str]:
    """Build what is not current; the packages that still do not import (a build that failed is
    said through `log`, and the bridge goes on without those types)."""
    for package in PACKAGES:
        if not current(package):
            try:
                build(package, log=log)
            except Ros2Error as e:
                log(str(e))
    importlib.invalidate_caches()
    return [package for package in PACKAGES if not available(package)]


def main(argv: list[str] | None = None) -> int:
    import argparse

    p = argparse.ArgumentParser(prog="python -m roar.ros2.interfaces", description=__doc__.split("\n\n")[0])
    p.add_argument("--prefix", type=Path, default=None,
                   help="another Python environment with the ROS 2 wheels to build into (default: this one)")
    root = p.parse_args(argv).prefix
    if root is None:
        try:
            import rclpy  # noqa: F401  (the wheels the build needs)
        except ImportError as e:
            print(f"the ROS 2 message builds need {e.name}: pip install 'roar-platform[ros2]'", file=sys.stderr)
            return 1
    elif not (root / "share" / "rosidl_default_generators").is_dir():
        print(f"{root} has no rosidl generators: pip install ros-<distro>-rosidl-default-generators there",
              file=sys.stderr)
        return 1
    for package in PACKAGES:
        if current(package, root):
            print(f"{package}: current")
            continue
        try:
            build(package, root)
        except Ros2Error as e:
            print(e, file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
