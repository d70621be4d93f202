"""A deterministic fixed-priority pre-emptive scheduler in simulated time: what FreeRTOS does with
a board's task table, on the host, for the simulator and the tests.

The rules are FreeRTOS's, as the board glue uses them:
- each task is released every period (vTaskDelayUntil), from time 0;
- the highest-priority ready job runs; a release of a higher-priority task pre-empts it at once;
- ready jobs of equal priority share the CPU round-robin, switching at each tick (time slicing);
- a job takes its cost of CPU time; its body runs when it starts (it reads its inputs then),
  and what it writes is there from then on;
- a task still running when its next release comes has overrun: the releases that pass are
  counted as missed, and when the job ends the task runs again at once and keeps its period from
  there (the glue's answer to vTaskDelayUntil returning pdFALSE).
Everything is integer microseconds, so a run is exactly repeatable.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

TICK_US = 1_000  # [us] FreeRTOS tick (configTICK_RATE_HZ 1000): the round-robin time slice


@dataclass
class TaskStats:
    releases: int = 0  # jobs released
    completed: int = 0
    missed: int = 0  # releases that passed while the task was still running (overruns)
    deadline_misses: int = 0  # jobs that ended after their next release was due
    max_response_us: int = 0  # [us] release to end, worst
    max_latency_us: int = 0  # [us] release to start, worst
    starts_us: list[int] = field(default_factory=list)  # [us] when each job started

    def period_jitter_us(self, period_us: int) -> int:
        """[us] the largest deviation of the time between two starts from the period."""
        gaps = [b - a for a, b in zip(self.starts_us, self.starts_us[1:])]
        return max((abs(g - period_us) for g in gaps), default=0)


@dataclass
class _Job:
    task: int
    release_us: int
    remaining_us: int
    started: bool = False
    missed: int = 0


class Scheduler:
    """Runs `tasks` (objects with period_us, priority, cost_us) in simulated time. body(i, now_us)
    runs task i's body when a job of it starts; cost(i, job_number) gives that job's CPU time
    (default: the declared cost_us); overran(i, missed) is told when a job that overran ends."""

    def __init__(self, tasks: Sequence, body: Callable[[int, int], None],
                 cost: Callable[[int, int], int] | None = None,
                 overran: Callable[[int, int], None] | None = None, tick_us: int = TICK_US,
                 keep_starts: bool = True) -> None:
        self.tasks = list(tasks)
        self._body, self._overran, self.tick_us = body, overran, tick_us
        self._cost = cost or (lambda i, n: self.tasks[i].cost_us)
        self.keep_starts = keep_starts
        self.now_us = 0
        self.stats = [TaskStats() for _ in self.tasks]
        self._next_release = [0] * len(self.tasks)
        self._jobs: list[_Job | None] = [None] * len(self.tasks)
        self._ready: list[int] = []  # tasks with a job, in round-robin order within a priority
        self.busy_us = 0  # [us] CPU time spent in jobs

    def _release_due(self) -> None:
        for i, task in enumerate(self.tasks):
            while self._next_release[i] <= self.now_us:
                job = self._jobs[i]
                if job is not None:  # still running: this release passes
                    job.missed += 1
                    self.stats[i].missed += 1
                else:
                    self._start_job(i, self._next_release[i])
                self._next_release[i] += task.period_us

    def _start_job(self, i: int, release_us: int) -> None:
        st = self.stats[i]
        self._jobs[i] = _Job(i, release_us, max(0, self._cost(i, st.releases)))
        st.releases += 1
        self._ready.append(i)

    def _pick(self) -> _Job | None:
        if not self._ready:
            return None
        best = max(self.tasks[i].priority for i in self._ready)
        return self._jobs[next(i for i in self._ready if self.tasks[i].priority == best)]

    def run_until(self, end_us: int) -> None:
        """Advance simulated time to end_us, running every job due on the way."""
        while self.now_us < end_us:
            self._release_due()
            job = self._pick()
            next_release = min(self._next_release)
            if job is None:  # idle until the next release
                self.now_us = min(end_us, next_release)
                continue
            i = job.task
            st = self.stats[i]
            if not job.started:
                job.started = True
                st.max_latency_us = max(st.max_latency_us, self.now_us - job.release_us)
                if self.keep_starts:
                    st.starts_us.append(self.now_us)
                self._body(i, self.now_us)
            same_level = sum(1 for k in self._ready if self.tasks[k].priority == self.tasks[i].priority)
            slice_end = (self.now_us // self.tick_us + 1) * self.tick_us if same_level > 1 else end_us
            until = min(self.now_us + job.remaining_us, next_release, slice_end, end_us)
            self.busy_us += until - self.now_us
            job.remaining_us -= until - self.now_us
            self.now_us = until
            if job.remaining_us == 0:
                self._finish(job)
            elif until == slice_end and same_level > 1:  # time slice over: the next one of its level runs
                self._ready.remove(i)
                self._ready.append(i)

    def _finish(self, job: _Job) -> None:
        i = job.task
        st = self.stats[i]
        self._jobs[i] = None
        self._ready.remove(i)
        st.completed += 1
        response = self.now_us - job.release_us
        st.max_response_us = max(st.max_response_us, response)
        if response > self.tasks[i].period_us:
            st.deadline_misses += 1
        if job.missed:
            if self._overran is not None:
                self._overran(i, job.missed)
            self._start_job(i, self.now_us)  # runs again at once, its period counted from now
            self._next_release[i] = self.now_us + self.tasks[i].period_us

    def utilisation(self) -> float:
        """Declared CPU share of the task table."""
        return sum(t.cost_us / t.period_us for t in self.tasks)
