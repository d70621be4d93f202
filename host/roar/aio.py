"""One background asyncio loop for the async libraries behind the synchronous API (bleak).

Users call the Vehicle from plain code; BLE work runs on this loop in a daemon thread, so a
program never needs to know asyncio is involved."""

from __future__ import annotations

import asyncio
import concurrent.futures
import threading
from typing import Awaitable, TypeVar

from roar.checks import timeout

T = TypeVar("T")
_loop: asyncio.AbstractEventLoop | None = None
_lock = threading.Lock()


def background_loop() -> asyncio.AbstractEventLoop:
    global _loop
    with _lock:
        if _loop is None or _loop.is_closed():
            loop = asyncio.new_event_loop()
            threading.Thread(target=loop.run_forever, name="roar-asyncio", daemon=True).start()
            _loop = loop
        return _loop


def run_sync(coro: Awaitable[T], timeout_s: float | None = None) -> T:
    """Run a coroutine on the background loop and wait for its result (re-raising its error).
    On timeout the coroutine is cancelled and TimeoutError raised."""
    try:
        timeout_s = None if timeout_s is None else timeout("timeout_s", timeout_s)
    except ValueError:
        coro.close()  # never to run: no "never awaited" warning on top of the error
        raise
    loop = background_loop()
    if threading.current_thread().name == "roar-asyncio":
        raise RuntimeError("run_sync() called from the background loop itself")
    future = asyncio.run_coroutine_threadsafe(coro, loop)
    try:
        return future.result(timeout_s)
    except concurrent.futures.TimeoutError:
        future.cancel()
        raise TimeoutError from None
