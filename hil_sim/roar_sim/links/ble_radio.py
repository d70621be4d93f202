"""A virtual Bluetooth radio for tests and the simulator: bleak's public API on top of bumble's
real host stack and virtual controllers, so host code that uses BleakScanner / BleakClient
talks through HCI, L2CAP, ATT and GATT to a bumble peripheral playing the car, with no
hardware, kernel support or D-Bus.

    radio = VirtualRadio().install()              # inside the asyncio loop that bleak will use
    car = radio.add_device("ROAR Car", "F0:00:00:00:00:01")   # then add a GATT server to it
    BleakClient(address, backend=BumbleClient)    # production code with the backend injected

RF timing, packet loss and the OS's BLE stack are not modelled; every layer above the
controller is real.
"""

from __future__ import annotations

import asyncio
import uuid as _uuid
from typing import Any

from bleak.assigned_numbers import gatt_char_props_to_strs
from bleak.backends.characteristic import BleakGATTCharacteristic
from bleak.backends.client import BaseBleakClient, NotifyCallback
from bleak.backends.descriptor import BleakGATTDescriptor
from bleak.backends.device import BLEDevice
from bleak.backends.scanner import AdvertisementData, BaseBleakScanner
from bleak.backends.service import BleakGATTService, BleakGATTServiceCollection
from bleak.exc import BleakDeviceNotFoundError, BleakError, BleakGATTProtocolError
from bumble import att
from bumble.controller import Controller
from bumble.core import UUID, AdvertisingData
from bumble.device import Advertisement, Connection, Device, Peer
from bumble.hci import Address
from bumble.host import Host
from bumble.link import LocalLink
from bumble.transport.common import AsyncPipeSink

AD = AdvertisingData
ATT_MTU_REQUEST = 247  # [bytes]
_UUID_LISTS = (AD.COMPLETE_LIST_OF_16_BIT_SERVICE_CLASS_UUIDS, AD.INCOMPLETE_LIST_OF_16_BIT_SERVICE_CLASS_UUIDS,
               AD.COMPLETE_LIST_OF_32_BIT_SERVICE_CLASS_UUIDS, AD.INCOMPLETE_LIST_OF_32_BIT_SERVICE_CLASS_UUIDS,
               AD.COMPLETE_LIST_OF_128_BIT_SERVICE_CLASS_UUIDS, AD.INCOMPLETE_LIST_OF_128_BIT_SERVICE_CLASS_UUIDS)


def uuid_str(u: UUID) -> str:
    """bumble UUID -> bleak's lower-case 128-bit form."""
    return str(_uuid.UUID(bytes=bytes(reversed(u.to_bytes(force_128=True)))))


class VirtualRadio:
    """One LocalLink "air" plus the host's adapter (a central Device), powered on first use."""

    current: VirtualRadio | None = None

    def __init__(self, central_address: str = "C0:00:00:00:00:01") -> None:
        self.link = LocalLink()  # must be created inside the running loop
        self._central_address = central_address
        self._central: Device | None = None
        self._lock = asyncio.Lock()

    def add_device(self, name: str, address: str) -> Device:
        controller = Controller(name, link=self.link, public_address=address)
        return Device(name=name, address=Address(address), host=Host(controller, AsyncPipeSink(controller)))

    async def central(self) -> Device:
        async with self._lock:
            if self._central is None:
                device = self.add_device("host-adapter", self._central_address)
                await device.power_on()
                self._central = device
            return self._central

    def install(self) -> VirtualRadio:
        VirtualRadio.current = self
        return self

    @staticmethod
    def get(kwargs: dict[str, Any]) -> VirtualRadio:
        radio = kwargs.get("radio") or VirtualRadio.current
        if radio is None:
            raise BleakError("no VirtualRadio installed (VirtualRadio().install())")
        return radio


def _advertisement(adv: Advertisement) -> tuple[str | None, AdvertisementData]:
    name, manufacturer, service_data, uuids, tx = None, {}, {}, [], None
    for kind, value in adv.data.ad_structures:
        if kind in (AD.COMPLETE_LOCAL_NAME, AD.SHORTENED_LOCAL_NAME):
            if kind == AD.COMPLETE_LOCAL_NAME or name is None:
                name = value.decode(errors="replace")
        elif kind == AD.MANUFACTURER_SPECIFIC_DATA and len(value) >= 2:
            manufacturer[int.from_bytes(value[:2], "little")] = bytes(value[2:])
        elif kind in (AD.SERVICE_DATA_16_BIT_UUID, AD.SERVICE_DATA_32_BIT_UUID, AD.SERVICE_DATA_128_BIT_UUID):
            n = {AD.SERVICE_DATA_16_BIT_UUID: 2, AD.SERVICE_DATA_32_BIT_UUID: 4}.get(kind, 16)
            service_data[uuid_str(UUID.from_bytes(value[:n]))] = bytes(value[n:])
        elif kind in _UUID_LISTS:
            uuids += [uuid_str(u) for u in AD.ad_data_to_object(kind, value)]
        elif kind == AD.TX_POWER_LEVEL and value:
            tx = int.from_bytes(value[:1], "little", signed=True)
    return name, AdvertisementData(local_name=name, manufacturer_data=manufacturer, service_data=service_data,
                                   service_uuids=uuids, tx_power=tx, rssi=adv.rssi, platform_data=(adv,))


