"""The `roar` command: drive, calibrate and inspect cars, real or simulated."""

from roar.cli.main import main

__all__ = ["main"]
