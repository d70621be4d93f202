"""Everything about the package is in pyproject.toml; this adds one step to the wheel's build: the
firmware core's sources (firmware/core/include, firmware/core/src, firmware/host) go into
roar_sim/toolchains/firmware/, so an installed simulator builds the core on first use, outside
any checkout (roar_sim.toolchains.native)."""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
CORE_SOURCES = ("core/include", "core/src", "host")  # under firmware/: what the native build compiles


class BuildPyWithCoreSources(build_py):
    def run(self) -> None:
        editable = getattr(self, "editable_mode", False)  # an editable install builds from the checkout itself
        if not editable:  # a wheel holds this checkout's modules only, never ones a build left here before
            shutil.rmtree(self.build_lib, ignore_errors=True)
        super().run()
        if editable:
            return
        target = Path(self.build_lib) / "roar_sim" / "toolchains" / "firmware"
        for part in CORE_SOURCES:
            shutil.copytree(ROOT / "firmware" / part, target / part, dirs_exist_ok=True,
                            ignore=shutil.ignore_patterns("*.o", "__pycache__"))


setup(cmdclass={"build_py": BuildPyWithCoreSources})
