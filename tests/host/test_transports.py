"""Car URLs and the transport registry."""

import pytest

from roar import transports
from roar.transports import Transport, TransportError, open_url, parse_url, register


@pytest.mark.parametrize("url, expected", [
    ("serial:///dev/ttyUSB0?baud=9600", ("serial", "/dev/ttyUSB0", {"baud": "9600"})),
    ("serial://COM3", ("serial", "COM3", {})),
    ("ble://ROAR%20Car", ("ble", "ROAR Car", {})),
    ("ble://ROAR Car", ("ble", "ROAR Car", {})),
    ("ble://AA:BB:CC:DD:EE:FF?timeout=3", ("ble", "AA:BB:CC:DD:EE:FF", {"timeout": "3"})),
    ("SIM://oval?speedup=2&gui=1", ("sim", "oval", {"speedup": "2", "gui": "1"})),
    ("sim:///home/me/t.json", ("sim", "/home/me/t.json", {})),
    ("loop://", ("loop", "", {})),
])
def test_urls_parse(url, expected):
    assert parse_url(url) == expected


@pytest.mark.parametrize("url, words", [
    ("/dev/ttyUSB0", "not a car URL"),
    ("tcp://host:1", "unknown URL scheme 'tcp://': use one of ble://, http://, loop://, serial://, sim://"),
    ("serial://", "needs a port"),
    ("serial:///dev/ttyUSB0?baud=fast", "baud='fast' is not a valid int"),
    ("serial:///dev/ttyUSB0?parity=E", "unknown option(s) parity"),
    ("loop://?fail_after=1&fail_after=2", "given twice"),
    ("sim://?speedup=50", "speedup must be"),
    ("sim://?plot=out.jpg", "plot: must name a .png"),
    ("sim://?trace=", "trace= is empty: give a file name"),
    ("sim://?profile=", "profile= is empty"),
    ("sim://?profile=warp", "no car profile 'warp': use f1tenth, iarrc, roar or a .toml file"),
    ("sim://?robot=junior&profile=f1tenth", "no ROAR Junior profile 'f1tenth': use junior or a .toml file"),
    ("ble://?timeout=-1", "timeout must be"),
])
def test_bad_urls_give_one_line_errors(url, words):
    with pytest.raises(TransportError) as e:
        open_url(url)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_opening_a_missing_serial_port_says_so():
    t = open_url("serial:///dev/does-not-exist")
    with pytest.raises(TransportError, match="cannot open serial port /dev/does-not-exist: .*No such file"):
        t.open()


def test_sim_with_an_unknown_track_says_so():
    t = open_url("sim://monza")
    with pytest.raises(TransportError, match="unknown track 'monza'"):
        t.open()


def test_sim_takes_a_car_profile_so_one_url_drives_a_fitted_car():
    """sim://?profile= loads the ESC car with a profile's numbers, and the car's model (what an
    autopilot plans with) has that car's limits: the F1TENTH-like car is the faster."""
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    models = {}
    for name in ("roar", "f1tenth"):
        t = open_url(f"sim://oval?profile={name}")
        t.open()
        try:
            assert t.sim.profile.name == name
            models[name] = t.model()
        finally:
            t.close()
    assert models["f1tenth"].limits.max_speed_m_s > 2 * models["roar"].limits.max_speed_m_s


class Recorder(Transport):
    scheme = "rec"

    def __init__(self, name):
        self.name, self.data = name, []

    @classmethod
    def from_url(cls, target, options):
        return cls(target)

    def open(self):
        pass

    def write(self, data):
        self.data.append(data)

    def close(self):
        pass


def test_new_transports_plug_in_by_scheme():
    register("rec", Recorder)
    try:
        t = open_url("rec://box")
        assert isinstance(t, Recorder) and t.name == "box" and t.url == "rec://box"
        assert "rec" in transports.schemes()
    finally:
        transports.registry._REGISTRY.pop("rec")


def test_transports_registered_by_module_path_load_lazily():
    register("rec2", "test_transports:Recorder")
    try:
        assert isinstance(open_url("rec2://x"), Recorder)
    finally:
        transports.registry._REGISTRY.pop("rec2")


def test_installed_packages_add_transports_through_entry_points(monkeypatch):
    from importlib.metadata import EntryPoint

    registry = transports.registry
    monkeypatch.setattr(registry, "_entry_points_loaded", False)
    monkeypatch.setattr("importlib.metadata.entry_points", lambda group: [
        EntryPoint("plugin", "test_transports:Recorder", group)] if group == registry.ENTRY_POINT_GROUP else [])
    try:
        assert isinstance(open_url("plugin://x"), Recorder)
    finally:
        registry._REGISTRY.pop("plugin", None)


class _QueryLink(Transport):
    """A link whose car takes another form (as the Junior's queries): it signs through `signer`,
    answers each message, and has a session to tell."""

    scheme = "query"
    signs_itself = True

    def __init__(self) -> None:
        self.sent: list[str] = []

    @classmethod
    def from_url(cls, target, options):
        return cls()

    def open(self) -> None:
        pass

    def write(self, data: bytes) -> None:
        self.sent.append(self.signer.sign_query(data.decode()) if self.signer else data.decode())

    def close(self) -> None:
        pass

    def car_session(self):
        return (0x1234, 7)


def test_a_link_declares_what_the_layers_ask_and_the_layers_pass_it_through():
    """Transport declares the signing hooks, the autopilots and `link`, so no layer probes a link
    with hasattr: a plain link answers with its defaults, a layer with its link's answers."""
    from roar.transports.recording import RecordingTransport
    from roar.transports.signing import SigningTransport

    plain = open_url("loop://")
    assert (plain.signs_itself, plain.signer, plain.signing) == (False, None, False)
    assert plain.refusal() is None and plain.car_session() is None and plain.autopilots == () and plain.link is plain
    with pytest.raises(TransportError, match="no autopilot 'lane'"):
        plain.autopilot("lane")
    signed = SigningTransport(plain, bytes(16))
    recorded = RecordingTransport(signed, None)
    assert recorded.link is plain and recorded.scheme == "loop" and recorded.replies == plain.replies
    assert plain.signing and plain.signer is None  # a link of control messages is signed by the layer
    recorded.open()
    assert recorded.refusal() is None and recorded.car_session() is None and recorded.autopilots == ()
    assert recorded.messages is not None  # what a link offers beyond the interface passes through too

    query = _QueryLink()
    layer = SigningTransport(query, bytes(16))
    assert query.signer is layer and query.signing
    layer.open()  # no reply lines: the layer asks the link for the car's session
    assert layer.session == 0x1234 and layer.counter == 7
    layer.write(b"(1500,1500)")
    assert "ctr=" in query.sent[-1] and "mac=" in query.sent[-1]  # the link signed its own form


def test_a_phone_on_other_ports_is_reached_at_them():
    """udp://HOST?ports=R,D,S,C: the streams asked for and the control sent at those ports; a
    ports option that is not four ports is one line."""
    from roar.transports import TransportError, open_url

    link = open_url("udp://127.0.0.1?ports=9101,9102,9103,9104")
    assert link.ports == {"rgb": 9101, "depth": 9102, "state": 9103, "control": 9104}
    assert open_url("udp://127.0.0.1").ports == {"rgb": 8001, "depth": 8002, "state": 8003, "control": 8004}
    for bad in ("9101,9102,9103", "a,b,c,d", "0,1,2,3", "9101,9102,9103,70000"):
        with pytest.raises(TransportError, match="takes four ports 1..65535"):
            open_url(f"udp://127.0.0.1?ports={bad}")
