"""Installs as users make them, each into a fresh virtual environment outside the checkout: the
base package alone (`pip install roar-platform`, no extras) drives a loop:// car, pulls in neither
the simulator nor Bluetooth, and says in one line what to install for them; the wheel with the
simulator (`[sim]`) builds the firmware core from the sources it carries and races a lap; `[ros2]`
brings rclpy and builds the two message types no wheel has on first use. The base install is
pip's; the two heavy extras are installed by uv from the same wheel and metadata (see venv_with)."""

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from conftest import ROOT

HEAVY = ["pybullet", "matplotlib", "bleak", "bumble", "cffi"]
# one worker for the module (--dist loadgroup): its fixtures build a venv and a wheel once, not on every worker
pytestmark = pytest.mark.xdist_group("install")


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel built from the checkout, once for every environment here (with this environment's
    setuptools: what pip would fetch into an isolated build is the same)."""
    where = tmp_path_factory.mktemp("dist")
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
                           "--disable-pip-version-check", "-w", str(where), str(ROOT)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return next(where.glob("roar_platform-*.whl"))


UV = Path(sys.executable).parent / "uv"


def venv_with(folder: Path, requirement: str, installer: str = "pip") -> Path:
    """A fresh virtual environment in folder with requirement installed: its bin folder. By this
    environment's pip (so none is copied into each; without compiling every module installed to
    bytecode ahead, as pip would: a third of an install's time, and Python compiles on first import
    anyway), or by uv, which resolves the same metadata and links the files from its cache: the
    simulator's extra writes 1.1 GB, 32 s by pip on an idle machine and 100 s in the suite, 1 s by uv
    once cached. The base install stays with pip, so pip's own reading of the wheel is tested too."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(folder)], check=True)
    python = str(folder / "bin" / "python")
    if installer == "uv":
        if not UV.exists():
            pytest.skip("uv installs the heavy extras here: pip install uv (the dev extra pins it)")
        command = [str(UV), "pip", "install", "-q", "--python", python, requirement]
    else:
        command = [sys.executable, "-m", "pip", "--python", python, "install", "-q", "--no-compile",
                   "--disable-pip-version-check", requirement]
    proc = subprocess.run(command, capture_output=True, text=True, timeout=1200)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return folder / "bin"


@pytest.fixture(scope="module")
def base_venv(tmp_path_factory, wheel):
    return venv_with(tmp_path_factory.mktemp("base") / "venv", str(wheel))


def run(bin_dir, *args, timeout: float = 60, **kw):
    return subprocess.run([str(bin_dir / args[0]), *args[1:]], capture_output=True, text=True, timeout=timeout,
                          cwd=bin_dir.parent.parent, **kw)


def test_the_base_install_drives_a_car_without_the_simulator_or_bluetooth(base_venv):
    script = ("from roar import Vehicle\n"
              "with Vehicle('loop://') as car:\n"
              "    car.drive(0.3, -0.5)\n"
              "    car.flush()\n"
              "    print(car.transport.messages()[-1].decode())\n")
    proc = run(base_venv, "python", "-c", script)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "(1650,1250)"
    for module in HEAVY:
        assert run(base_venv, "python", "-c", f"import {module}").returncode != 0, f"{module} came with the base install"


@pytest.mark.parametrize("argv, extra", [(["send", "sim://", "--for", "0.1"], "sim"), (["race"], "sim"),
                                         (["sim", "--serial"], "sim"), (["sweep"], "sweep"), (["scan"], "ble"),
                                         (["send", "ble://", "--for", "0.1"], "ble"),
                                         (["ros2", "loop://", "--for", "0.1"], "ros2")])
def test_the_simulator_and_bluetooth_say_what_to_install(base_venv, argv, extra):
    proc = run(base_venv, "roar", *argv)
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"pip install 'roar-platform[{extra}]'" in lines[0], proc.stderr


# --- ROS 2: the wheels, and the two message types built on first use ----------------------------------

