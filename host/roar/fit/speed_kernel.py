"""The fit's speed model stepped through its windows, compiled by Numba (roar.fit.model.speeds
says what it models). The fit's least squares calls it tens of thousands of times: as numpy,
a window's steps cost one array operation each (3 ms a call, 80 s of a 100 s `roar fit`).
Imported only once Numba is known to be there (roar.compiled)."""

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True)
def speeds(fractions: np.ndarray, v0: np.ndarray, top_m_s: float, drive_m_s2: float, coast_m_s2: float,
           traction_m_s2: float, step_s: float, out: np.ndarray) -> None:
    """out[w, k]: the speed [m/s] after step k of window w, from v0[w] at its start, for the
    motor's drive fractions[w, k] (-1..1, 0 in the dead band)."""
    coast = coast_m_s2 * step_s
    for w in range(fractions.shape[0]):
        v = v0[w]
        for k in range(fractions.shape[1]):
            f = fractions[w, k]
            target = f * top_m_s  # the wheels' speed the motor drives towards (0 in the dead band)
            if f == 0.0:  # in the dead band: drag to rest
                step = coast
            elif abs(v) > abs(target) and v * target >= 0.0:  # a car faster than its wheels coasts down to them
                step = coast
            else:  # driven: the motor's push, at most what the tyres take
                step = min(drive_m_s2 * abs(f) + coast_m_s2, traction_m_s2) * step_s
            v = min(v + step, target) if v < target else max(v - step, target)
            out[w, k] = v
