"""The simulated world the MicroPython board programs run in under the suite: one clock in
microseconds and a deterministic scheduler. `install()` puts the stand-ins of `time` and
`asyncio` in place (call it before importing board code); `machine`, `network` and `bluetooth`
are plain modules beside this one.

    import sim
    sim.install(start_us=...)
    ... import the board program, sim.spawn(its main()) ...
    sim.run_until(t_us)           # run every task due up to t_us, in time order

Runs on MicroPython (the WebAssembly runtime has no machine, network, bluetooth or sockets and
its asyncio is tied to JavaScript's event loop).
"""

import sys

TICKS_PERIOD = 1 << 30  # as MicroPython's ticks on an ESP32: ticks_ms() and ticks_us() wrap here


class CancelledError(BaseException):
    pass


class Wait:
    """What a task waits for, yielded to the scheduler: ("sleep", wake_us), ("io", stream),
    ("join", task, deadline_us or None), ("yield",)."""

    def __init__(self, what):
        self.what = what

    def __iter__(self):
        got = yield self.what
        return got

    __await__ = __iter__


class Task:
    def __init__(self, coro, name=""):
        self.coro, self.name = coro, name
        self.done = False
        self.value = None
        self.error = None
        self.token = 0  # bumped at each wake-up: stale wake-ups carry an old token
        self.joiners = []

    def cancel(self):
        if not self.done:
            _ready.append((self, self._wake_token(), None, CancelledError()))
            return True
        return False

    def _wake_token(self):
        self.token += 1
        return self.token

    def result(self):
        if self.error is not None:
            raise self.error
        return self.value


now_us = 0
current = None  # the task being stepped
_seq = 0
_ready = []  # (task, token, value, exception) to step now, in order
_timers = []  # (wake_us, seq, task, token), kept sorted
errors = []  # unhandled exceptions of tasks: (task name, repr)


def spawn(coro, name=""):
    task = Task(coro, name)
    _ready.append((task, task._wake_token(), None, None))
    return task


def _at(wake_us, task, token):
    global _seq
    _seq += 1
    entry = (wake_us, _seq, task, token)
    i = len(_timers)
    while i and _timers[i - 1][:2] > entry[:2]:
        i -= 1
    _timers.insert(i, entry)


def wake(task, value=None):
    """Make a waiting task runnable now with `value` as the result of its await."""
    _ready.append((task, task._wake_token(), value, None))


def _step(task, token, value, exc):
    global current
    if task.done or token != task.token:
        return
    current = task
    try:
        what = task.coro.throw(exc) if exc is not None else task.coro.send(value)
    except StopIteration as stop:
        _finish(task, stop.value if stop.args else None, None)
        return
    except CancelledError as e:
        _finish(task, None, e)
        return
    except Exception as e:  # noqa: BLE001 - recorded: the run fails on it
        errors.append((task.name, repr(e)))
        sys.print_exception(e)
        _finish(task, None, e)
        return
    finally:
        current = None
    kind = what[0]
    token = task._wake_token()
    if kind == "sleep":
        _at(max(what[1], now_us), task, token)
    elif kind == "io":
        what[1].waiters.append((task, token))
    elif kind == "join":
        other, deadline = what[1], what[2]
        if other.done:
            _ready.append((task, token, None, None))
        else:
            other.joiners.append((task, token))
            if deadline is not None:
                _at(deadline, task, token)
    else:  # "yield"
        _ready.append((task, token, None, None))


def _finish(task, value, error):
    task.done, task.value, task.error = True, value, error
    for joiner, token in task.joiners:
        _ready.append((joiner, token, None, None))
    task.joiners = []


def run_until(t_us):
    """Run every task that is due, in time order, up to t_us; the clock then reads t_us."""
    global now_us
    while True:
        while _ready:
            _step(*_ready.pop(0))
        if not _timers or _timers[0][0] > t_us:
            break
        wake_us, _, task, token = _timers.pop(0)
        now_us = max(now_us, wake_us)
        _ready.append((task, token, None, None))
    now_us = max(now_us, t_us)


def advance(us):
    """Time passing inside a task (a blocking sleep on the board)."""
    global now_us
    now_us += us


def install(start_us=0):
    """Put the stand-ins of time and asyncio in place; the clock starts at start_us."""
    global now_us
    now_us = start_us
    import sim_time
    import sim_asyncio

    sys.modules["time"] = sim_time
    sys.modules["asyncio"] = sim_asyncio
