"""Two cars in one world (each its own firmware core at 1 kHz, one physics world at 200 Hz):
simulated seconds per wall second while both drive (target >= 15x real time), beside one car."""

import time

TITLE = "Two cars in one world"
SECONDS = 10.0  # [s] simulated


def run() -> None:
    from roar.protocol import encode
    from roar_sim.runs.fleet import Fleet
    from roar.tracks import get

    rates = {}
    for count in (1, 2):
        with Fleet(get("oval"), count=count, gap_m=2.0) as fleet:
            for car in fleet.cars:
                car.write(encode(1500, 1500))
            fleet.run(0.1)
            start = time.perf_counter()
            for _ in range(round(SECONDS / 0.02)):
                for car in fleet.cars:
                    car.write(encode(1560, 1500))
                fleet.run(0.02)
            rates[count] = SECONDS / (time.perf_counter() - start)
    print(f"  one car {rates[1]:.0f}x real time; two cars {rates[2]:.0f}x real time (target >= 15)")
