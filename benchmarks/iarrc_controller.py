"""The IARRC controller: the simulated car's 0 -> 2 m/s speed step against the seed's figures;
the task table on the host scheduler at its declared costs (CPU share, the control loop's period
jitter, each task's worst response); and each task body's cost on a Cortex-M4 (QEMU -icount)."""

import random
import time

from roar_sim.emulators import qemu

from roar_sim.toolchains import arm
from roar_sim.core.iarrc import iarrc_tasks
from roar_sim.core.rtos import Scheduler
from roar_sim.runs.step_response import measure

TITLE = "IARRC controller: speed step, task schedule, task costs"
SCHEDULE_S = 10.0  # [s] simulated
BOARD_HZ = 16e6  # [Hz] the AnyFC F7 glue's clock


def run() -> None:
    start = time.perf_counter()
    r = measure(2.0, 3.0)
    wall = time.perf_counter() - start
    print(f"  step: {r.summary()}")
    print(f"        {'targets met' if r.meets_targets() else 'targets NOT met'}; "
          f"{(len(r.times_s) * 0.005 + 0.4) / wall:.1f}x real time with the tasks on the host scheduler")

    tasks = iarrc_tasks()
    s = Scheduler(tasks, lambda i, t: None)
    s.run_until(int(SCHEDULE_S * 1e6))
    control = next(i for i, t in enumerate(tasks) if t.name == "control")
    jitter = s.stats[control].period_jitter_us(tasks[control].period_us)
    print(f"  schedule ({SCHEDULE_S:g} s at the declared costs): CPU {s.busy_us / (SCHEDULE_S * 1e6):.1%}, "
          f"control period jitter {jitter} us of {tasks[control].period_us} us, "
          f"missed releases {sum(st.missed for st in s.stats)}")
    rng = random.Random(1)
    varied = Scheduler(tasks, lambda i, t: None, cost=lambda i, n: rng.randint(tasks[i].cost_us // 4, tasks[i].cost_us))
    varied.run_until(int(SCHEDULE_S * 1e6))
    print(f"    with each job taking 25-100 % of its cost (seeded): control period jitter "
          f"{varied.stats[control].period_jitter_us(tasks[control].period_us)} us")
    print("    task       period  prio  cost   worst response")
    for t, st in zip(tasks, s.stats):
        print(f"    {t.name:<10} {t.period_us / 1000:5.0f} ms {t.priority:4d} {t.cost_us:4d} us {st.max_response_us:6d} us")

    missing = qemu.available()
    if missing:
        print(f"  Cortex-M4 task costs: skipped ({missing})")
        return
    result = qemu.run(arm.build_task_bench())
    measured = qemu.task_instructions(result)
    print("  Cortex-M4 task bodies at their worst input (QEMU -icount):")
    for t in tasks:
        n = measured[t.name]
        print(f"    {t.name:<10} {n:7,.0f} instructions = {n / BOARD_HZ * 1e6:5.0f} us at 16 MHz "
              f"(declared {t.cost_us} us)")
