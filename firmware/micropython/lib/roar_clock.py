"""Time for the MicroPython boards: a millisecond count that never wraps.

MicroPython's time.ticks_ms() wraps (after 2**30 ms on an ESP32), and ticks_diff() is right only
for intervals under half of that. Clock.now() extends it: each reading adds the ticks since the
previous one, so as long as it is read more often than every 6 days (the loops read it every
millisecond) time only ever grows, and every timed state stays expired however long the
silence. The count is a small int for 12 days, then a Python int like any other.

All timing of the boards is in whole milliseconds; the protocol's timing constants are whole
milliseconds too (checked below), so the boards decide exactly as the C++ core does.
"""

import time

from roar_wire import spec


def ms(us):
    """A protocol time [us] in [ms]; it must be whole milliseconds."""
    if us % 1000:
        raise ValueError("%d us is not a whole number of milliseconds" % us)
    return us // 1000


class Clock:
    def __init__(self, ticks_ms=None):
        self._ticks = ticks_ms or time.ticks_ms
        self._raw = self._ticks()
        self._now = 0  # [ms] since the clock was made

    def now(self):
        """[ms] since the clock was made; never wraps, never goes back."""
        raw = self._ticks()
        step = time.ticks_diff(raw, self._raw)
        if step > 0:
            self._now += step
            self._raw = raw
        return self._now


FAILSAFE_MS = ms(spec.TIMING_FAILSAFE_TIMEOUT_US)
JUNIOR_FAILSAFE_MS = ms(spec.JUNIOR_FAILSAFE_TIMEOUT_US)
DEAD_TIME_MS = ms(spec.L298N_DEAD_TIME_US)
BRAKE_STEP_MS = ms(spec.TIMING_BRAKE_STEP_US)
FRAME_MS = ms(spec.TIMING_SERVO_FRAME_US)
