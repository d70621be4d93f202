# Runs under MicroPython (tests/firmware/test_micropython_boards.py): the ESP32-CAM car's MicroPython
# program (firmware/micropython/car) in the simulated world of hil_sim/micropython/standins,
# through a scenario from /scenario.json:
#   {"start_us": ..., "end_us": ..., "events": [[t_us, "write" | "serial" | "connect" | "disconnect", text], ...]}
# "write" is a BLE write to the control characteristic, "serial" bytes typed on the console;
# "connect" with text "paired" pairs. "key_file" (hex): what /roar_key.bin holds at the start.
# Prints one JSON line: the pulses the loop decided at each millisecond tick (as changes;
# checked against the PWM stand-ins), every reply line with its tick, what the radio advertised
# and holds, the key file, the watchdog, the peak heap.
import json
from binascii import hexlify

import sim

with open("/scenario.json") as f:
    scenario = json.load(f)
sim.install(scenario["start_us"])
if scenario.get("key_file"):  # the key a previous run left
    from binascii import unhexlify

    with open("/roar_key.bin", "wb") as f:
        f.write(unhexlify(scenario["key_file"]))

import bluetooth  # noqa: E402 (after the stand-ins are in place)
import machine  # noqa: E402

import car_app  # noqa: E402
import config  # noqa: E402
from roar_wire import spec  # noqa: E402

CONTROL_UUID = spec.BLE_CONTROL_UUID
replies = []  # [tick us, line]


typed = [b""]  # console bytes the loop has not read yet


class TestConsole:
    def read(self, n):
        data, typed[0] = typed[0][:n], typed[0][n:]
        return data

    def write(self, text):
        replies.append([sim.now_us // 1000 * 1000, text])


changes = []  # [tick us, [throttle, steering]]
_poll = car_app.CarBoard.poll


def poll(self):
    pulses = list(_poll(self))
    tick = sim.now_us // 1000 * 1000
    if changes and changes[-1][0] == tick:
        changes.pop()
    if not changes or changes[-1][1] != pulses:
        changes.append([tick, pulses])
    hw = [machine.pwms[config.THROTTLE_PIN].duty_ns() // 1000, machine.pwms[config.STEERING_PIN].duty_ns() // 1000]
    assert hw == pulses, (hw, pulses)
    return pulses


car_app.CarBoard.poll = poll
car_app.Console = TestConsole
sim.spawn(car_app.main(), "main")


def run():
    for at, action, text in scenario["events"]:
        sim.run_until(at)
        radio = bluetooth.radio
        if action == "write":
            radio.central_write(CONTROL_UUID, text.encode())
        elif action == "serial":
            typed[0] += text.encode()
        elif action == "connect":
            radio.central_connect(paired=text == "paired")
        else:
            radio.central_disconnect()
        yield  # the runner collects garbage between steps
    sim.run_until(scenario["end_us"])


roar_steps = run()


def roar_finish(first, peak):
    radio = bluetooth.radio
    wdt = machine.watchdogs[0] if machine.watchdogs else None
    try:
        with open(config.KEY_FILE, "rb") as f:
            key_file = hexlify(f.read()).decode()
    except OSError:
        key_file = None
    print(json.dumps({"changes": changes, "replies": replies, "errors": sim.errors,
                      "advertising": [[t, i, hexlify(a).decode(), hexlify(r).decode()] for t, i, a, r in radio.advertising],
                      "state": hexlify(radio.central_read(spec.BLE_STATE_UUID)).decode(),
                      "velocity": hexlify(radio.central_read(spec.BLE_VELOCITY_UUID)).decode(),
                      "session": hexlify(radio.central_read(spec.BLE_SESSION_UUID)).decode(), "key_file": key_file,
                      "control_flags": radio.flags[radio.handles[CONTROL_UUID.lower()]],
                      "ble_settings": radio.settings, "dropped_writes": radio.dropped,
                      "led": machine.pins[config.STATUS_LED_PIN].value(),
                      "watchdog_gap_us": wdt.longest_gap_us if wdt else None,
                      "watchdog_timeout_ms": wdt.timeout_ms if wdt else None, "peak_heap": peak}))
