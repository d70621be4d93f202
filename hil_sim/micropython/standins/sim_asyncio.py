"""`asyncio` for board programs under the suite: MicroPython's asyncio API (the part the boards
use) on the simulated clock and scheduler of sim.py, with TCP servers whose clients are the
test program's Client objects.

    server = await asyncio.start_server(handler, "0.0.0.0", 81)
    client = sim_asyncio.connect(81)       # the test program's end
    client.send(b"GET /?stop=True HTTP/1.1\\r\\n\\r\\n"); sim.run_until(t); client.received
"""

import sim
from sim import CancelledError, Task, Wait  # noqa: F401 (CancelledError is part of the API)


class TimeoutError(Exception):  # noqa: A001 - the name asyncio gives it
    pass


def create_task(coro):
    return sim.spawn(coro, getattr(coro, "__name__", "task"))


def current_task():
    return sim.current


async def sleep_ms(ms):
    await Wait(("sleep", sim.now_us + int(ms) * 1000))


async def sleep(s):
    await Wait(("sleep", sim.now_us + int(s * 1000000)))


async def wait_for_ms(aw, timeout_ms):
    task = aw if isinstance(aw, Task) else create_task(aw)
    deadline = sim.now_us + int(timeout_ms) * 1000
    while not task.done:
        if sim.now_us >= deadline:
            task.cancel()
            raise TimeoutError()
        await Wait(("join", task, deadline))
    return task.result()


async def wait_for(aw, timeout_s):
    return await wait_for_ms(aw, int(timeout_s * 1000))


async def gather(*aws):
    tasks = [a if isinstance(a, Task) else create_task(a) for a in aws]
    for t in tasks:
        while not t.done:
            await Wait(("join", t, None))
    return [t.result() for t in tasks]


def run(coro):
    """On the board this runs forever; here it only starts the task (the test drives time)."""
    return create_task(coro)


class Event:
    def __init__(self):
        self._set = False
        self.waiters = []

    def set(self):
        self._set = True
        waiters, self.waiters = self.waiters, []
        for task, token in waiters:
            if task.token == token:
                sim.wake(task)

    def clear(self):
        self._set = False

    def is_set(self):
        return self._set

    async def wait(self):
        while not self._set:
            await Wait(("io", self))


# --- TCP -----------------------------------------------------------------------------------

_servers = {}  # port -> handler
connections = []  # every Client, in connection order


class _Pipe:
    """Bytes one way, with the tasks waiting for them."""

    def __init__(self):
        self.data = b""
        self.eof = False
        self.waiters = []

    def put(self, data):
        self.data += data
        self._wake()

    def close(self):
        self.eof = True
        self._wake()

    def _wake(self):
        waiters, self.waiters = self.waiters, []
        for task, token in waiters:
            if task.token == token:
                sim.wake(task)


class StreamReader:
    def __init__(self, pipe):
        self._pipe = pipe

    async def read(self, n=-1):
        pipe = self._pipe
        while not pipe.data and not pipe.eof:
            await Wait(("io", pipe))
        if n < 0:
            n = len(pipe.data)
        data, pipe.data = pipe.data[:n], pipe.data[n:]
        return data

    async def readline(self):
        pipe = self._pipe
        while b"\n" not in pipe.data and not pipe.eof:
            await Wait(("io", pipe))
        i = pipe.data.find(b"\n")
        i = len(pipe.data) if i < 0 else i + 1
        data, pipe.data = pipe.data[:i], pipe.data[i:]
        return data


class StreamWriter:
    def __init__(self, client):
        self._client = client

    def write(self, data):
        if not self._client.closed_by_server:
            self._client.received += bytes(data)

    async def drain(self):
        await Wait(("yield",))

    def close(self):
        self._client.closed_by_server = True
        self._client.to_server.close()

    async def wait_closed(self):
        await Wait(("yield",))

    def get_extra_info(self, name):
        return ("10.0.0.%d" % self._client.number, 40000 + self._client.number) if name == "peername" else None


class Client:
    """The test program's end of one connection."""

    def __init__(self, number):
        self.number = number
        self.to_server = _Pipe()
        self.received = b""
        self.closed_by_server = False

    def send(self, data):
        self.to_server.put(bytes(data))

    def close(self):
        self.to_server.close()

    def take(self):
        """What the server sent since the last take()."""
        data, self.received = self.received, b""
        return data


class Server:
    def __init__(self, port):
        self.port = port

    def close(self):
        _servers.pop(self.port, None)

    async def wait_closed(self):
        await Wait(("yield",))


async def start_server(handler, host, port, backlog=5):
    _servers[port] = handler
    return Server(port)


def connect(port):
    """A new client connection to the server on port (its handler starts at once)."""
    if port not in _servers:
        raise OSError("connection refused: nothing listens on port %d" % port)
    client = Client(len(connections) + 1)
    connections.append(client)
    sim.spawn(_servers[port](StreamReader(client.to_server), StreamWriter(client)), "connection %d" % client.number)
    return client
