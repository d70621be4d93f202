"""SipHash-2-4 (Aumasson and Bernstein, 2012), the twin of the core's roar/siphash.h: a keyed
64-bit MAC of bytes under a 128-bit key, in Python that CPython and MicroPython both run.
Golden vectors: protocol/vectors/siphash24.json."""

MASK = 0xFFFFFFFFFFFFFFFF
KEY_BYTES = 16


def _rotl(x, b):
    return ((x << b) | (x >> (64 - b))) & MASK


def _round(v0, v1, v2, v3):
    v0 = (v0 + v1) & MASK
    v1 = _rotl(v1, 13) ^ v0
    v0 = _rotl(v0, 32)
    v2 = (v2 + v3) & MASK
    v3 = _rotl(v3, 16) ^ v2
    v0 = (v0 + v3) & MASK
    v3 = _rotl(v3, 21) ^ v0
    v2 = (v2 + v1) & MASK
    v1 = _rotl(v1, 17) ^ v2
    v2 = _rotl(v2, 32)
    return v0, v1, v2, v3


def _le(data):
    x = 0
    for i in range(len(data) - 1, -1, -1):
        x = (x << 8) | data[i]
    return x


def mac(key, data):
    """The MAC (an int, 0..2^64-1) of data (bytes) under key (16 bytes)."""
    if len(key) != KEY_BYTES:
        raise ValueError("a SipHash key is 16 bytes")
    k0, k1 = _le(key[:8]), _le(key[8:])
    v0, v1 = k0 ^ 0x736F6D6570736575, k1 ^ 0x646F72616E646F6D
    v2, v3 = k0 ^ 0x6C7967656E657261, k1 ^ 0x7465646279746573
    n = len(data)
    whole = n - n % 8
    for i in range(0, whole + 8, 8):
        m = _le(data[i:i + 8]) if i < whole else _le(data[whole:]) | (n & 0xFF) << 56
        v3 ^= m
        v0, v1, v2, v3 = _round(v0, v1, v2, v3)
        v0, v1, v2, v3 = _round(v0, v1, v2, v3)
        v0 ^= m
    v2 ^= 0xFF
    for _ in range(4):
        v0, v1, v2, v3 = _round(v0, v1, v2, v3)
    return v0 ^ v1 ^ v2 ^ v3
