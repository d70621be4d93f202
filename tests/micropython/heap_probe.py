# Runs under MicroPython (tests/firmware/test_micropython_boards.py, make bench): one board program
# ("board" in /scenario.json) driven for "seconds" of simulated time the way a host drives it
# (the Junior: a control request every 20 ms on a kept connection; the car: a BLE control write
# every 20 ms). It runs in steps of 20 ms (hil_sim/micropython/run.mjs collects garbage and
# measures the heap between steps). Prints one JSON line: the heap in use before the program
# was imported, and the most the program added to it [bytes].
import json

import sim

with open("/scenario.json") as f:
    scenario = json.load(f)
board = scenario["board"]
sim.install(1000000)
import bluetooth  # noqa: E402 (the stand-ins, in the heap before the program is)
import machine  # noqa: E402,F401
import network  # noqa: E402,F401
import sim_asyncio  # noqa: E402
from roar_wire import spec  # noqa: E402

REQUEST = b"GET /?forward=True&left_spd=0.5&right_spd=0.5 HTTP/1.1\r\nHost: junior\r\n\r\n"


class QuietConsole:
    def read(self, n):
        return b""

    def write(self, text):
        pass


def run():
    yield  # the heap before the program
    if board == "junior":
        import junior_app as app
    else:
        import car_app as app
    app.Console = QuietConsole
    sim.spawn(app.main(), "main")
    for _ in range(160):  # the Junior's boot grace, Wi-Fi, server up
        sim.run_until(sim.now_us + 20000)
        yield
    client = sim_asyncio.connect(81) if board == "junior" else None
    if board == "car":
        bluetooth.radio.central_connect()
    for i in range(int(scenario["seconds"] * 50)):
        if client:
            client.send(REQUEST)
        else:
            bluetooth.radio.central_write(spec.BLE_CONTROL_UUID, b"(%d,1500)" % (1500 + i % 40 * 10))
        sim.run_until(sim.now_us + 20000)
        if client:
            client.take()
        yield


roar_steps = run()


def roar_finish(first, peak):
    print(json.dumps({"baseline": first, "peak": peak - first, "errors": sim.errors}))
