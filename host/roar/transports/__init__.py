"""Transports chosen by URL, pyserial-style:

    serial:///dev/ttyUSB0?baud=115200   a car on USB serial (pyserial)
    ble://ROAR Car                       a car over Bluetooth LE (bleak), by name or address
    ble://                               the first car advertising the ROAR service
    sim://  sim://oval                   the simulated car, in this process (real time)
    http://192.168.4.1:81                a ROAR Junior over Wi-Fi (or the simulated one)
    loop://                              records what is written, for tests

A transport is a small class (see base.Transport) registered under its URL scheme; register()
adds new ones, and installed packages can add theirs through the "roar.transports" entry point
group (value "module:Class").
"""

from roar.transports.base import LinkLost, Transport, TransportError
from roar.transports.registry import open_url, parse_url, register, schemes

__all__ = ["LinkLost", "Transport", "TransportError", "open_url", "parse_url", "register", "schemes"]
