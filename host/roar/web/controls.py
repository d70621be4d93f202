"""Who drives the car from the browser, and with what: one driver at a time, a dead man, and
every message from a page checked before it may move anything.

    controls = Controls()
    controls.join("a"); controls.join("b")           # the first page drives, the second watches
    controls.handle("a", '{"t": "drive", "throttle": 0.3, "steering": 0}', now_s)
    controls.command(now_s)                          # (0.3, 0.0); neutral 250 ms after the last drive

The page sends its stick every DRIVE_PERIOD_S while it drives; when nothing comes from the driver
for DEAD_MAN_S (the page is hidden or closed, its socket is cut, its script stalls) the command
is neutral until the driver sends again. Anything a page sends that is not a well-formed message
of its role is ignored and counted by reason (`ignored`), never raised and never driven.
"""

from __future__ import annotations

import collections
import json
import math
from dataclasses import dataclass

DEAD_MAN_S = 0.25  # [s] no drive message from the driver this long: neutral
DRIVE_PERIOD_S = 0.05  # [s] how often the page sends its stick while it drives
MAX_MESSAGE_CHARS = 1024  # a page's control messages are a few dozen characters
AUTOPILOT_NONE = "none"
NEUTRAL = (0.0, 0.0)


@dataclass
class Client:
    """One page on the server: its id and since when it has been connected."""

    id: str
    joined_s: float


class Controls:
    """The driving state shared by every page: the driver, the last stick, the limit, the
    autopilot, whether the run is recorded. Not thread-safe: the server calls it from its event
    loop only."""

    def __init__(self, autopilots: tuple[str, ...] = (), can_record: bool = False) -> None:
        self.autopilots = (AUTOPILOT_NONE, *autopilots)
        self.can_record = can_record
        self.clients: dict[str, Client] = {}
        self.driver: str | None = None
        self.stick = NEUTRAL  # (throttle, steering) [-1, 1] as the driver last sent it
        self.max_throttle = 0.5  # [0, 1] the stick's throttle is scaled by this
        self.autopilot = AUTOPILOT_NONE
        self.recording = False
        self.last_drive_s: float | None = None  # when the driver last sent its stick
        self.dead_man_trips = 0  # times the driver went quiet for DEAD_MAN_S while driving
        self._tripped = True  # neutral until the driver's first drive message
        self.ignored: collections.Counter[str] = collections.Counter()  # reason -> messages

    # --- pages -----------------------------------------------------------------------------------

    def join(self, client_id: str, now_s: float) -> str:
        """A page connected: it drives if nobody does, else it watches. Its role. (A page without
        the token, where one is needed, never gets here: the server refuses its socket.)"""
        self.clients[client_id] = Client(client_id, now_s)
        if self.driver is None:
            self._set_driver(client_id)
        return self.role(client_id)

    def leave(self, client_id: str) -> None:
        """A page went away: if it drove, the car is at neutral and nobody drives."""
        self.clients.pop(client_id, None)
        if self.driver == client_id:
            self.driver = None
            self._neutral()

    def role(self, client_id: str) -> str:
        return "driver" if client_id == self.driver else "viewer"

    def _set_driver(self, client_id: str | None) -> None:
        self.driver = client_id
        self._neutral()

    def _neutral(self) -> None:
        self.stick = NEUTRAL
        self.autopilot = AUTOPILOT_NONE
        self.last_drive_s = None
        self._tripped = True

    # --- what a page sends -------------------------------------------------------------------------

    def handle(self, client_id: str, text, now_s: float) -> str | None:
        """One message from a page. Returns what changed that every page should hear of ("role",
        "settings", "record") or None; a bad message is counted in `ignored` and changes nothing."""
        message = self._parse(text)
        if message is None:
            return None
        kind = message.get("t")
        if client_id not in self.clients:
            return self._ignore("unknown page")
        if kind == "take":
            if self.driver != client_id:
                self._set_driver(client_id)
            return "role"
        if client_id != self.driver:
            return self._ignore("not the driver")
        if kind == "drive":
            return self._drive(message, now_s)
        if kind in ("stop", "release"):  # the stop button; the page hidden
            self._neutral()
            return "settings" if kind == "stop" else None
        if kind == "limit":
            value = _number(message.get("max_throttle"))
            if value is None or not 0 <= value <= 1:
                return self._ignore("max_throttle not in 0..1")
            self.max_throttle = value
            return "settings"
        if kind == "autopilot":
            name = message.get("name")
            if name not in self.autopilots:
                return self._ignore("unknown autopilot")
            self.autopilot = name
            self.stick = NEUTRAL
            self.last_drive_s = now_s  # the autopilot drives while the page holds the dead man
            self._tripped = False
            return "settings"
        if kind == "record":
            on = message.get("on")
            if not isinstance(on, bool) or not self.can_record:
                return self._ignore("record needs on: true|false and roar-platform[record]")
            self.recording = on
            return "record"
        return self._ignore("unknown message")

    def _drive(self, message: dict, now_s: float) -> None:
        throttle, steering = _number(message.get("throttle")), _number(message.get("steering"))
        if throttle is None or steering is None:
            self._ignore("axis not a finite number")
            return None
        if not (-1 <= throttle <= 1 and -1 <= steering <= 1):
            self._ignore("axis outside -1..1")
            return None
        self.stick = (throttle, steering)
        self.last_drive_s = now_s
        self._tripped = False
        return None

    def _parse(self, text) -> dict | None:
        if not isinstance(text, str):
            return self._ignore("not text")
        if len(text) > MAX_MESSAGE_CHARS:
            return self._ignore("too long")
        try:
            message = json.loads(text, parse_constant=_no_constant)
        except (ValueError, RecursionError):
            return self._ignore("not JSON")
        if not isinstance(message, dict) or not isinstance(message.get("t"), str):
            return self._ignore("not a message")
        return message

    def _ignore(self, reason: str) -> None:
        self.ignored[reason] += 1
        return None

    # --- what the car is sent ----------------------------------------------------------------------

    def alive(self, now_s: float) -> bool:
        """The driver has sent within DEAD_MAN_S (the dead man is held). Trips once per silence."""
        if self._tripped:
            return False
        if self.last_drive_s is None or now_s - self.last_drive_s > DEAD_MAN_S:
            self._tripped = True
            self.dead_man_trips += 1
            self.stick = NEUTRAL
            self.autopilot = AUTOPILOT_NONE
            return False
        return True

    def command(self, now_s: float) -> tuple[float, float]:
        """(throttle, steering) for the car from the stick: scaled by the limit, neutral when
        nobody drives or the driver has gone quiet."""
        if self.driver is None or not self.alive(now_s):
            return NEUTRAL
        throttle, steering = self.stick
        return throttle * self.max_throttle, steering


def _number(value) -> float | None:
    """A JSON number that is finite, else None (booleans are not numbers here)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        value = float(value)
    except OverflowError:  # an integer beyond any float
        return None
    return value if math.isfinite(value) else None


def _no_constant(name: str):
    raise ValueError(f"{name} is not JSON")
