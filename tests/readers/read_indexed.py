"""Reads an MCAP log with the Python `mcap` reader's seeking path (through the summary's chunk
and message indexes, CRCs checked) and its stream reader, and prints both as JSON:
{"statistics": N, "indexed": [[topic, sequence, log_time, data]...], "stream": [...]}.
Usage: python read_indexed.py LOG"""
import json
import sys

from mcap.reader import SeekingReader
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader

with open(sys.argv[1], "rb") as f:
    reader = SeekingReader(f, validate_crcs=True)
    summary = reader.get_summary()
    out = {"statistics": summary.statistics.message_count if summary and summary.statistics else -1,
           "chunk_indexes": len(summary.chunk_indexes) if summary else 0, "indexed": [], "stream": []}
    for _schema, channel, m in reader.iter_messages(log_time_order=True):
        out["indexed"].append([channel.topic, m.sequence, str(m.log_time), m.data.decode()])
with open(sys.argv[1], "rb") as f:
    topics = {}
    for r in StreamReader(f, skip_magic=False, validate_crcs=True).records:
        if isinstance(r, Channel):
            topics[r.id] = r.topic
        elif isinstance(r, Message):
            out["stream"].append([topics[r.channel_id], r.sequence, str(r.log_time), r.data.decode()])
json.dump(out, sys.stdout)
