"""BLE end to end: the host library's bleak code talks through bumble's real host stack and
virtual controllers to a bumble GATT server with the ROAR layout, whose control writes feed the
firmware core (host build) on the wall clock."""

import re
import time

import pytest
from bumble.core import AdvertisingData

from conftest import wait_for
from roar import TransportError, Vehicle
from roar.aio import run_sync
from roar.protocol import encode, spec
from roar.transports.ble import scan
from roar_sim.links.ble_car import BleCar
from roar_sim.links.ble_radio import BumbleClient, BumbleScanner, VirtualRadio

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)

BACKENDS = dict(scanner_backend=BumbleScanner, client_backend=BumbleClient)


@pytest.fixture
def radio():
    async def make():
        return VirtualRadio().install()

    yield run_sync(make())
    VirtualRadio.current = None


@pytest.fixture
def car(radio):
    async def start():
        c = BleCar(radio)
        await c.start()
        return c

    c = run_sync(start())
    yield c
    run_sync(c.stop())


def outputs(car):
    return car.outputs.throttle_us, car.outputs.steering_us


def test_scan_finds_cars_by_the_roar_service(radio, car):
    async def add_other():
        other = radio.add_device("Headphones", "F0:00:00:00:00:99")
        other.advertising_data = bytes(AdvertisingData([(AdvertisingData.COMPLETE_LOCAL_NAME, b"Headphones")]))
        await other.power_on()
        await other.start_advertising(auto_restart=True, advertising_interval_min=20)

    run_sync(add_other())
    cars = scan(0.5, backend=BumbleScanner)
    assert [(d.name, d.address, d.is_car) for d in cars] == [("ROAR Car", "F0:00:00:00:00:01", True)]
    everything = scan(0.5, only_cars=False, backend=BumbleScanner)
    assert {d.name for d in everything} == {"ROAR Car", "Headphones"}


@pytest.mark.parametrize("target", ["", "ROAR%20Car", "F0:00:00:00:00:01"])
def test_writes_arrive_and_drive_the_firmware(car, target):
    with Vehicle(f"ble://{target}", **BACKENDS) as v:
        v.drive(throttle=0.5, steering=-0.5)
        assert wait_for(lambda: outputs(car) == (1750, 1250))
        assert car.writes[0] == encode(1500, 1500) and car.writes[-1] == encode(1750, 1250)
        assert car.replies[:2] == ["READY 1", "ARMED"]
    assert wait_for(lambda: outputs(car) == (1500, 1500))
    assert car.writes[-1] == encode(1500, 1500)  # neutral on the way out


def test_the_car_has_the_roar_gatt_layout(car):
    from bleak import BleakClient

    async def layout():
        async with BleakClient("F0:00:00:00:00:01", backend=BumbleClient) as client:
            service = client.services.get_service(spec.BLE_SERVICE_UUID)
            return {c.uuid: sorted(c.properties) for c in service.characteristics}

    chars = run_sync(layout())
    assert chars[spec.BLE_CONTROL_UUID] == ["read", "write", "write-without-response"]
    assert set(chars) == {spec.BLE_CONTROL_UUID, spec.BLE_VELOCITY_UUID, spec.BLE_PID_UUID, spec.BLE_STATE_UUID,
                          spec.BLE_NAME_UUID, spec.BLE_OVERRIDE_UUID, spec.BLE_SESSION_UUID}


def test_link_loss_is_survived(car):
    with Vehicle("ble://", **BACKENDS) as v:
        v.drive(0.3)
        assert wait_for(lambda: outputs(car) == (1650, 1500))
        assert car.connections == 1
        run_sync(car.drop_link())
        assert wait_for(lambda: car.connections == 2, timeout_s=5)  # the host found the car again
        assert wait_for(lambda: v.connected)
        v.stop()
        v.drive(0.2)
        writes_before = len(car.writes)
        assert wait_for(lambda: len(car.writes) > writes_before + 5)
        assert wait_for(lambda: outputs(car) == (1600, 1500))


