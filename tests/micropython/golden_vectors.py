# Runs under MicroPython (tests/test_micropython.py): every golden vector through the portable
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
            if result != control.NONE:
                ok = result == control.OK
                got.append([at, control.token(result), parser.throttle_us if ok else None,
                            parser.steering_us if ok else None])
            at += 1
    out[case["name"]] = got
print(json.dumps(out))
