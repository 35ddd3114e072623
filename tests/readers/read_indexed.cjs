// Reads an MCAP log with @mcap/core's indexed reader (through the summary's chunk and message
// indexes, as a viewer seeks) and with its stream reader, and prints both as JSON:
// {"statistics": N, "indexed": [[topic, sequence, log_time, data]...], "stream": [...]}.
// Usage: NODE_PATH=.../node_modules node read_indexed.cjs LOG
const fs = require("fs");
const { McapIndexedReader, McapStreamReader } = require("@mcap/core");

async function main() {
  const buf = fs.readFileSync(process.argv[2]);
  const readable = {
    size: async () => BigInt(buf.length),
    read: async (offset, size) => buf.subarray(Number(offset), Number(offset + size)),
  };
  const text = new TextDecoder();
  const indexed = await McapIndexedReader.Initialize({ readable });
  const out = { statistics: Number(indexed.statistics?.messageCount ?? -1), indexed: [], stream: [] };
  for await (const m of indexed.readMessages()) {
    const topic = indexed.channelsById.get(m.channelId).topic;
    out.indexed.push([topic, m.sequence, m.logTime.toString(), text.decode(m.data)]);
  }
  const stream = new McapStreamReader({ validateCrcs: true });
  stream.append(buf);
  const topics = new Map();
  for (let r = stream.nextRecord(); r; r = stream.nextRecord()) {
    if (r.type === "Channel") topics.set(r.id, r.topic);
    if (r.type === "Message") out.stream.push([topics.get(r.channelId), r.sequence, r.logTime.toString(), text.decode(r.data)]);
  }
  process.stdout.write(JSON.stringify(out));
}

main().catch((e) => {
  console.error(e);
  process.exit(1);
});
