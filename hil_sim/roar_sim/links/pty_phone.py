"""A simulated ESC car reached as a real one with the phone on it: control over a serial port (a
pty, as USB serial), its pose streamed by the phone over UDP (ROAR's state stream, without
camera frames), with the phone's tracking noise. What `roar fit` proves itself on: a car whose
numbers it does not know (a profile drawn at random), measured only through what a real car
gives it.

    with PtyCarWithPhone(profile, noise_m=0.003, pose_hz=30) as car:
        car.path           # the serial port: serial://{car.path}
        car.pose_url       # udp://127.0.0.1?ports=... (the phone's streams, on free ports)
"""

from __future__ import annotations

import asyncio
import threading

from roar_sim.links.phone_udp import Phone, StreamConfig
from roar_sim.links.pty import PtyCar
from roar_sim.plants.car_profile import CarProfile

START_TIMEOUT_S = 10.0  # [s]


class PtyCarWithPhone:
    def __init__(self, profile: CarProfile, noise_m: float = 0.0, pose_hz: float = 30.0, seed: int = 0) -> None:
        from roar_sim.robots.esc import EscCar

        self.sim = EscCar(None, profile=profile)  # paced in real time by the phone's loop
        self.pty = PtyCar(self.sim)
        free = {"rgb": 0, "depth": 0, "state": 0, "control": 0}  # (not ROAR's: a phone elsewhere on this machine)
        self.phone = Phone(self.sim, StreamConfig(camera=False, rate_hz=pose_hz, pose_noise_m=noise_m, seed=seed,
                                                  ports=free))
        self.path = self.pty.path
        self.pose_url = ""  # once started
        self._loop = asyncio.new_event_loop()
        self._task = None  # the serving coroutine's future
        self._thread = threading.Thread(target=self._loop.run_forever, name="pty-phone", daemon=True)

    def __enter__(self) -> PtyCarWithPhone:
        self._thread.start()
        try:
            asyncio.run_coroutine_threadsafe(self.phone.start(), self._loop).result(START_TIMEOUT_S)
        except BaseException:
            self.__exit__()
            raise
        ports = ",".join(str(self.phone.bound(k)[1]) for k in ("rgb", "depth", "state", "control"))
        self.pose_url = f"udp://127.0.0.1?ports={ports}"
        self._task = asyncio.run_coroutine_threadsafe(self._serve(), self._loop)
        return self

    async def _serve(self) -> None:
        await self.phone.serve(0.0, step=self.pty.pump)

    def __exit__(self, *exc) -> None:
        if self._task is not None:
            self._task.cancel()
        asyncio.run_coroutine_threadsafe(self._close(), self._loop).result(START_TIMEOUT_S)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(timeout=5)
        self._loop.close()
        self.pty.close()
        self.sim.close()

    async def _close(self) -> None:
        """The phone's ports closed, and the loop turned until their sockets are."""
        self.phone.close()
        for _ in range(3):
            await asyncio.sleep(0)
