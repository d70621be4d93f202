"""The batched world's compiled loops (Numba, module level so that its disk cache serves every later
process): the ESC and servo behind each car's latency, the single-track body, wall contact, the
lidar marched on the track's distance field, and progress along the centre line.

Arrays are per car in rows (structure of arrays where the loops read columns). Every loop over cars
is a prange: the cars share nothing but the read-only track pool.
"""

import math

import numba as nb

from roar.protocol import spec
from roar_sim.world.wall_field import sdf_in

G_M_S2 = 9.81  # [m/s^2]
NEUTRAL_US = float(spec.CONTROL_NEUTRAL_US)  # [us]
HALF_RANGE_US = (spec.CONTROL_MAX_US - spec.CONTROL_MIN_US) / 2  # [us]
RING = 32  # pulses in flight per car: a frame each 20 ms within the longest latency (0.5 s) and then some
SUBSTEPS = 2  # integration steps per physics step (2.5 ms each at the PyBullet car's 5 ms)
HIT_M = 2e-3  # [m] a beam this near a wall has met it (the last two samples then place the wall's face)
MARCH_STEPS = 96  # the most steps a beam takes
OVERSTEP = 1.0  # sphere tracing's step over the distance to the nearest wall, while no sphere is skipped
DONE_US = 1 << 30  # [us] a frame in flight this far past due has acted already

# body columns: the centre of mass's x, y [m], yaw [rad], its velocity along and across the car
# [m/s], the yaw rate [rad/s], and the last longitudinal acceleration [m/s^2] (the load it moves)
X, Y, YAW, VX, VY, R, AX = range(7)
BODY = 7
# actuator columns: the servo's angle and target [rad], the ESC's drive (-1..1) and brake (0..1)
ANGLE, TARGET, DRIVE, BRAKE = range(4)
ACT = 4
# ESC columns: mode (0 neutral, 1 forward, 2 brake, 3 reverse), reverse locked, braked since
NEUTRAL, FORWARD, BRAKING, REVERSE = range(4)
# parameter columns (roar_sim.batch.model.parameters fills them: what each is, from where)
(P_MASS, P_IZ, P_LF, P_LR, P_H, P_MU, P_SLIP, P_DAMP, P_SLIDING, P_VTOP, P_FDRIVE, P_FDRAG, P_FBRAKE, P_TAU, P_ROLL,
 P_MAXSTEER, P_RATE, P_LAG, P_TRIM, P_DEADBAND, P_REVERSE, P_LATENCY, P_BASE, P_REAR, P_FRONT, P_HALFW,
 P_LIDAR) = range(27)
PARAMS = 27


@nb.njit(cache=True, nogil=True, fastmath=True)
def _wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


@nb.njit(cache=True, nogil=True, fastmath=True)
def _esc_pulse(esc, i, width, deadband, reverse_limit, act):
    """HobbyEsc.pulse: a throttle pulse [us] taken by car i's ESC; act's drive and brake."""
    off = width - NEUTRAL_US
    if abs(off) <= deadband:
        if esc[i, 2]:
            esc[i, 1] = 0
            esc[i, 2] = 0
        esc[i, 0] = NEUTRAL
        act[i, DRIVE] = 0.0
        act[i, BRAKE] = 0.0
        return
    amount = min(1.0, (abs(off) - deadband) / (HALF_RANGE_US - deadband))
    if off > 0:
        esc[i, 0], esc[i, 1], esc[i, 2] = FORWARD, 1, 0
        act[i, DRIVE], act[i, BRAKE] = amount, 0.0
    elif esc[i, 1]:
        esc[i, 0], esc[i, 2] = BRAKING, 1
        act[i, DRIVE], act[i, BRAKE] = 0.0, amount
    else:
        esc[i, 0] = REVERSE
        act[i, DRIVE], act[i, BRAKE] = -amount * reverse_limit, 0.0


@nb.njit(cache=True, nogil=True, fastmath=True)
def _servo_pulse(act, i, width, max_angle, trim_rad):
    """SteeringServo.pulse: car i's servo aims for a steering pulse [us] (right above neutral)."""
    frac = max(-1.0, min(1.0, (width - NEUTRAL_US) / HALF_RANGE_US))
    act[i, TARGET] = max(-max_angle, min(max_angle, -frac * max_angle + trim_rad))


@nb.njit(cache=True, nogil=True, fastmath=True)
def _servo_advance(act, i, dt, rate, lag):
    step = rate * dt
    error = act[i, TARGET] - act[i, ANGLE]
    if lag > 0.0:
        error *= -math.expm1(-dt / lag)
    act[i, ANGLE] += max(-step, min(step, error))


