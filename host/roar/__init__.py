"""ROAR: drive small autonomous racing cars from Python, in simulation and for real."""

__version__ = "0.1.0"
