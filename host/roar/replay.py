"""Reading a recording back (roar.recorder's MCAP files): what it holds, per channel the count,
rate and longest gap, with the mcap library's reader. A file that is not one ends in one line
(ReplayError): missing, empty, not MCAP, cut off, or another program's recording.

    log = read_log("run.mcap")       # .metadata, .channels {topic: ChannelStats}, .duration_s
    print(summary("run.mcap"))
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path

from roar.errors import RoarError

MAGIC = b"\x89MCAP0\r\n"  # the first bytes of every MCAP file (mcap.dev's specification)


class ReplayError(RoarError):
    """A recording that cannot be read (one line)."""


@dataclass
class ChannelStats:
    topic: str
    schema: str
    count: int = 0
    first_ns: int = 0
    last_ns: int = 0
    longest_gap_ns: int = 0

    @property
    def rate_hz(self) -> float:
        span = (self.last_ns - self.first_ns) / 1e9
        return (self.count - 1) / span if self.count > 1 and span > 0 else 0.0


@dataclass
class Log:
    path: Path
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)  # record name -> fields
    channels: dict[str, ChannelStats] = field(default_factory=dict)
    start_ns: int = 0
    end_ns: int = 0

    @property
    def duration_s(self) -> float:
        return (self.end_ns - self.start_ns) / 1e9

    @property
    def messages(self) -> int:
        return sum(c.count for c in self.channels.values())


def open_reader(path: str | Path):
    """(file, mcap reader) of a roar recording, or ReplayError in one line."""
    from mcap.reader import make_reader

    path = Path(path)
    try:
        f = open(path, "rb")
    except FileNotFoundError:
        raise ReplayError(f"{path}: no such file") from None
    except OSError as e:
        raise ReplayError(f"{path}: cannot be read ({e.strerror})") from None
    head = f.read(len(MAGIC))
    if not head:
        f.close()
        raise ReplayError(f"{path}: the file is empty (a recording that never started?)")
    if head != MAGIC:
        f.close()
        raise ReplayError(f"{path}: not an MCAP file (it does not start as one)")
    f.seek(0)
    return f, make_reader(f)


def read_log(path: str | Path) -> Log:
    """Everything but the messages' contents: metadata, and per channel its statistics."""
    from mcap.exceptions import McapError

    f, reader = open_reader(path)
    log = Log(Path(path))
    try:
        with f:
            for record in reader.iter_metadata():
                log.metadata[record.name] = dict(record.metadata)
            last: dict[str, int] = {}
            for schema, channel, message in reader.iter_messages(log_time_order=False):
                stats = log.channels.get(channel.topic)
                t = message.log_time
                if stats is None:
                    stats = log.channels[channel.topic] = ChannelStats(channel.topic, schema.name if schema else "",
                                                                       first_ns=t, last_ns=t)
                else:
                    stats.longest_gap_ns = max(stats.longest_gap_ns, t - last[channel.topic])
                    stats.first_ns, stats.last_ns = min(stats.first_ns, t), max(stats.last_ns, t)
                last[channel.topic] = t
                stats.count += 1
    except (McapError, EOFError, ValueError, struct.error) as e:
        raise ReplayError(f"{path}: cut off or damaged ({e}): a recording that was not finished") from None
    if log.metadata.get("run", {}).get("recorder") != "roar":
        topics = ", ".join(sorted(log.channels)[:5]) or "none"
        raise ReplayError(f"{path}: not a roar recording (no run metadata from roar; its channels: {topics})")
    if log.channels:
        log.start_ns = min(c.first_ns for c in log.channels.values())
        log.end_ns = max(c.last_ns for c in log.channels.values())
    return log


def messages(path: str | Path, topics: list[str] | None = None):
    """(topic, log time [ns], message) of a recording in time order: JSON channels as dicts,
    protobuf ones (Foxglove's types) as protobuf messages built from the file's own schemas."""
    import json

    from mcap.exceptions import McapError

    f, reader = open_reader(path)
    decoders: dict[int, object] = {}
    with f:
        try:
            for schema, channel, message in reader.iter_messages(topics=topics):
                decode = decoders.get(channel.id)
                if decode is None:
                    decode = decoders[channel.id] = json.loads if channel.message_encoding == "json" else \
                        _protobuf_decoder(schema)
                yield channel.topic, message.log_time, decode(message.data)
        except (McapError, EOFError, ValueError, struct.error) as e:
            raise ReplayError(f"{path}: cut off or damaged ({e}): a recording that was not finished") from None


def _protobuf_decoder(schema):
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    if schema is None or schema.encoding != "protobuf":
        raise ReplayError(f"a channel whose schema is {getattr(schema, 'encoding', 'missing')}: not roar's")
    pool = descriptor_pool.DescriptorPool()
    for file in descriptor_pb2.FileDescriptorSet.FromString(schema.data).file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name)).FromString


def summary(path: str | Path) -> str:
    log = read_log(path)
    run = log.metadata.get("run", {})
    clock = run.get("clock", "?")
    lines = [f"{log.path}: {log.duration_s:.2f} s of {clock} time, {log.messages:,} messages; car "
             f"{run.get('car', '?')}" + (f", protocol {log.metadata['car']['protocol_version']}"
                                          if "protocol_version" in log.metadata.get("car", {}) else "")]
    if run.get("command"):
        lines.append(f"  recorded by: {run['command']}")
    width = max([len(t) for t in log.channels] + [7])
    lines.append(f"  {'channel':<{width}}  {'schema':<26} {'messages':>8} {'rate':>9} {'longest gap':>12}")
    for topic in sorted(log.channels):
        c = log.channels[topic]
        lines.append(f"  {topic:<{width}}  {c.schema:<26} {c.count:>8,} {c.rate_hz:>6.1f} Hz {c.longest_gap_ns / 1e9:>10.3f} s")
    return "\n".join(lines)
