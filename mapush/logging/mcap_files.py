"""Reading mapush's MCAP files, finished or cut: summaries, recovery of killed files, training scalars.

A file whose writer was killed has no footer or index, so indexed readers (Foxglove's among them) refuse it; every
complete record before the cut is still there. `recover` streams those records into a new,
indexed file; the other readers here fall back to the same streaming when the index is missing.
"""

from __future__ import annotations

import json
import signal
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from mcap.exceptions import InvalidMagic
from mcap.reader import make_reader
from mcap.records import Attachment, Channel, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from mapush.atomic import replacing
from mapush.errors import BadInput

THREADS_TAG = "Perf/threads"
"""Each iteration's MuJoCo threads, beside its times: what its wall time is multiplied by to count core-seconds."""
CPU_TAG = "Perf/cpu_s"
"""Each iteration's CPU seconds (the process's, every thread): its core-seconds, however crowded the machine was."""


@dataclass
class Contents:
    """What `stream_records` found: schemas and channels by id, then messages, metadata and attachments."""

    schemas: dict[int, Schema]
    channels: dict[int, Channel]
    messages: list[Message]
    metadata: list[Metadata]
    attachments: list[Attachment]
    complete: bool  # the file ended with its footer


def exit_on_sigterm() -> None:
    """Turn SIGTERM into SystemExit so that `finally` blocks close the MCAP files being written."""
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))


def _check_file(path: Path) -> None:
    if not Path(path).is_file():
        raise BadInput(f"{str(path)!r} is not a file; valid: an .mcap file written by mapush")


def stream_records(path: Path) -> Contents:
    """Every complete record of `path`, read sequentially; stops at the first broken or missing one."""
    _check_file(path)
    found = Contents({}, {}, [], [], [], complete=False)
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f, validate_crcs=True, record_size_limit=1 << 31).records:  # a torn chunk: cut
                if isinstance(record, Schema):
                    found.schemas[record.id] = record
                elif isinstance(record, Channel):
                    found.channels[record.id] = record
                elif isinstance(record, Message):
                    found.messages.append(record)
                elif isinstance(record, Metadata):
                    found.metadata.append(record)
                elif isinstance(record, Attachment):
                    found.attachments.append(record)
            found.complete = True
        except InvalidMagic:
            raise BadInput(f"{str(path)!r} is not an MCAP file (bad magic); valid: an .mcap file") from None
        except Exception:  # the cut: a truncated record or a placeholder length
            pass
    return found


def is_complete(path: Path) -> bool:
    """Whether the indexed reader accepts the file (it has its footer and summary)."""
    try:
        with open(path, "rb") as f:
            make_reader(f).get_summary()
        return True
    except Exception:
        return False


def summary(path: Path) -> dict:
    """Topics with schema and message count, the time span, and whether the file is complete (or was cut)."""
    contents = stream_records(path)
    counts: dict[int, int] = {}
    for message in contents.messages:
        counts[message.channel_id] = counts.get(message.channel_id, 0) + 1
    times = [m.log_time for m in contents.messages]
    topics = {}
    for channel_id, channel in sorted(contents.channels.items(), key=lambda kv: kv[1].topic):
        schema = contents.schemas.get(channel.schema_id)
        topics[channel.topic] = {"schema": schema.name if schema else "", "messages": counts.get(channel_id, 0)}
    return {
        "file": str(path),
        "complete": contents.complete and is_complete(path),
        "messages": len(contents.messages),
        "start_ns": min(times) if times else None,
        "end_ns": max(times) if times else None,
        "duration_s": (max(times) - min(times)) / 1e9 if times else 0.0,
        "topics": topics,
        "metadata": [m.name for m in contents.metadata],
        "attachments": [a.name for a in contents.attachments],
    }


def recover(source: Path, target: Path) -> dict:
    """Write every complete record of `source` (typically a killed writer's file) to an indexed `target`.

    Raises BadInput when nothing can be recovered: no empty file is ever written.
    """
    contents = stream_records(source)
    if not contents.messages and not contents.metadata and not contents.attachments:
        raise BadInput(f"{str(source)!r} holds no complete message, metadata or attachment; nothing to recover")
    target = Path(target)
    with replacing(target) as tmp, open(tmp, "wb") as f:
        writer = Writer(f, chunk_size=256 * 1024, compression=CompressionType.ZSTD)
        writer.start(profile="", library="mapush recover")
        schema_ids = {
            old: writer.register_schema(s.name, s.encoding, s.data) for old, s in sorted(contents.schemas.items())
        }
        channel_ids = {
            old: writer.register_channel(c.topic, c.message_encoding, schema_ids.get(c.schema_id, 0), c.metadata)
            for old, c in sorted(contents.channels.items())
        }
        for m in contents.messages:
            if m.channel_id in channel_ids:
                writer.add_message(channel_ids[m.channel_id], m.log_time, m.data, m.publish_time, m.sequence)
        for meta in contents.metadata:
            writer.add_metadata(meta.name, meta.metadata)
        for a in contents.attachments:
            writer.add_attachment(a.create_time, a.log_time, a.name, a.media_type, a.data)
        writer.finish()
    return {"messages": len(contents.messages), "complete_source": contents.complete, "file": str(target)}


def repair_in_place(path: Path) -> bool:
    """Recover a cut file over itself (used when a killed run resumes); returns whether it needed it."""
    if is_complete(path):
        return False
    recover(path, path)
    return True


def iter_json(path: Path, topic_prefix: str = "") -> Iterator[tuple[str, int, dict]]:
    """(topic, log time, decoded JSON) of every JSON message under `topic_prefix`, from a finished or cut file."""
    contents = stream_records(path)
    for message in contents.messages:
        channel = contents.channels.get(message.channel_id)
        if channel and channel.message_encoding == "json" and channel.topic.startswith(topic_prefix):
            try:
                data = json.loads(message.data)
            except ValueError:  # torn inside a message: what came before it is what is complete
                return
            yield channel.topic, message.log_time, data


def _part_number(path: Path) -> int:
    """0 for `metrics.mcap`, k for `metrics.k.mcap` (the k-th resumption, see `next_free_path`)."""
    middle = path.name.split(".")[1:-1]
    return int(middle[0]) if middle and middle[0].isdigit() else 0


def metrics_parts(run_dir: Path) -> list[Path]:
    """A run's metrics files in the order they were written: `metrics.mcap`, then each resume's part."""
    return sorted(Path(run_dir).glob("metrics*.mcap"), key=_part_number)


def file_scalars(path: Path, prefix: str = "", into: dict | None = None) -> dict[str, dict[int, float]]:
    """The training scalars of one metrics file (whose tag starts with `prefix`), `{tag: {iteration: value}}`,
    added to `into` where given (an iteration it holds already is replaced)."""
    scalars = {} if into is None else into
    for topic, _, data in iter_json(path, "/metrics/" + prefix):
        scalars.setdefault(topic.removeprefix("/metrics/"), {})[int(data["iteration"])] = float(data["value"])
    return scalars


def training_scalars(run_dir: Path, prefix: str = "") -> dict[str, dict[int, float]]:
    """Every training scalar of a run (whose tag starts with `prefix`), `{tag: {iteration: value}}`, over
    `metrics.mcap` and its resumed parts.

    A resumed run repeats the iterations between its last checkpoint and the cut; the later file wins.
    """
    files = metrics_parts(run_dir)
    if not files:
        raise BadInput(f"{str(run_dir)!r} has no metrics.mcap; valid: a run dir made by `mapush train`")
    scalars: dict[str, dict[int, float]] = {}
    for path in files:
        file_scalars(path, prefix, into=scalars)
    return scalars
