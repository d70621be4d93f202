"""The ROAR wire protocol, portable: the same files run on CPython >= 3.11 (under roar.protocol
on the laptop) and on MicroPython >= 1.22 (copied to the board's /lib).

    roar_wire.spec      every constant of protocol/spec.toml (generated; plain values)
    roar_wire.control   the control message: encode(), the streaming Parser, decode()
    roar_wire.junior    the ROAR Junior's control query: parse_query()

Nothing here imports dataclasses, enum or typing, or allocates per byte.
"""

INF = float("inf")


def finite(value):
    """Whether a float is a number (not NaN, not infinite): what a decoder accepts from the wire."""
    return value == value and value not in (INF, -INF)
