"""ble:// -- a car over Bluetooth LE (bleak), with the ROAR GATT layout (protocol spec [ble]).

    ble://                 the first car advertising the ROAR vehicle-control service
    ble://ROAR Car         a car by advertised name (spaces are fine; %20 works too)
    ble://AA:BB:CC:DD:EE:FF  a car by address
    ble://?timeout=20      seconds to look for it (default 10)
    ble://?pair=1          pair first (bonded, encrypted: a car that asks for it gets LE Secure
                           Connections where the host's stack and the car's can do it); a
                           signing host pairs anyway where the car can, ?pair=0 never

Each control message is one write-without-response to the control characteristic (a signed
message longer than the link's ATT payload goes in pieces, which the car's streaming parser
joins). The car sends nothing back on this link (read_lines() is empty); its own failsafe stops
it when writes stop arriving. A signing host reads the car's session from its session
characteristic.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass

from bleak import BleakClient, BleakScanner
from bleak.exc import BleakError

from roar.aio import run_sync
from roar.checks import MAX_SCAN_S, number
from roar.protocol import spec
from roar.telemetry import VehicleState
from roar.transports.base import LinkLost, Transport, TransportError, pop_number, pop_option

DEFAULT_TIMEOUT_S = 10.0  # [s] to find and connect to the car
MAX_CONNECT_S = 120.0  # [s] the longest a connection may be given
WRITE_TIMEOUT_S = 1.0  # [s]
_ADDRESS = re.compile(r"^([0-9A-Fa-f]{2}:){5}[0-9A-Fa-f]{2}$|^[0-9A-Fa-f-]{36}$")  # MAC, or a macOS UUID


@dataclass(frozen=True)
class FoundDevice:
    name: str | None
    address: str
    rssi: int | None
    is_car: bool  # advertises the ROAR service


def _advertises_roar(adv) -> bool:
    return spec.BLE_SERVICE_UUID in [u.lower() for u in adv.service_uuids]


def _no_bluetooth(e: BaseException) -> TransportError:
    detail = " ".join(str(e).split()) or type(e).__name__
    return TransportError(f"Bluetooth is not available on this machine (no adapter or no BlueZ/D-Bus: {detail})")


def scan(timeout_s: float = 5.0, only_cars: bool = True, backend=None) -> list[FoundDevice]:
    """Devices heard within timeout_s, strongest first; only ROAR cars unless only_cars=False."""
    timeout_s = number("timeout_s", timeout_s, 0, MAX_SCAN_S, "s", low_open=True)

    async def _scan():
        return await BleakScanner.discover(timeout=timeout_s, return_adv=True, backend=backend)

    try:
        seen = run_sync(_scan(), timeout_s + 5)
    except (BleakError, OSError) as e:
        raise _no_bluetooth(e) from None
    found = []
    for device, adv in seen.values():
        is_car = _advertises_roar(adv)
        if is_car or not only_cars:
            found.append(FoundDevice(adv.local_name or device.name, device.address, adv.rssi, is_car))
    return sorted(found, key=lambda d: -(d.rssi if d.rssi is not None else -999))


class BleTransport(Transport):
    scheme = "ble"
    min_period_s = 0.0075  # [s] the shortest BLE connection interval

    def __init__(self, target: str = "", timeout_s: float = DEFAULT_TIMEOUT_S, scanner_backend=None,
                 client_backend=None, pair: bool | None = None) -> None:
        """pair: True pair first (fail if the car cannot), False never, None pair when signing
        (`signing`, set by the signing layer) where the car can, else go on unencrypted."""
        self.target = target
        self.pair = pair
        self.encrypted = False  # the link was paired
        self.timeout_s = number("timeout_s", timeout_s, 0, MAX_CONNECT_S, "s", low_open=True)
        self.scanner_backend, self.client_backend = scanner_backend, client_backend
        self._client: BleakClient | None = None
        self._connected = False

    @classmethod
    def from_url(cls, target: str, options: dict[str, str], scanner_backend=None,
                 client_backend=None) -> BleTransport:
        timeout = pop_number(options, "timeout", DEFAULT_TIMEOUT_S, 0, MAX_CONNECT_S, "s", low_open=True)
        return cls(target.strip("/"), timeout, scanner_backend, client_backend, pop_option(options, "pair", bool, None))

    def describe_target(self) -> str:
        if not self.target:
            return "a car advertising the ROAR service"
        return f"the car at {self.target}" if _ADDRESS.match(self.target) else f"a car named {self.target!r}"

    def _matches(self, device, adv) -> bool:
        if not self.target:
            return _advertises_roar(adv)
        if _ADDRESS.match(self.target):
            return device.address.lower() == self.target.lower()
        return self.target in (adv.local_name, device.name)

    async def _connect(self) -> None:
        try:
            device = await BleakScanner.find_device_by_filter(self._matches, timeout=self.timeout_s,
                                                              backend=self.scanner_backend)
        except (BleakError, OSError) as e:  # no adapter, no BlueZ, no D-Bus: scanning cannot start
            raise _no_bluetooth(e) from None
        if device is None:
            raise TransportError(f"no BLE car found: looked {self.timeout_s:g} s for {self.describe_target()} "
                                 f"(powered on? in range? `roar scan` lists what is heard)")
        client = BleakClient(device, disconnected_callback=self._on_disconnect, timeout=self.timeout_s,
                             backend=self.client_backend)
        await client.connect()
        if self.pair or (self.pair is None and self.signing):
            try:
                await client.pair()
                self.encrypted = True
            except (BleakError, OSError, NotImplementedError):
                if self.pair:
                    raise
                # a car whose stack cannot pair (ArduinoBLE on the Nano 33 BLE): the signatures protect it
        if client.services.get_characteristic(spec.BLE_CONTROL_UUID) is None:
            await client.disconnect()
            raise TransportError(f"{device.name or device.address} has no ROAR control characteristic "
                                 f"{spec.BLE_CONTROL_UUID}")
        self._client, self._connected = client, True

    def _on_disconnect(self, client: BleakClient) -> None:
        self._connected = False

    def open(self) -> None:
        try:
            run_sync(self._connect(), self.timeout_s + 5)
        except TransportError:
            raise
        except TimeoutError:
            raise TransportError(f"timed out connecting to {self.describe_target()}") from None
        except (BleakError, OSError) as e:
            raise TransportError(f"cannot connect to {self.describe_target()}: {' '.join(str(e).split())}") from None

    def write(self, data: bytes) -> None:
        client = self._client
        if client is None or not self._connected:
            raise LinkLost(f"BLE link to {self.describe_target()} lost")
        piece = max(1, client.mtu_size - 3)  # [bytes] one write's payload
        try:
            for at in range(0, len(data), piece):
                run_sync(client.write_gatt_char(spec.BLE_CONTROL_UUID, data[at:at + piece], response=False),
                         WRITE_TIMEOUT_S)
        except (BleakError, OSError, TimeoutError) as e:
            self._connected = False
            raise LinkLost(f"BLE link to {self.describe_target()} lost: {e or type(e).__name__}") from None

    def car_session(self) -> tuple[int, int] | None:
        """(session, last counter accepted) from the car's session characteristic (session 0: no
        key, or a car too old to have the characteristic); None when the link cannot tell now."""
        client = self._client
        if client is None or not self._connected:
            return None
        if client.services.get_characteristic(spec.BLE_SESSION_UUID) is None:
            return 0, 0
        try:
            value = run_sync(client.read_gatt_char(spec.BLE_SESSION_UUID), WRITE_TIMEOUT_S)
        except (BleakError, OSError, TimeoutError):
            return None
        return struct.unpack("<2I", bytes(value[:8])) if len(value) >= 8 else (0, 0)

    def state(self) -> VehicleState | None:
        """Speed from the velocity characteristic, the throttle output from the state one."""
        client = self._client
        if client is None or not self._connected:
            return None
        try:
            velocity = run_sync(client.read_gatt_char(spec.BLE_VELOCITY_UUID), WRITE_TIMEOUT_S)
            state = run_sync(client.read_gatt_char(spec.BLE_STATE_UUID), WRITE_TIMEOUT_S)
        except (BleakError, OSError, TimeoutError):
            return None
        speed = struct.unpack("<f", bytes(velocity[:4]))[0] if len(velocity) >= 4 else None
        throttle_out = struct.unpack("<2f", bytes(state[:8]))[1] if len(state) >= 8 else None
        return VehicleState(speed_m_s=speed, throttle_out_us=throttle_out)

    def close(self) -> None:
        client, self._client = self._client, None
        if client is not None and self._connected:
            self._connected = False
            try:
                run_sync(client.disconnect(), 5)
            except (BleakError, OSError, TimeoutError):
                pass
