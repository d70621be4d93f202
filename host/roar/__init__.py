"""ROAR: drive small autonomous racing cars from Python, in simulation and for real.

    from roar import Vehicle
    with Vehicle("sim://") as car:        # then "serial:///dev/ttyUSB0" or "ble://" for a real car
        car.drive(throttle=0.3, steering=0.5)
"""

from roar.calibration import Calibration, CalibrationError, ChannelCalibration
from roar.errors import RoarError
from roar.telemetry import CarEvent, EventKind, VehicleState
from roar.transports import LinkLost, TransportError
from roar.vehicle import Vehicle

__version__ = "0.1.0"

__all__ = ["Calibration", "CalibrationError", "CarEvent", "ChannelCalibration", "EventKind", "LinkLost",
           "RoarError", "TransportError", "Vehicle", "VehicleState"]