@nb.njit(cache=True, nogil=True, fastmath=True)
def _sdf(pool, meta, k, x, y):
    """[m] track k's distance from (x, y) to its nearest wall's face, bilinear; 1e9 off its grid."""
    return sdf_in(pool, meta[k, 0], meta[k, 1], meta[k, 2], int(meta[k, 3]), int(meta[k, 4]), int(meta[k, 5]), x, y)


@nb.njit(cache=True, nogil=True, fastmath=True)
def _touching(pool, meta, k, x, y, yaw, rear, front, half_width):
    """Whether the car's footprint (from `rear` to `front` [m] along it from (x, y), half_width
    across) reaches into a wall: its edge sampled every ~0.1 m."""
    c, s = math.cos(yaw), math.sin(yaw)
    along = max(2, int((front - rear) / 0.1) + 1)
    for j in range(along):
        u = rear + (front - rear) * j / (along - 1)
        for side in (-1.0, 1.0):
            v = side * half_width
            if _sdf(pool, meta, k, x + u * c - v * s, y + u * s + v * c) < 0.0:
                return True
    for j in range(1, 3):  # the two ends' middles
        v = half_width * (2 * j - 3) / 3
        for u in (rear, front):
            if _sdf(pool, meta, k, x + u * c - v * s, y + u * s + v * c) < 0.0:
                return True
    return False


@nb.njit(cache=True, nogil=True, fastmath=True)
def _motor_force(p, vx, drive, brake):
    """[N] the rear wheels' push on the car along it, as the PyBullet car's velocity motors give it
    (Racecar.apply): towards the throttle's wheel speed with the motor's torque, a faster car
    coasting; braking towards standstill; in neutral the drag alone."""
    m, tau = p[P_MASS], p[P_TAU]
    if brake > 0.0:
        most = p[P_FBRAKE] * brake
        return max(-most, min(most, -m * vx / tau))
    if drive != 0.0:
        target = drive * p[P_VTOP]
        if vx * target > 0.0 and abs(vx) > abs(target):  # faster than its wheels: coasts
            return -math.copysign(min(p[P_FDRAG], m * abs(vx) / tau), vx)
        most = p[P_FDRIVE] * abs(drive) + p[P_FDRAG]
        return max(-most, min(most, m * (target - vx) / tau))
    return -math.copysign(min(p[P_FDRAG], m * abs(vx) / tau), vx)


@nb.njit(cache=True, nogil=True, fastmath=True)
def _integrate(body, i, p, cos_d, sin_d, drive, brake, dt):
    """One step of car i's single-track body, its tyres as PyBullet's contacts are: the rear's push
    (within its friction), then each axle's sideways impulse that stops its wheels sliding sideways
    (a share dt / slip_tau of their slide each step: contacts that give a little), each within its
    friction times its load (the load moved by the last acceleration), along and across on their own."""
    m, iz, lf, lr, h, mu = p[P_MASS], p[P_IZ], p[P_LF], p[P_LR], p[P_H], p[P_MU]
    wheelbase = lf + lr
    vx, vy, r, ax = body[i, VX], body[i, VY], body[i, R], body[i, AX]
    load_f = max(0.0, m * (G_M_S2 * lr - ax * h) / wheelbase)
    load_r = max(0.0, m * (G_M_S2 * lf + ax * h) / wheelbase)
    fx = _motor_force(p, vx, drive, brake)
    sliding = abs(fx) > mu * load_r  # the rear wheels spin or lock: they slide, and hold less sideways
    fx = max(-mu * load_r, min(mu * load_r, fx))
    roll = -math.copysign(min(p[P_ROLL] + p[P_DAMP] * m * abs(vx), m * abs(vx) / dt), vx) if vx != 0.0 else 0.0
    vx_new = vx + ((fx + roll) / m + vy * r) * dt
    if vx != 0.0 and vx * vx_new < 0.0 and drive == 0.0:  # drag and brakes stop a car, never reverse it
        vx_new = 0.0
    vy -= vx * r * dt
    # the sideways slides at the front wheels (in their frame) and at the rear axle
    slide_f = -sin_d * vx_new + cos_d * (vy + lf * r)
    slide_r = vy - lr * r
    k11 = 1.0 / m + lf * lf * cos_d * cos_d / iz
    k12 = cos_d * (1.0 / m - lf * lr / iz)
    k22 = 1.0 / m + lr * lr / iz
    share = min(1.0, dt / p[P_SLIP])
    most_f = mu * load_f * dt
    most_r = mu * load_r * dt * (p[P_SLIDING] if sliding else 1.0)  # (along and across on their own, as Bullet's)
    det = k11 * k22 - k12 * k12
    pf = -share * (k22 * slide_f - k12 * slide_r) / det
    pr = -share * (k11 * slide_r - k12 * slide_f) / det
    if abs(pf) > most_f:  # the front slides: its friction's most, the rear's impulse again beside it
        pf = math.copysign(most_f, pf)
        pr = -(share * slide_r + k12 * pf) / k22
        pr = max(-most_r, min(most_r, pr))
    elif abs(pr) > most_r:  # the rear slides: likewise
        pr = math.copysign(most_r, pr)
        pf = -(share * slide_f + k12 * pr) / k11
        pf = max(-most_f, min(most_f, pf))
    vx_new -= sin_d * pf / m
    vy_new = vy + (cos_d * pf + pr) / m
    r_new = r + (lf * cos_d * pf - lr * pr) / iz
    yaw = body[i, YAW]
    c, s = math.cos(yaw), math.sin(yaw)
    body[i, X] += (vx_new * c - vy_new * s) * dt
    body[i, Y] += (vx_new * s + vy_new * c) * dt
    body[i, YAW] = _wrap(yaw + r_new * dt)
    body[i, AX] = (vx_new - vx) / dt - vy * r
    body[i, VX], body[i, VY], body[i, R] = vx_new, vy_new, r_new


