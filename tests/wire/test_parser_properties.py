"""Properties of both streaming parsers, and the differential test: the C++ firmware parser
(through the C ABI) and the Python host decoder agree on every generated stream."""

from hypothesis import given
from hypothesis import strategies as st

from roar.protocol import ParseResult, StreamDecoder, encode
from roar.protocol import spec
from roar_sim.core import car

# Streams made of protocol-ish pieces find the interesting states far more often than
# uniform random bytes; raw binary is mixed in too.
pieces = st.one_of(
    st.builds(lambda t, s: encode(t, s), st.integers(1000, 2000), st.integers(1000, 2000)),
    st.builds(lambda t, s: f"({t},{s})".encode(), st.integers(0, 99999), st.integers(0, 99999)),
    st.builds(lambda v, s: f"[{v},{s}]".encode(), st.integers(-6000, 6000), st.integers(900, 2100)),
    st.sampled_from([b"(", b")", b",", b"\n", b"\r", b" ", b"\0", b"\t", b"-", b".", b"((", b"))", b",,", b"[", b"]",
                     b"[-", b"--"]),
    st.binary(max_size=16),
    st.text(alphabet="()[]-0123456789,\n", max_size=20).map(str.encode),
)
streams = st.lists(pieces, max_size=40).map(b"".join)


def chunked(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({c % (len(data) + 1) for c in cuts})
    bounds = [0, *points, len(data)]
    return [data[a:b] for a, b in zip(bounds, bounds[1:])]


def feed_all(parser, chunks):
    events = []
    for c in chunks:
        events += parser.feed(c)
    return events


@given(streams, st.lists(st.integers(0, 10_000), max_size=8), st.lists(st.integers(0, 10_000), max_size=8))
def test_cpp_and_python_agree(data, cuts_py, cuts_cpp):
    """Same events, at the same offsets, however each side's input is split into reads."""
    py = feed_all(StreamDecoder(), chunked(data, cuts_py))
    cpp = feed_all(car.ControlParser(), chunked(data, cuts_cpp))
    assert cpp == py


@given(st.binary(max_size=512))
def test_arbitrary_bytes_agree_and_stay_in_range(data):
    py = StreamDecoder().feed(data)
    cpp = car.ControlParser().feed(data)
    assert cpp == py
    for ev in py:
        assert ev.result != ParseResult.NONE
        if ev.result == ParseResult.OK:
            assert spec.CONTROL_MIN_US <= ev.command.throttle_us <= spec.CONTROL_MAX_US
            assert spec.CONTROL_MIN_US <= ev.command.steering_us <= spec.CONTROL_MAX_US


@given(streams)
def test_ok_events_are_exactly_the_valid_messages(data):
    """Every accepted command is the 11-byte valid message ending at that byte: nothing partial."""
    for ev in StreamDecoder().feed(data):
        if ev.result == ParseResult.OK:
            start = ev.at + 1 - spec.CONTROL_MAX_MESSAGE_BYTES
            assert start >= 0 and data[start:ev.at + 1] == encode(ev.command.throttle_us, ev.command.steering_us)


@given(streams, st.integers(1000, 2000), st.integers(1000, 2000))
def test_valid_message_after_any_garbage_and_a_line_end_is_accepted(garbage, t, s):
    events = StreamDecoder().feed(garbage + b"\n" + encode(t, s))
    assert events[-1].result == ParseResult.OK
    assert (events[-1].command.throttle_us, events[-1].command.steering_us) == (t, s)


@given(streams)
def test_at_most_one_event_per_byte_and_offsets_increase(data):
    events = car.ControlParser().feed(data)
    ats = [e.at for e in events]
    assert ats == sorted(set(ats))
