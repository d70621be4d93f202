"""The car's Bluetooth side, virtual: a bumble peripheral with the ROAR GATT layout (protocol
spec [ble]) whose control characteristic feeds the board loop of the firmware core
(CarBoard, host build), run on the wall clock. Used by the BLE tests; the host reaches it through virtual_ble's bleak backend.

    radio = VirtualRadio().install()
    car = BleCar(radio); await car.start()      # advertises "ROAR Car" with the ROAR service
    ... host drives it over bleak ...
    car.outputs                                  # what the firmware drives on the pins now
    await car.drop_link()                        # the car walks out of range

    BleCar(radio, nvm=...)     # a board whose EEPROM holds a signing key (car.serial_in(b"KEY ..."))
    BleCar(radio, secure=True) # control writes need an encrypted link: LE Secure Connections pairing
                               # (default: when the board has a key, as the ESP32-CAM car's glue)
"""

from __future__ import annotations

import asyncio
import struct
import time

from bumble.core import UUID, AdvertisingData
from bumble.gatt import Characteristic, CharacteristicValue, Service
from bumble.pairing import PairingConfig, PairingDelegate

from roar.protocol import spec
from roar_sim.core.car import CarBoard, CarConfig, CarOutputs
from roar_sim.links.ble_radio import VirtualRadio

TICK_S = 0.002  # [s] firmware loop period on the wall clock
ADVERTISING_INTERVAL_MS = 20  # [ms]
FRAME_US = spec.TIMING_SERVO_FRAME_US  # [us]

P = Characteristic.Properties
READABLE, WRITEABLE = Characteristic.Permissions.READABLE, Characteristic.Permissions.WRITEABLE


