"""The base package alone, as a user who only drives real cars installs it: a fresh virtual
environment with `pip install roar-platform` (no extras) drives a loop:// car, pulls in neither
the simulator nor Bluetooth, and says in one line what to install for them."""

import subprocess
import sys

import pytest

from conftest import ROOT

HEAVY = ["pybullet", "matplotlib", "bleak", "bumble", "cffi"]


@pytest.fixture(scope="module")
def base_venv(tmp_path_factory):
    venv = tmp_path_factory.mktemp("base") / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    proc = subprocess.run([str(venv / "bin" / "pip"), "install", "-q", "--disable-pip-version-check", str(ROOT)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return venv / "bin"


def run(bin_dir, *args, **kw):
    return subprocess.run([str(bin_dir / args[0]), *args[1:]], capture_output=True, text=True, timeout=60,
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
                                         (["send", "ble://", "--for", "0.1"], "ble")])
def test_the_simulator_and_bluetooth_say_what_to_install(base_venv, argv, extra):
    proc = run(base_venv, "roar", *argv)
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"pip install 'roar-platform[{extra}]'" in lines[0], proc.stderr
