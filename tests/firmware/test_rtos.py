"""The IARRC car's task table on the host scheduler (FreeRTOS's rules in simulated time): the RC
task pre-empts everything, no deadline is missed at the declared costs, equal priorities share the
CPU round-robin, and an overrunning task is counted, starves only the tasks below it, and stops
the watchdog when it is the RC task."""

import random
from dataclasses import dataclass

import pytest

from roar_sim.core.iarrc import IarrcBoard, TaskSpec, iarrc_tasks
from roar_sim.core.rtos import Scheduler

TASKS = iarrc_tasks()
NAMES = [t.name for t in TASKS]
RC, CONTROL, BATTERY = NAMES.index("rc"), NAMES.index("control"), NAMES.index("battery")


@dataclass(frozen=True)
class Task:
    period_us: int
    priority: int
    cost_us: int


def run(tasks, seconds, cost=None, log=None, overran=None):
    calls = [] if log is None else log
    s = Scheduler(tasks, lambda i, t: calls.append((i, t)), cost=cost, overran=overran)
    s.run_until(int(seconds * 1e6))
    return s


def test_the_task_table_is_the_seeds_priority_order():
    by_priority = sorted(TASKS, key=lambda t: -t.priority)
    assert by_priority[0].name == "rc" and by_priority[-1].name == "battery"
    assert {t.name for t in TASKS} == {"rc", "control", "host", "gyro", "telemetry", "battery"}
    assert TASKS[NAMES.index("gyro")].priority == TASKS[NAMES.index("telemetry")].priority  # round-robin pair
    assert all(t.cost_us < t.period_us and t.stack_words >= 128 for t in TASKS)


def test_no_deadline_is_missed_at_the_declared_costs():
    s = run(TASKS, 10.0)
    for task, st in zip(TASKS, s.stats):
        assert st.missed == 0 and st.deadline_misses == 0, task.name
        assert st.completed == st.releases == 10_000_000 // task.period_us, task.name
        assert st.max_response_us <= task.period_us
    assert s.stats[RC].max_latency_us == 0  # the RC task never waits
    assert 0 < s.busy_us / 10e6 == pytest.approx(s.utilisation(), rel=1e-3)


def test_the_rc_task_preempts_a_long_job_at_every_release():
    # A battery job of 9 ms: the RC task still starts exactly at each 2 ms release, inside it.
    costs = lambda i, n: 9_000 if i == BATTERY else TASKS[i].cost_us  # noqa: E731
    log = []
    s = run(TASKS, 1.0, cost=costs, log=log)
    rc_starts = [t for i, t in log if i == RC]
    assert rc_starts == list(range(0, 1_000_000, 2_000))
    battery_start = next(t for i, t in log if i == BATTERY)
    assert any(battery_start < t < battery_start + 9_000 for t in rc_starts)  # pre-empted, then resumed
    assert s.stats[BATTERY].max_response_us > 9_000 + 4 * TASKS[RC].cost_us
    assert s.stats[BATTERY].completed == 2 and s.stats[BATTERY].deadline_misses == 0


def test_equal_priorities_share_the_cpu_at_each_tick():
    log = []
    s = run([Task(10_000, 2, 4_000), Task(10_000, 2, 4_000)], 0.01, log=log)
    assert log == [(0, 0), (1, 1_000)]  # the second starts one tick in, before the first is done
    assert s.stats[0].max_response_us == 7_000 and s.stats[1].max_response_us == 8_000


def test_an_overrunning_task_runs_again_at_once_and_starves_only_lower_ones():
    overruns = []
    costs = lambda i, n: 25_000 if i == CONTROL and n == 3 else TASKS[i].cost_us  # noqa: E731
    log = []
    s = run(TASKS, 1.0, cost=costs, log=log, overran=lambda i, missed: overruns.append((i, missed)))
    control_starts = [t for i, t in log if i == CONTROL]
    # Job 3 is released at 30 ms and needs 25 ms of CPU besides the RC task's share: every release
    # that passes before it ends is missed, and it runs again at once when it ends ...
    end = control_starts[4]
    assert end - control_starts[3] > 25_000  # pre-empted by the RC task on the way
    missed = (end - 30_000) // 10_000
    assert missed >= 2 and overruns[0] == (CONTROL, missed)
    assert s.stats[CONTROL].missed == missed and s.stats[CONTROL].deadline_misses == 1
    # The tasks below it waited all that time, and lost releases too; none above it did.
    assert {i for i, _ in overruns[1:]} == {NAMES.index("host"), NAMES.index("gyro")}
    assert control_starts[5] - end == 10_000  # ... then keeps its period from there
    assert s.stats[RC].deadline_misses == 0 and s.stats[RC].max_latency_us == 0
    assert s.stats[NAMES.index("host")].max_latency_us > 20_000  # below it: held back while it ran


def test_the_board_counts_overruns_in_telemetry_and_only_a_live_rc_task_feeds_the_watchdog():
    board = IarrcBoard()
    board.begin()
    stuck = {"rc": False}

    def cost(i, n):
        return 5_000 if i == RC and stuck["rc"] else TASKS[i].cost_us

    s = Scheduler(TASKS, board.run, cost=cost, overran=board.overran)
    s.run_until(1_000_000)
    feeds = board.watchdog_feeds
    assert feeds == 100 and board.overruns == 0  # every control run found the RC task alive
    stuck["rc"] = True  # the RC task now takes 5 ms every 2 ms: it runs back to back
    s.run_until(2_000_000)
    assert board.overruns > 100
    assert board.watchdog_feeds == feeds  # the control task never runs: nothing feeds the watchdog
    tel = [line for line in board.link_out.decode().splitlines() if line.startswith("TEL")]
    assert tel and tel[-1].split()[-1] == "0"  # the telemetry task is starved too; its last line predates it


def test_the_same_inputs_give_the_same_schedule():
    a, b = [], []
    costs = lambda i, n: (TASKS[i].cost_us * (n % 7 + 1)) // 2  # noqa: E731
    run(TASKS, 2.0, cost=costs, log=a)
    run(TASKS, 2.0, cost=costs, log=b)
    assert a == b and len(a) > 1000


def test_control_period_jitter_is_bounded_by_the_rc_task_whatever_the_costs_up_to_the_declared():
    rng = random.Random(7)
    s = run(TASKS, 5.0, cost=lambda i, n: rng.randint(TASKS[i].cost_us // 4, TASKS[i].cost_us))
    jitter = s.stats[CONTROL].period_jitter_us(TASKS[CONTROL].period_us)
    assert 0 < jitter <= TASKS[RC].cost_us  # only the RC task ever delays it
    assert all(st.missed == 0 for st in s.stats)


def test_a_table_row_is_a_taskspec():
    assert isinstance(TASKS[0], TaskSpec)