class BumbleScanner(BaseBleakScanner):
    def __init__(self, detection_callback, service_uuids, scanning_mode="active", **kwargs: Any) -> None:
        super().__init__(detection_callback, service_uuids)
        self._radio = VirtualRadio.get(kwargs)
        self._active = scanning_mode != "passive"
        self._device: Device | None = None

    def _on_advertisement(self, adv: Advertisement) -> None:
        name, data = _advertisement(adv)
        if not self.is_allowed_uuid(data.service_uuids):
            return
        address = adv.address.to_string(with_type_qualifier=False)
        self.call_detection_callbacks(self.create_or_update_device(address, address, name, adv.address, data), data)

    async def start(self) -> None:
        self.seen_devices = {}
        self._device = await self._radio.central()
        self._device.on(Device.EVENT_ADVERTISEMENT, self._on_advertisement)
        if not self._device.is_scanning:
            await self._device.start_scanning(active=self._active, filter_duplicates=False)

    async def stop(self) -> None:
        if self._device is not None:
            self._device.remove_listener(Device.EVENT_ADVERTISEMENT, self._on_advertisement)
            if self._device.is_scanning:
                await self._device.stop_scanning()


class BumbleClient(BaseBleakClient):
    def __init__(self, address_or_ble_device: BLEDevice | str, services=None, **kwargs: Any) -> None:
        super().__init__(address_or_ble_device, **kwargs)
        self._radio = VirtualRadio.get(kwargs)
        details = getattr(address_or_ble_device, "details", None)
        self._peer_address = details if isinstance(details, Address) else Address(str(self.address))
        self._name = getattr(address_or_ble_device, "name", None) or self.address
        self._service_filter = services
        self._connection: Connection | None = None
        self._peer: Peer | None = None
        self._closing = False
        self._subscriptions: dict[int, Any] = {}

    @property
    def name(self) -> str:
        return self._name

    @property
    def mtu_size(self) -> int:
        return self._connection.att_mtu if self._connection else 23

    @property
    def is_connected(self) -> bool:
        return self._connection is not None

    async def connect(self, pair: bool, **kwargs: Any) -> None:
        central = await self._radio.central()
        if central.is_scanning:  # adapters pause discovery while connecting
            await central.stop_scanning()
        try:
            connection = await central.connect(self._peer_address, timeout=self._timeout)
        except Exception as e:  # bumble's TimeoutError / ConnectionError
            if "timeout" in type(e).__name__.lower():
                raise TimeoutError(f"connect to {self.address} timed out") from e
            raise BleakDeviceNotFoundError(self.address, str(e)) from e
        self._connection, self._closing = connection, False
        connection.on(Connection.EVENT_DISCONNECTION, self._on_disconnection)
        self._peer = Peer(connection)
        if pair:
            await connection.pair()
        await self._peer.request_mtu(ATT_MTU_REQUEST)
        self.services = await self._discover()

    def _on_disconnection(self, reason: int) -> None:
        self._connection = self._peer = None
        self.services = None
        if not self._closing and self._disconnected_callback is not None:
            self._disconnected_callback()

    async def disconnect(self) -> None:
        if self._connection is not None:
            self._closing = True
            await self._connection.disconnect()

    async def pair(self, *args: Any, **kwargs: Any) -> None:
        await self._require().connection.pair()

    async def unpair(self) -> None:
        raise NotImplementedError("unpair is not supported by the virtual radio")

    def _require(self) -> Peer:
        if self._peer is None:
            raise BleakError("Not connected")
        return self._peer

    async def _discover(self) -> BleakGATTServiceCollection:
        peer = self._require()
        wanted = [UUID(u) for u in self._service_filter] if self._service_filter else []
        services = await peer.discover_services(wanted)
        if wanted:
            names = {uuid_str(u) for u in wanted}
            services = [s for s in services if uuid_str(s.uuid) in names]
        collection = BleakGATTServiceCollection()
        for service in services:
            bleak_service = BleakGATTService(service, service.handle, uuid_str(service.uuid))
            collection.add_service(bleak_service)
            await service.discover_characteristics()
            for ch in service.characteristics:
                await ch.discover_descriptors()
                bleak_char = BleakGATTCharacteristic(ch, ch.handle, uuid_str(ch.uuid),
                                                     list(gatt_char_props_to_strs(int(ch.properties))),
                                                     lambda: self.mtu_size - 3, bleak_service)
                collection.add_characteristic(bleak_char)
                for d in ch.descriptors:
                    collection.add_descriptor(BleakGATTDescriptor(d, d.handle, uuid_str(d.type), bleak_char))
        return collection

    async def _att(self, coro):
        try:
            return await coro
        except att.ATT_Error as e:
            raise BleakGATTProtocolError(e.error_code) from e

    async def read_gatt_char(self, characteristic, *, use_cached=False, **kwargs) -> bytearray:
        self._require()
        return bytearray(await self._att(characteristic.obj.read_value()))

    async def read_gatt_descriptor(self, descriptor, *, use_cached=False, **kwargs) -> bytearray:
        self._require()
        return bytearray(await self._att(descriptor.obj.read_value()))

    async def write_gatt_char(self, characteristic, data, response: bool) -> None:
        self._require()
        await self._att(characteristic.obj.write_value(bytes(data), with_response=response))

    async def write_gatt_descriptor(self, descriptor, data) -> None:
        self._require()
        await self._att(descriptor.obj.write_value(bytes(data), with_response=True))

    async def start_notify(self, characteristic, callback: NotifyCallback, **kwargs) -> None:
        peer = self._require()
        self._subscriptions[characteristic.handle] = subscription = lambda value: callback(bytearray(value))
        await self._att(peer.subscribe(characteristic.obj, subscription))

    async def stop_notify(self, characteristic) -> None:
        peer = self._require()
        await self._att(peer.unsubscribe(characteristic.obj, self._subscriptions.pop(characteristic.handle, None)))