class BleCar:
    def __init__(self, radio: VirtualRadio, name: str = spec.BLE_LOCAL_NAME,
                 address: str = "F0:00:00:00:00:01", config: CarConfig | None = None, nvm: bytes | None = None,
                 secure: bool | None = None) -> None:
        """nvm: the board's EEPROM (its signing key and session); secure: the control and session
        characteristics need an encrypted link, which the car pairs with LE Secure Connections
        only (no legacy pairing), as a stack that can do so should; None: when the board has a
        key at start (the ESP32-CAM car's rule), False as the Nano 33 BLE (its stack cannot)."""
        self.radio, self.name, self.address, self.secure = radio, name, address, secure
        # The board's clock is set from the wall clock before each loop iteration (loop_us 0).
        self.board = CarBoard(config or CarConfig(), loop_us=0, frame_us=FRAME_US, nvm=nvm)
        self.write_links: list[tuple[bool, bool]] = []  # (encrypted, LE Secure Connections) of each control write
        self.writes: list[bytes] = []  # every control write, in arrival order
        self.replies: list[str] = []  # lines the firmware printed (it would print them on serial)
        self.history: list[tuple[float, int, int]] = []  # (t [s], throttle_us, steering_us) at each change
        self.pid_gains: tuple[float, float, float] | None = None
        self.connections = 0  # links a host has opened so far
        self.device = None
        self._t0 = time.monotonic()
        self._task: asyncio.Task | None = None

    @property
    def outputs(self) -> CarOutputs:
        """What the firmware drives on the pins now."""
        return self.board.outputs

    def now_us(self) -> int:
        return int((time.monotonic() - self._t0) * 1e6)

    async def start(self) -> None:
        self.board.begin()
        if self.secure is None:
            self.secure = self.board.session != 0
        device = self.device = self.radio.add_device(self.name, self.address)
        readable = READABLE | (Characteristic.Permissions.READ_REQUIRES_ENCRYPTION if self.secure else 0)
        writeable = WRITEABLE | (Characteristic.Permissions.WRITE_REQUIRES_ENCRYPTION if self.secure else 0)
        control = Characteristic(spec.BLE_CONTROL_UUID, P.READ | P.WRITE | P.WRITE_WITHOUT_RESPONSE,
                                 readable | writeable,
                                 CharacteristicValue(read=self._read_control, write=self._on_control))
        session = Characteristic(spec.BLE_SESSION_UUID, P.READ, readable,
                                 CharacteristicValue(read=lambda _c: struct.pack("<2I", self.board.session,
                                                                                         self.board.last_counter)))
        velocity = Characteristic(spec.BLE_VELOCITY_UUID, P.READ, READABLE,
                                  CharacteristicValue(read=lambda _c: struct.pack("<f", 0.0)))
        pid = Characteristic(spec.BLE_PID_UUID, P.WRITE, WRITEABLE, CharacteristicValue(write=self._on_pid))
        state = Characteristic(spec.BLE_STATE_UUID, P.READ, READABLE, CharacteristicValue(read=self._read_state))
        name = Characteristic(spec.BLE_NAME_UUID, P.WRITE, WRITEABLE, CharacteristicValue(write=lambda _c, _v: None))
        override = Characteristic(spec.BLE_OVERRIDE_UUID, P.WRITE, WRITEABLE,
                                  CharacteristicValue(write=lambda _c, _v: None))
        device.add_service(Service(spec.BLE_SERVICE_UUID, [control, velocity, pid, state, name, override, session]))
        if self.secure:  # Secure Connections only, Just Works (a car has no display or keys)
            device.pairing_config_factory = lambda _connection: PairingConfig(
                sc=True, mitm=False, bonding=True,
                delegate=PairingDelegate(io_capability=PairingDelegate.IoCapability.NO_OUTPUT_NO_INPUT))
        device.advertising_data = bytes(AdvertisingData([
            (AdvertisingData.FLAGS, bytes([0x06])),
            (AdvertisingData.COMPLETE_LOCAL_NAME, self.name.encode()),
            (AdvertisingData.INCOMPLETE_LIST_OF_128_BIT_SERVICE_CLASS_UUIDS,
             UUID(spec.BLE_SERVICE_UUID).to_bytes(force_128=True)),
        ]))
        device.on("connection", self._on_connection)
        await device.power_on()
        await device.start_advertising(auto_restart=True, advertising_interval_min=ADVERTISING_INTERVAL_MS)
        self._task = asyncio.get_running_loop().create_task(self._run())

    def _on_connection(self, _connection) -> None:
        self.connections += 1

    def serial_in(self, data: bytes) -> None:
        """Bytes on the car's USB serial port (where a key is set: b"KEY <32 hex>\\n")."""
        self.board.serial_in(data)

    def _on_control(self, connection, value: bytes) -> None:
        self.writes.append(bytes(value))
        self.write_links.append((connection.is_encrypted, bool(connection.sc)))
        self.board.set_clock(self.now_us())
        self.board.ble_write(bytes(value))

    def _read_control(self, _connection) -> bytes:
        return f"({self.outputs.throttle_us},{self.outputs.steering_us})".encode()

    def _on_pid(self, _connection, value: bytes) -> None:
        if len(value) == 12:
            self.pid_gains = struct.unpack("<3f", value)

    def _read_state(self, _connection) -> bytes:
        return struct.pack("<2f", 0.0, float(self.outputs.throttle_us))

    async def _run(self) -> None:
        while True:
            now = self.now_us()
            self.board.set_clock(now)
            self.board.run(1)
            out = self.outputs
            self.replies += self.board.serial_out().decode("ascii").splitlines()
            if not self.history or self.history[-1][1:] != (out.throttle_us, out.steering_us):
                self.history.append((now / 1e6, out.throttle_us, out.steering_us))
            await asyncio.sleep(TICK_S)

    async def drop_link(self) -> None:
        """Every connection to the car ends, as when it drives out of range."""
        for connection in list(self.device.connections.values()):
            await connection.disconnect()

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
        await self.device.stop_advertising()
        await self.drop_link()
