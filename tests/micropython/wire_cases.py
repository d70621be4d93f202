# Runs under MicroPython (tests/wire/test_micropython.py): decode, encode and Junior query cases from
# /cases.json through the portable module; prints one JSON line with every answer.
import json

from roar_wire import control, junior

with open("/cases.json") as f:
    cases = json.load(f)


def answer(call, *args):
    try:
        return ["ok", call(*args)]
    except ValueError as e:
        return ["error", str(e)]


out = {
    "decode": [answer(control.decode, m.encode()) for m in cases["decode"]],
    "encode": [answer(lambda t, s: control.encode(t, s).decode(), t, s) for t, s in cases["encode"]],
    "queries": [list(junior.parse_query(q)) for q in cases["queries"]],
    "speeds": [junior.parse_unit_permille(s) for s in cases["speeds"]],
}
print(json.dumps(out))
