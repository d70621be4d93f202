# Runs under MicroPython (tests/wire/test_micropython.py): every golden SBUS frame through the
# portable encoder, frame decoder and stream decoder; prints one JSON line {name: [ok, ...]}.
import binascii
import json

from roar_wire import sbus

with open("/sbus.json") as f:
    cases = json.load(f)["cases"]
out = {}
for case in cases:
    data = binascii.unhexlify(case["hex"])
    decoder = sbus.Decoder()
    results = [decoder.feed(b, i * 120) for i, b in enumerate(data)]
    out[case["name"]] = [sbus.encode(case["channels"], case["flags"], case["end"]) == data,
                         list(sbus.decode_frame(data)) == [case["channels"], case["flags"], case["end"]],
                         results[-1]]
print(json.dumps(out))