def test_the_car_fails_safe_when_the_host_goes_away(car):
    v = Vehicle("ble://", **BACKENDS)
    v.drive(0.4)
    assert wait_for(lambda: outputs(car) == (1700, 1500))
    v._sender.stop()  # the host hangs: the link stays up but nothing more is written
    silent_from = time.monotonic()
    assert wait_for(lambda: car.outputs.latched, timeout_s=2)
    waited = time.monotonic() - silent_from
    assert outputs(car) == (1500, 1500) and "FAILSAFE" in car.replies
    assert waited < 1.0  # the 250 ms timeout plus scheduling slack, never "held the last command"
    v.transport.close()


def test_no_car_in_range_is_a_clear_error(radio):
    with pytest.raises(TransportError) as e:
        Vehicle("ble://Nobody?timeout=0.3", **BACKENDS)
    assert "no BLE car found: looked 0.3 s for a car named 'Nobody'" in str(e.value) and "\n" not in str(e.value)


def test_without_a_bluetooth_adapter_the_error_is_one_line():
    """This machine has no BlueZ/D-Bus: the real bleak backend must fail with a clear message."""
    with pytest.raises(TransportError) as e:
        Vehicle("ble://?timeout=1")
    message = str(e.value)
    assert "\n" not in message
    assert "Bluetooth is not available" in message or "no BLE car found" in message


def test_state_reads_the_velocity_and_state_characteristics(car):
    """Over BLE the car's speed (velocity: 0, no speedometer on these boards) and the throttle
    pulse it outputs come back through state(); position is not available there (None)."""
    with Vehicle("ble://", **BACKENDS) as host:
        host.drive(throttle=0.5)
        assert wait_for(lambda: outputs(car)[0] == 1750)
        state = host.state()
        assert state.speed_m_s == 0.0 and state.throttle_out_us == 1750.0
        assert state.x_m is None and state.yaw_rad is None and host.lidar() is None
        assert host.wait_for(timeout_s=0.2) is None  # BLE carries no reply lines


def test_a_ble_car_is_recorded_like_any_other(car, tmp_path):
    pytest.importorskip("foxglove", reason="pip install foxglove-sdk (the project's record extra)")
    from roar.replay import messages, read_log

    path = tmp_path / "ble.mcap"
    with Vehicle("ble://", record=path, **BACKENDS) as v:
        v.drive(throttle=0.5, steering=-0.5)
        assert wait_for(lambda: outputs(car) == (1750, 1250))
        time.sleep(0.1)
    sent = [(m["throttle_us"], m["steering_us"]) for _, _, m in messages(path, ["/control"])]
    assert (1750, 1250) in sent and sent[-1] == (1500, 1500)  # what went over the air, neutral last
    assert len(sent) == len(car.writes)  # every write the car got, recorded once
    assert read_log(path).metadata["run"]["clock"] == "monotonic"


# --- signed control and pairing over BLE ---------------------------------------------------------

KEY = bytes(range(16))


def start_car(radio, **kw):
    async def start():
        c = BleCar(radio, **kw)
        await c.start()
        return c

    return run_sync(start())


def keyed_car(radio, **kw):
    """A car whose key was set over its USB serial port (then rebooted: its session is 2)."""
    from roar_sim.core.car import CarBoard

    board = CarBoard()
    board.begin()
    board.serial_in(b"KEY " + KEY.hex().encode() + b"\n")
    board.run(3)
    assert board.serial_out().decode().splitlines()[-2].startswith("KEY ")
    return start_car(radio, nvm=board.nvm, **kw)


