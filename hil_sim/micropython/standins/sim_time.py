"""`time` for board programs under the suite: the simulated clock, wrapping as an ESP32's does."""

import sim


def ticks_us():
    return sim.now_us % sim.TICKS_PERIOD


def ticks_ms():
    return (sim.now_us // 1000) % sim.TICKS_PERIOD


def ticks_cpu():
    return ticks_us()


def ticks_add(ticks, delta):
    return (ticks + delta) % sim.TICKS_PERIOD


def ticks_diff(a, b):
    half = sim.TICKS_PERIOD // 2
    return ((a - b + half) % sim.TICKS_PERIOD) - half


def sleep_us(us):
    sim.advance(us)


def sleep_ms(ms):
    sim.advance(ms * 1000)


def sleep(s):
    sim.advance(int(s * 1000000))


def time():
    return sim.now_us // 1000000


def time_ns():
    return sim.now_us * 1000