@nb.njit(cache=True, nogil=True, parallel=True, fastmath=True)
def advance(wire, chunk_loops, loop_us, t_us, body, act, esc, ring, ring_at, params, track_of, pool, meta, mask,
            touching):
    """Car i's ESC, servo and body through wire's loops (uint16 [loops, n, 2]: the pulses on its wire
    after each board loop iteration) in physics steps of chunk_loops loops: at each step's end the
    frames that started are put in flight (latency), those due act, then the servo slews and the
    body moves (SUBSTEPS). touching[i]: car i met a wall (it stops where it was before). Only the
    cars whose mask[i] is set."""
    n = body.shape[0]
    steps = wire.shape[0] // chunk_loops
    dt = chunk_loops * loop_us * 1e-6
    for i in nb.prange(n):
        if not mask[i]:
            continue
        p = params[i]
        touching[i] = False
        for k in range(steps):
            last = (k + 1) * chunk_loops - 1
            t_us[i] += chunk_loops * loop_us
            th, st = wire[last, i, 0], wire[last, i, 1]
            head, count = ring_at[i, 0], ring_at[i, 1]
            for j in range(count):  # [us] each frame's time still to wait
                if ring[i, (head + j) % RING, 0] > -DONE_US:
                    ring[i, (head + j) % RING, 0] -= chunk_loops * loop_us
            # a frame whose pulses differ from the newest in flight goes in flight (the same pulses again act alike)
            newest = (head + count - 1) % RING
            if count == 0 or ring[i, newest, 1] != th or ring[i, newest, 2] != st:
                if count == RING:  # (never: RING frames span longer than the longest latency)
                    head, count = (head + 1) % RING, count - 1
                slot = (head + count) % RING
                ring[i, slot, 0] = int(round(p[P_LATENCY] * 1e6))
                ring[i, slot, 1] = th
                ring[i, slot, 2] = st
                count += 1
            while count > 0 and ring[i, head, 0] <= 0:
                if ring[i, head, 0] > -DONE_US:  # (pulses that already acted are kept as the newest)
                    _esc_pulse(esc, i, float(ring[i, head, 1]), p[P_DEADBAND], p[P_REVERSE], act)
                    _servo_pulse(act, i, float(ring[i, head, 2]), p[P_MAXSTEER], p[P_TRIM])
                if count == 1:  # the newest stays, marked as done, for the comparison above
                    ring[i, head, 0] = -DONE_US
                    break
                head, count = (head + 1) % RING, count - 1
            ring_at[i, 0], ring_at[i, 1] = head, count
            _servo_advance(act, i, dt, p[P_RATE], p[P_LAG])
            before_x, before_y, before_yaw = body[i, X], body[i, Y], body[i, YAW]
            steer = act[i, ANGLE]
            cos_d, sin_d = math.cos(steer), math.sin(steer)
            for _ in range(SUBSTEPS):
                _integrate(body, i, p, cos_d, sin_d, act[i, DRIVE], act[i, BRAKE], dt / SUBSTEPS)
            if track_of[i] >= 0:
                c, s = math.cos(body[i, YAW]), math.sin(body[i, YAW])
                bx, by = body[i, X] - p[P_BASE] * c, body[i, Y] - p[P_BASE] * s  # the base's origin
                if _touching(pool, meta, track_of[i], bx, by, body[i, YAW], p[P_REAR], p[P_FRONT],
                             p[P_HALFW]):
                    touching[i] = True
                    body[i, X], body[i, Y], body[i, YAW] = before_x, before_y, before_yaw
                    body[i, VX], body[i, VY], body[i, R], body[i, AX] = 0.0, 0.0, 0.0, 0.0


