"""The real firmware on the emulated ATmega328P (simavr; cycle counts are deterministic):
CPU cycles per control message "(1500,1500)" parsed by the core's ControlParser, beside a plain
single-pass reference parser measured in the same run (target: <= 330 cycles), the whole
receive path, and the latency from the last byte of a new command to the first output pulse
that carries it. (The same image's fourth run, the SBUS decoder, is reported by sbus_decode.)"""

import statistics

from roar.protocol import encode, spec

TITLE = "Nano firmware in the AVR emulator (ATmega328P, 16 MHz)"
TRIALS = 60
BITS_PER_BYTE = 10  # 8N1
PARSER_TARGET = 330  # [cycles per message]


def run() -> None:
    from roar_sim.emulators import simavr
    from roar_sim.toolchains import avr

    missing = simavr.available()
    if missing:
        print(f"  skipped: {missing}")
        return
    parser_cycles, plain_cycles, car_cycles = (w for _, w in simavr.parser_bench_pulses(0.2)[:3])
    per_parser, per_plain, per_car = (c / avr.BENCH_MESSAGES for c in (parser_cycles, plain_cycles, car_cycles))
    message_bytes = len(encode(1500, 1500))
    line_cycles = message_bytes * BITS_PER_BYTE / spec.SERIAL_BAUD * simavr.F_CPU  # one message on the wire
    verdict = "ok" if per_parser <= PARSER_TARGET else "OVER TARGET"
    print(f"  cycles per message: core parser {per_parser:,.0f} (target <= {PARSER_TARGET}, {verdict}); "
          f"plain single-pass reference {per_plain:,.0f}; ratio {per_parser / per_plain:.2f}")
    print(f"  whole receive path (parser + failsafe + replies): {per_car:,.0f} cycles per message")
    print(f"  share of the CPU at full {spec.SERIAL_BAUD}-baud line rate: parser {per_parser / line_cycles:.3f}, "
          f"receive path {per_car / line_cycles:.3f}")

    latencies = []
    with simavr.EmulatedNano() as nano:
        nano.run(0.05)
        nano.write(encode(1500, 1500) + b"\n")
        nano.run(0.1)
        for i in range(TRIALS):
            nano.run(0.0013 * (i % 16))  # spread the arrivals over the 20 ms frame
            width = 1600 + 50 * (i % 2)
            nano.write(encode(width, 1500) + b"\n")
            sent = len(nano.sent_at)
            nano.run(0.05)
            arrived = nano.sent_at[sent]  # the cycle this command's last byte entered the UART
            first = next(r for r, w in nano.pulse_cycles("D5") if r > arrived and abs(w / 16 - width) < 10)
            latencies.append((first - arrived) / simavr.CYCLES_PER_US / 1000)
    frame_ms = spec.TIMING_SERVO_FRAME_US / 1000
    print(f"  command byte -> new pulse: p50 {statistics.median(latencies):.1f} ms, max {max(latencies):.1f} ms "
          f"({TRIALS} commands at spread phases); max / frame period {max(latencies) / frame_ms:.2f}")