def test_a_keyed_car_over_ble_takes_only_signed_messages_in_pieces(radio):
    """The host reads the session from the session characteristic and signs; a signed message
    (up to 34 bytes) longer than a default link's 20-byte writes goes in pieces. A car whose
    stack cannot pair (the Nano 33 BLE's): the signing host goes on unencrypted."""
    car = keyed_car(radio, secure=False)
    try:
        assert car.board.session == 2
        with Vehicle("ble://", key=KEY, **BACKENDS) as v:
            v.drive(throttle=0.5, steering=-0.5)
            assert wait_for(lambda: outputs(car) == (1750, 1250))
            assert v.signer.session == 2 and v.signer.refused == 0
        assert car.writes and all(re.fullmatch(rb"\(\d{4},\d{4},[0-9a-f]{1,8},[0-9a-f]{12}\)", w) for w in car.writes)
        with Vehicle("ble://", key=False, **BACKENDS) as v:  # an unsigned host: refused
            v.drive(throttle=0.5)
            time.sleep(0.6)
            assert outputs(car) == (1500, 1500) and car.outputs.latched
        assert "ERR unsigned 00000002" in car.replies
        with Vehicle("ble://", key=bytes(16), **BACKENDS) as v:  # another key: forged
            v.drive(throttle=0.5)
            time.sleep(0.6)
            assert outputs(car) == (1500, 1500)
        assert "ERR forged 00000002" in car.replies
        # ATT payloads of 20 bytes (a link without an MTU exchange): the pieces join
        class SmallMtu(BumbleClient):
            @property
            def mtu_size(self):
                return 23

        time.sleep(0.2)  # (the last host's last messages are answered)
        before, replies_before = len(car.writes), len(car.replies)
        with Vehicle("ble://", key=KEY, scanner_backend=BumbleScanner, client_backend=SmallMtu) as v:
            v.drive(throttle=0.2)
            assert wait_for(lambda: outputs(car) == (1600, 1500))
        assert max(len(w) for w in car.writes[before:]) == 20
        assert not [r for r in car.replies[replies_before:] if r.startswith("ERR")]
        # BLE cannot clear the key
        with Vehicle("ble://", key=KEY, **BACKENDS) as v:
            v.transport.link.write(b"\nKEY -\n")
            time.sleep(0.1)
        assert car.board.session == 2
    finally:
        run_sync(car.stop())


def test_a_car_that_asks_for_encryption_pairs_with_le_secure_connections(radio):
    car = start_car(radio, secure=True)
    try:
        with Vehicle("ble://", reconnect=False, **BACKENDS) as v:  # not paired: the car drops every write
            v.drive(throttle=0.5)
            time.sleep(0.5)
        assert car.writes == [] and outputs(car) == (1500, 1500)
        with Vehicle("ble://?pair=1", **BACKENDS) as v:
            v.drive(throttle=0.5)
            assert wait_for(lambda: outputs(car) == (1750, 1500))
        assert car.write_links and set(car.write_links) == {(True, True)}  # encrypted, Secure Connections
    finally:
        run_sync(car.stop())


def test_a_keyed_car_asks_for_encryption_and_a_signing_host_pairs_by_itself(radio):
    """As the ESP32-CAM car's glue: with a key, the control and session characteristics need an
    encrypted link. A host with the key pairs (LE Secure Connections) without being told; a host
    without it, unpaired, is not heard at all."""
    car = keyed_car(radio)
    try:
        assert car.secure
        with Vehicle("ble://", key=KEY, **BACKENDS) as v:
            v.drive(throttle=0.5)
            assert wait_for(lambda: outputs(car) == (1750, 1500))
            assert v.transport.link.encrypted and v.signer.session == 2
        assert car.write_links and set(car.write_links) == {(True, True)}
        before = len(car.writes)
        with Vehicle("ble://", key=False, reconnect=False, **BACKENDS) as v:
            v.drive(throttle=0.5)
            time.sleep(0.5)
        assert len(car.writes) == before and outputs(car) == (1500, 1500)
    finally:
        run_sync(car.stop())
