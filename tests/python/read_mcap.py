"""Summarise an MCAP flight log with the reference Python `mcap` reader.

Usage: read_mcap.py FILE.mcap

Prints one JSON document to stdout:
    {"topics": {TOPIC: {"schema_name", "schema_encoding", "message_encoding", "count",
                        "summary_count", "first", "last",
                        "first_log_time_ns", "last_log_time_ns"}}}
`count` is what iterating the messages found, `summary_count` what the file's statistics
record says; `first`/`last` are the decoded JSON messages. The Rust test suite compares this
with Kestrel's own reader, so the log is known to read the same outside our code.
"""

import json
import sys

from mcap.reader import make_reader


def summarise(path):
    topics = {}
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        stats = summary.statistics if summary is not None else None
        for schema, channel, message in reader.iter_messages():
            decoded = json.loads(message.data)
            topic = topics.get(channel.topic)
            if topic is None:
                summary_count = None
                if stats is not None:
                    summary_count = stats.channel_message_counts.get(channel.id)
                topic = topics[channel.topic] = {
                    "schema_name": schema.name if schema is not None else "",
                    "schema_encoding": schema.encoding if schema is not None else "",
                    "message_encoding": channel.message_encoding,
                    "count": 0,
                    "summary_count": summary_count,
                    "first": decoded,
                    "first_log_time_ns": message.log_time,
                }
            topic["count"] += 1
            topic["last"] = decoded
            topic["last_log_time_ns"] = message.log_time
    return {"topics": topics}


def topic_span(path, topic):
    """The topic names of the log and the first and last decoded message on `topic`, reading
    only that topic's messages (a quick look at a long log)."""
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        names = sorted({c.topic for c in summary.channels.values()}) if summary is not None else []
        first = last = None
        for _, _, message in reader.iter_messages(topics=[topic]):
            last = json.loads(message.data)
            if first is None:
                first = last
    return {"topics": names, "first": first, "last": last}


def main():
    if len(sys.argv) != 2:
        print("usage: read_mcap.py FILE.mcap", file=sys.stderr)
        return 2
    json.dump(summarise(sys.argv[1]), sys.stdout, indent=1, sort_keys=True)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
