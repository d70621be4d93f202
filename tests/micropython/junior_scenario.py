# Runs under MicroPython (tests/firmware/test_micropython_boards.py): the ROAR Junior's MicroPython
# program (firmware/micropython/junior) in the simulated world of hil_sim/micropython/standins,
# through a scenario from /scenario.json:
#   {"start_us": ..., "end_us": ..., "wall_cm": 100, "console": text typed before the reset,
#    "events": [[t_us, connection, "send" | "close" | "type", text], ...]}
# An HC-SR04 answers every trigger pulse with the echo of a wall at wall_cm. Prints one JSON
# line: every reply (by event), the L298N pins the loop wrote at each millisecond tick (as
# changes; also checked against the pins' stand-ins), the console's lines, the key file, the
# watchdog's longest gap, the peak heap.
import json
from binascii import hexlify

import sim

with open("/scenario.json") as f:
    scenario = json.load(f)
sim.install(scenario["start_us"])

import machine  # noqa: E402 (after the stand-ins are in place)
import sim_asyncio  # noqa: E402

import config  # noqa: E402
import junior_app  # noqa: E402

ECHO_DELAY_US = 450  # [us] from the trigger's falling edge to the echo's start (the HC-SR04's burst)
echo_width_us = scenario["wall_cm"] * 20000 // 343 + 1


async def echo():
    await sim_asyncio.sleep(ECHO_DELAY_US / 1e6)
    machine.pins[config.ULTRASONIC_ECHO].drive(1)
    await sim.Wait(("sleep", sim.now_us + echo_width_us))
    machine.pins[config.ULTRASONIC_ECHO].drive(0)


def on_output(pin, value):
    if pin == config.ULTRASONIC_TRIGGER and value == 0:
        sim.spawn(echo(), "echo")


typed = [scenario.get("console", "").encode()]  # typed on the console before the reset
console_out = []  # [t us, line]


class TestConsole:
    def read(self, n):
        data, typed[0] = typed[0][:n], typed[0][n:]
        return data

    def write(self, text):
        console_out.append([sim.now_us, text])


machine.on_output = on_output
junior_app.Console = TestConsole
sim.spawn(junior_app.main(), "main")

OUT_PINS = [config.LEFT_IN1, config.LEFT_IN2, config.RIGHT_IN1, config.RIGHT_IN2]
EN_PINS = [config.ENABLE_LEFT, config.ENABLE_RIGHT]


def hardware():
    """The L298N inputs as the pins' stand-ins hold them: [[in1, in2, duty permille], ...]."""
    p, w = machine.pins, machine.pwms
    duty = [(w[e].duty_u16() * 1000 + 32767) // 65535 for e in EN_PINS]
    v = [p[i].value() for i in OUT_PINS]
    return [[v[0], v[1], duty[0]], [v[2], v[3], duty[1]]]


changes = []  # [tick us, pins] each time the loop's pins change
_write = junior_app.Motors.write


def write(self, pins):
    _write(self, pins)
    pins = [[int(a), int(b), d] for a, b, d in pins]
    tick = sim.now_us // 1000 * 1000  # the tick this poll belongs to (the loop may run a little late)
    if changes and changes[-1][0] == tick:
        changes.pop()  # a late tick's catch-up poll: the later one stands
    if not changes or changes[-1][1] != pins:
        changes.append([tick, pins])
    assert hardware() == pins, (hardware(), pins)


junior_app.Motors.write = write

events = scenario["events"]
clients = {}
replies = []


def run():
    for i, (at, conn, action, text) in enumerate(events):
        sim.run_until(at)
        if action == "type":  # on the console, after the window: nobody reads it any more
            typed[0] += text.encode()
            continue
        if action == "send":
            if conn not in clients:
                clients[conn] = sim_asyncio.connect(81)
            clients[conn].send(text.encode())
        else:
            clients.pop(conn).close()
        sim.run_until(at)
        replies.append([i, clients[conn].take().decode() if conn in clients else ""])
        yield  # the runner collects garbage between steps
    sim.run_until(scenario["end_us"])


roar_steps = run()


def roar_finish(first, peak):
    wdt = machine.watchdogs[0] if machine.watchdogs else None
    try:
        with open(config.KEY_FILE, "rb") as f:
            key_file = hexlify(f.read()).decode()
    except OSError:
        key_file = None
    print(json.dumps({"replies": replies, "changes": changes, "errors": sim.errors, "console": console_out,
                      "key_file": key_file,
                      "watchdog_gap_us": wdt.longest_gap_us if wdt else None,
                      "watchdog_timeout_ms": wdt.timeout_ms if wdt else None, "peak_heap": peak}))
