# Runs under MicroPython (tests/sim/test_platoon.py): V2V datagrams from /cases.json decoded, and
# messages encoded, through the portable module; prints one JSON line with every answer.
import json

from roar_wire import v2v

with open("/cases.json") as f:
    cases = json.load(f)


def encoded(args):
    try:
        return ["ok", v2v.encode(*args).decode()]
    except ValueError:
        return ["error"]


out = {
    "decode": [v2v.decode(d.encode()) for d in cases["decode"]],
    "encode": [encoded(a) for a in cases["encode"]],
}
print(json.dumps(out))
