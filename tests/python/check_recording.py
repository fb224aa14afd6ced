"""An independent reader of seacover's recordings: Foxglove's `mcap`
package (PyPI `mcap`) and `jsonschema`, nothing of seacover's.

    python check_recording.py FILE

Reads every message — through the summary's index when the file has one,
and, for a file cut short (no summary, no end magic), record by record as
the mcap CLI's recover does, stopping at the first incomplete record — and
validates each one against its channel's JSON Schema. Prints one JSON
object: whether the file was finished, the channels with their schema
names and message counts, the number of messages that failed validation
(with the first few errors), and the log time span.
"""

import json
import sys

import jsonschema
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap.records import Channel, Message, Schema


def read(path):
    """Yields (schema, channel, message) for every readable message."""
    with open(path, "rb") as f:
        data = f.read()
    finished = data.endswith(b"\x89MCAP0\r\n") and len(data) > 16
    if finished:
        with open(path, "rb") as f:
            reader = make_reader(f)
            for schema, channel, message in reader.iter_messages(log_time_order=False):
                yield finished, schema, channel, message
        return
    # Recovery: the stream reader yields records until the cut; chunks are
    # decompressed by it; an incomplete trailing record raises.
    schemas, channels = {}, {}
    import io

    stream = StreamReader(io.BytesIO(data), skip_magic=False, emit_chunks=False)
    try:
        for record in stream.records:
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
            elif isinstance(record, Message):
                channel = channels[record.channel_id]
                yield finished, schemas.get(channel.schema_id), channel, record
    except (McapError, EOFError, ValueError, Exception) as e:  # the cut
        sys.stderr.write(f"recovered up to the cut: {type(e).__name__}: {e}\n")


def main(path):
    counts, schema_names, validators = {}, {}, {}
    invalid, errors = 0, []
    finished = None
    start = end = None
    for fin, schema, channel, message in read(path):
        finished = fin
        topic = channel.topic
        counts[topic] = counts.get(topic, 0) + 1
        if schema is None:
            invalid += 1
            errors.append(f"{topic}: no schema")
            continue
        schema_names[topic] = schema.name
        if topic not in validators:
            assert schema.encoding == "jsonschema", schema.encoding
            assert channel.message_encoding == "json", channel.message_encoding
            document = json.loads(schema.data)
            jsonschema.validators.validator_for(document).check_schema(document)
            validators[topic] = jsonschema.validators.validator_for(document)(document)
        try:
            validators[topic].validate(json.loads(message.data))
        except jsonschema.ValidationError as e:
            invalid += 1
            if len(errors) < 5:
                errors.append(f"{topic}: {e.message}")
        t = message.log_time
        start = t if start is None else min(start, t)
        end = t if end is None else max(end, t)
    print(
        json.dumps(
            {
                "finished": bool(finished),
                "counts": counts,
                "schemas": schema_names,
                "invalid": invalid,
                "errors": errors,
                "start_ns": start,
                "end_ns": end,
            }
        )
    )


if __name__ == "__main__":
    main(sys.argv[1])
