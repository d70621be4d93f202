# What the portable protocol package (roar_wire) answers for a fuzz input: written once, in the
# Python both CPython and MicroPython run, so the differential runner (fuzz/differential.py)
# asks the same questions of the C++ core, CPython and MicroPython. Run as a MicroPython
# program, it reads /inputs.json ({"control"|"sbus"|"junior"|"http": [hex, ...]}) and prints one
# JSON line of the answers. The Junior's HTTP side is the MicroPython board's own library
# (firmware/micropython/lib/roar_junior.py, the twin of the core's reader and board).
import json

from roar_wire import control, junior, sbus, signing

# The signed golden vectors' key and session (protocol/vectors/signed_messages.json), so that
# their messages in the corpus pass and the authenticator's every verdict is reached.
SIGNING_KEY = bytes(range(16))
SIGNING_SESSION = 0x2A


def control_events(data):
    """[at, result, a, b, counter, mac, verdict] per message event: a, b = throttle, steering
    (ok) or speed, steering (setpoint), counter and mac those of a signed message, verdict a
    keyed authenticator's; else None."""
    p, out = control.Parser(), []
    auth = signing.Authenticator()
    auth.set_key(SIGNING_KEY, SIGNING_SESSION)
    for at in range(len(data)):
        r = p.feed(data[at])
        if r == control.OK or r == control.SETPOINT:
            a, b = (p.throttle_us, p.steering_us) if r == control.OK else (p.speed_mm_s, p.setpoint_steering_us)
            counter, mac = p.signature if p.signature else (None, None)
            out.append([at, r, a, b, counter, mac, auth.check(r, p)])
        elif r != control.NONE:
            out.append([at, r, None, None, None, None, None])
    return out


def sbus_trace(data):
    """The decoder on (pause / 25 us, byte) pairs: [i, result, channels, flags, end] per byte
    that finished something (the frame's fields for a good frame, else None), then the counters
    [good, lost, failsafe, dropped, locked, last_good_us]."""
    d, now, out = sbus.Decoder(), 1000, []
    for i in range(0, len(data) - 1, 2):
        now += 25 * data[i]
        r = d.feed(data[i + 1], now)
        if r == sbus.FRAME:
            out.append([i, r, list(d.channels), d.flags, d.end])
        elif r != sbus.NONE:
            out.append([i, r, None, None, None])
    out.append([d.good_frames, d.lost_frames, d.failsafe_frames, d.dropped, 1 if d.locked else 0, d.last_good_us])
    return out


REASONS = {junior.UNKNOWN_NAME: 1, junior.BAD_FLAG: 2, junior.BAD_SPEED: 3}  # the core's JuniorQueryError codes


def junior_answer(data):
    """[parameters applied, 0] or [0, the refusal's code] for a query's bytes (one char each)."""
    actions, reason = junior.parse_query("".join(chr(b) for b in data))
    if reason is None:
        return [len(actions), 0]
    return [0, REASONS[reason.split(":")[0]]]


DISTANCE_CM = 42  # what the ultrasonic ranger reads in every reply


JUNIOR_SESSION = 1  # the session of a board whose key was just set (blank memory before)


def http_exchange(data):
    """One connection's bytes, request by request, to a board without a key and to one with
    SIGNING_KEY: for each, [bytes taken, reader state, the reply (hex), kept open] per decided
    request, until the bytes run out or the board closes."""
    return [_http_exchange(data, False), _http_exchange(data, True)]


def _http_exchange(data, keyed):
    import roar_junior

    board, out, at = roar_junior.JuniorBoard(), [], 0
    if keyed:
        board.auth.set_key(SIGNING_KEY, JUNIOR_SESSION)
    while at < len(data):
        reader = roar_junior.HttpRequestReader()
        used, state = reader.feed(data[at:])
        at += used
        if state == roar_junior.INCOMPLETE:
            break
        reply, keep = board.respond(reader, DISTANCE_CM, 0)
        out.append([used, state, reply.hex(), 1 if keep else 0])
        if not keep or used == 0:
            break
    return out


ANSWERS = {"control": control_events, "sbus": sbus_trace, "junior": junior_answer, "http": http_exchange}


def answer_all(inputs):
    return {kind: [ANSWERS[kind](bytes.fromhex(h)) for h in items] for kind, items in inputs.items()}


def main():
    with open("/inputs.json") as f:
        print(json.dumps(answer_all(json.load(f))))


if __name__ == "__main__":
    main()