@nb.njit(cache=True, nogil=True, parallel=True, fastmath=True)
def scan(body, params, track_of, pool, meta, angles, turn, range_m, min_range_m, mask, out):
    """out[i, b]: car i's lidar beam b (angles [rad] from the car's heading, right to left, its
    mount turned by turn[i]) marched on its track's distance field: [m] to the first wall, or
    range_m; only the cars whose mask[i] is set."""
    n, beams = out.shape
    for i in nb.prange(n):
        if not mask[i]:
            continue
        p = params[i]
        yaw = body[i, YAW]
        c, s = math.cos(yaw), math.sin(yaw)
        ahead = p[P_LIDAR] - p[P_BASE]  # [m] from the centre of mass to the lidar
        ox, oy = body[i, X] + ahead * c, body[i, Y] + ahead * s
        k = track_of[i]
        x0, y0, res = meta[k, 0], meta[k, 1], meta[k, 2]
        nx, ny, start = int(meta[k, 3]), int(meta[k, 4]), int(meta[k, 5])
        for b in range(beams):
            a = yaw + turn[i] + angles[b]
            dx, dy = math.cos(a), math.sin(a)
            t = min_range_m
            hit = range_m
            last_d, last_step = 1e9, 0.0
            for _ in range(MARCH_STEPS):
                d = sdf_in(pool, x0, y0, res, nx, ny, start, ox + t * dx, oy + t * dy)  # (its track's grid read once)
                if last_step > last_d + d:  # the over-long step passed a wall: back to a plain one
                    t -= last_step - last_d
                    last_d, last_step = 1e9, last_d
                    continue
                if d < HIT_M:
                    if last_d < 1e9 and last_d > d:  # the wall's face between the last two samples (a secant)
                        t += d * last_step / (last_d - d)
                    else:
                        t += d
                    hit = max(min_range_m, min(range_m, t))
                    break
                last_step = OVERSTEP * d  # over-relaxed: the spheres of a beam along a wall overlap
                last_d = d
                t += last_step
                if t >= range_m:
                    break
            out[i, b] = hit


@nb.njit(cache=True, nogil=True, parallel=True, fastmath=True)
def project(xy, hint, line, arc, seg_len, line_at, track_of, window, s_out, cte_out, heading_out):
    """Each car's point xy[i] on its track's centre line (line: every track's points, track k's from
    line_at[k, 0], line_at[k, 1] of them; arc: each point's arc-length position [m]), searching
    `window` segments each side of hint[i] (updated): its position along [m], cross-track error
    (left +) [m] and the segment's heading [rad]."""
    for i in nb.prange(xy.shape[0]):
        k = track_of[i]
        start, n = line_at[k, 0], line_at[k, 1]
        px, py = xy[i, 0], xy[i, 1]
        best, seg, best_t, cross = 1e30, 0, 0.0, 0.0
        for j in range(hint[i] - window, hint[i] + window + 1):
            q = j % n
            a, b = start + q, start + (q + 1) % n
            ax, ay = line[a, 0], line[a, 1]
            dx, dy = line[b, 0] - ax, line[b, 1] - ay
            t = min(1.0, max(0.0, ((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)))
            ex, ey = ax + t * dx - px, ay + t * dy - py
            d2 = ex * ex + ey * ey
            if d2 < best:
                best, seg, best_t = d2, q, t
                cross = dx * (py - ay) - dy * (px - ax)
        hint[i] = seg
        a, b = start + seg, start + (seg + 1) % n
        s_out[i] = arc[a] + best_t * seg_len[a]
        cte_out[i] = math.copysign(math.sqrt(best), cross)
        heading_out[i] = math.atan2(line[b, 1] - line[a, 1], line[b, 0] - line[a, 0])