@pytest.mark.skipif(sys.version_info[:2] != (3, 11), reason="the ROS 2 wheels are built for Python 3.11")
def test_the_ros2_extra_installs_and_builds_its_types_on_first_use(tmp_path, wheel):
    venv = venv_with(tmp_path / "venv", f"{wheel}[ros2]", installer="uv").parent
    env = {k: v for k, v in os.environ.items() if k not in ("LD_LIBRARY_PATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE",
                                                            "AMENT_PREFIX_PATH", "PYTHONPATH")}
    # (the first run builds the types with CMake: over 60 s once on a CI machine busy with the suite)
    first = run(venv / "bin", "roar", "ros2", "loop://", "--for", "0.3", "--domain", "231", env=env, timeout=300)
    assert first.returncode == 0, first.stderr
    assert "building ackermann_msgs" in first.stdout and "is node /roar" in first.stdout, first.stdout
    again = run(venv / "bin", "roar", "ros2", "loop://", "--for", "0.3", "--domain", "231", env=env)
    assert again.returncode == 0 and "building" not in again.stdout, again.stdout  # once
    assert run(venv / "bin", "python", "-c", "import ackermann_msgs.msg, tf2_msgs.msg", env=env).returncode == 0


# --- the wheel, with the simulator, outside any checkout ---------------------------------------------

@pytest.fixture(scope="module")
def sim_wheel(tmp_path_factory, wheel):
    """The wheel installed with [sim] into a fresh virtual environment in a folder of its own: (the
    wheel, the venv's bin folder, a working folder away from the checkout)."""
    where = tmp_path_factory.mktemp("wheel")
    bin_dir = venv_with(where / "venv", f"{wheel}[sim]", installer="uv")
    (where / "work").mkdir()
    return wheel, bin_dir, where / "work"


def away_from_the_checkout(work, **env):
    """The environment of a user's shell in `work`: their own cache, no PYTHONPATH into the checkout."""
    clean = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "ROAR_CORE_LIB", "CXX")}
    return {**clean, "HOME": str(work), "XDG_CACHE_HOME": str(work / "cache"), **env}


def test_the_wheel_holds_the_three_packages_and_the_core_sources_and_nothing_else(sim_wheel):
    wheel, _, _ = sim_wheel
    names = zipfile.ZipFile(wheel).namelist()
    assert {n.split("/")[0] for n in names} == {"roar", "roar_wire", "roar_sim", wheel.name.split("-py3")[0] + ".dist-info"}
    packaged = {n.split("roar_sim/toolchains/firmware/", 1)[1] for n in names if "/toolchains/firmware/" in n}
    expected = {str(p.relative_to(ROOT / "firmware")) for part in ("core/include", "core/src", "host")
                for p in (ROOT / "firmware" / part).rglob("*") if p.is_file()}
    assert packaged == expected and "host/c_api.h" in packaged
    profiles = {n.rsplit("/", 1)[1] for n in names if "/plants/car_profiles/" in n}
    assert profiles == {p.name for p in (ROOT / "hil_sim/roar_sim/plants/car_profiles").glob("*.toml")} >= {"roar.toml"}


def test_the_installed_wheel_builds_the_core_in_the_users_cache_and_races_a_lap(sim_wheel):
    _, bin_dir, work = sim_wheel
    env = away_from_the_checkout(work)
    race = subprocess.run([str(bin_dir / "roar"), "race", "--laps", "1", "--plot", "lap.png", "--track", "random:3",
                           "--car-profile", "roar"], cwd=work, env=env, capture_output=True, text=True, timeout=600)
    assert race.returncode == 0, race.stderr[-2000:]
    assert "lap 1:" in race.stdout and "wall contacts: 0" in race.stdout
    assert (work / "lap.png").read_bytes()[:4] == b"\x89PNG"
    assert (work / "cache" / "roar" / "core" / "release" / "libroarcore.so").exists()
    where = subprocess.run([str(bin_dir / "python"), "-c", "from roar_sim.toolchains import native; "
                            "print(native.INSTALLED, native.CORE)"], cwd=work, env=env, capture_output=True, text=True)
    installed, core = where.stdout.split()
    assert installed == "True" and "site-packages" in core and not core.startswith(str(ROOT))


def test_without_a_compiler_the_installed_simulator_says_so_in_one_line(sim_wheel):
    _, bin_dir, work = sim_wheel
    env = away_from_the_checkout(work, XDG_CACHE_HOME=str(work / "empty-cache"), CXX="no-such-c++")
    race = subprocess.run([str(bin_dir / "roar"), "race", "--laps", "1"], cwd=work, env=env, capture_output=True,
                          text=True, timeout=120)
    lines = race.stderr.strip().splitlines()
    assert race.returncode == 1 and len(lines) == 1, race.stderr
    assert "C++ compiler" in lines[0] and "apt-get install g++" in lines[0]
