# Runs under MicroPython (tests/wire/test_micropython.py): every golden vector through the portable
# parser; prints one JSON line {case name: [[at, token, throttle, steering], ...]}.
import json

from roar_wire import control

with open("/vectors.json") as f:
    cases = json.load(f)["cases"]
out = {}
for case in cases:
    parser = control.Parser()
    got, at = [], 0
    for chunk in case["chunks"]:
        for ch in chunk:
            result = parser.feed(ord(ch))
            if result == control.OK:
                got.append([at, "ok", parser.throttle_us, parser.steering_us])
            elif result == control.SETPOINT:
                got.append([at, "setpoint", parser.speed_mm_s, parser.setpoint_steering_us])
            elif result != control.NONE:
                got.append([at, control.token(result), None, None])
            at += 1
    out[case["name"]] = got
print(json.dumps(out))
