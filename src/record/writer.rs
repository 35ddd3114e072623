//! A durable, failure-safe writer of indexed MCAP files.
//!
//! The mcap crate's writer cannot take back a record once written (its statistics and data
//! CRC already count it), so a failed write would leave its bytes queued for the next one.
//! This writer builds each commit (one event's messages) as one buffer, writes it at the
//! end of the last good commit, and syncs; if anything fails it truncates the file back to
//! that offset, so the file is exactly the acknowledged commits and a retry writes each
//! message once. The layout is MCAP's (<https://mcap.dev/spec>): magic, header, then per
//! commit its new schemas, channels and attachments followed by one uncompressed chunk of its
//! messages (with its CRC) and the chunk's message indexes; on `finish` a data end with the
//! data section's CRC, a summary (schemas, channels, statistics, chunk indexes, attachment
//! index), summary offsets and a footer with the summary CRC. A reader that seeks through
//! the summary's indexes and one that streams the records read the same messages; a file cut
//! by a crash streams up to its last whole commit.

use std::collections::BTreeMap;
use std::io::{Seek, SeekFrom, Write};

/// Where a log's bytes go: a file, or a test double that fails on demand.
pub trait Sink: Write + Seek + Send {
    /// Makes everything written durable.
    fn sync(&mut self) -> std::io::Result<()>;
    /// Cuts the sink back to `len` bytes.
    fn truncate(&mut self, len: u64) -> std::io::Result<()>;
}

impl Sink for std::fs::File {
    fn sync(&mut self) -> std::io::Result<()> {
        self.sync_data()
    }

    fn truncate(&mut self, len: u64) -> std::io::Result<()> {
        self.set_len(len)
    }
}

impl<S: Sink + ?Sized> Sink for Box<S> {
    fn sync(&mut self) -> std::io::Result<()> {
        (**self).sync()
    }

    fn truncate(&mut self, len: u64) -> std::io::Result<()> {
        (**self).truncate(len)
    }
}

const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

mod op {
    pub(crate) const HEADER: u8 = 0x01;
    pub(crate) const FOOTER: u8 = 0x02;
    pub(crate) const SCHEMA: u8 = 0x03;
    pub(crate) const CHANNEL: u8 = 0x04;
    pub(crate) const MESSAGE: u8 = 0x05;
    pub(crate) const CHUNK: u8 = 0x06;
    pub(crate) const MESSAGE_INDEX: u8 = 0x07;
    pub(crate) const CHUNK_INDEX: u8 = 0x08;
    pub(crate) const ATTACHMENT: u8 = 0x09;
    pub(crate) const ATTACHMENT_INDEX: u8 = 0x0A;
    pub(crate) const STATISTICS: u8 = 0x0B;
    pub(crate) const SUMMARY_OFFSET: u8 = 0x0E;
    pub(crate) const DATA_END: u8 = 0x0F;
}

/// A record body under construction.
#[derive(Default)]
struct Body(Vec<u8>);

impl Body {
    fn u8(&mut self, v: u8) -> &mut Self {
        self.0.push(v);
        self
    }
    fn u16(&mut self, v: u16) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn u32(&mut self, v: u32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn u64(&mut self, v: u64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn str(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32);
        self.0.extend_from_slice(s.as_bytes());
        self
    }
    fn bytes32(&mut self, b: &[u8]) -> &mut Self {
        self.u32(b.len() as u32);
        self.0.extend_from_slice(b);
        self
    }
    fn raw(&mut self, b: &[u8]) -> &mut Self {
        self.0.extend_from_slice(b);
        self
    }
}

/// Appends one record (opcode, length, body) to `out`.
fn record(out: &mut Vec<u8>, opcode: u8, body: &Body) {
    out.push(opcode);
    out.extend_from_slice(&(body.0.len() as u64).to_le_bytes());
    out.extend_from_slice(&body.0);
}

struct SchemaRec {
    id: u16,
    name: String,
    encoding: String,
    data: Vec<u8>,
}

struct ChannelRec {
    id: u16,
    schema_id: u16,
    topic: String,
    encoding: String,
}

struct AttachmentRef {
    offset: u64,
    length: u64,
    log_time: u64,
    create_time: u64,
    data_size: u64,
    name: String,
    media_type: String,
}

/// Where a committed chunk is, for the summary's chunk index.
struct ChunkRef {
    start_time: u64,
    end_time: u64,
    offset: u64,
    length: u64,
    /// Per channel, the file offset of its message index record after the chunk.
    index_offsets: Vec<(u16, u64)>,
    index_length: u64,
    size: u64,
}

/// One message to write.
pub struct Message<'a> {
    pub channel: u16,
    pub sequence: u32,
    pub log_time: u64,
    pub data: &'a [u8],
}

/// Why a commit failed: the OS error, with the sink already cut back to the last good
/// commit (or the cut itself failed, and the file must not be written again).
#[derive(Debug)]
pub struct CommitError {
    pub source: std::io::Error,
    /// Whether the sink was restored to the last good commit.
    pub restored: bool,
}

/// An unchunked MCAP writer whose every commit is all-or-nothing and durable.
pub struct McapWriter<S: Sink> {
    sink: S,
    /// Length of the file up to the last durable commit.
    committed: u64,
    /// CRC of the data section up to `committed`.
    crc: crc32fast::Hasher,
    schemas: Vec<SchemaRec>,
    channels: Vec<ChannelRec>,
    attachments: Vec<AttachmentRef>,
    chunks: Vec<ChunkRef>,
    /// Messages per channel, and the first and last log time, of committed messages.
    counts: BTreeMap<u16, u64>,
    times: Option<(u64, u64)>,
    /// The records of the next commit outside its chunk (schemas, channels, attachments).
    staged: Vec<u8>,
    /// The message records of the next commit's chunk.
    staged_chunk: Vec<u8>,
    staged_attachments: Vec<AttachmentRef>,
    /// (channel, log time, offset in the chunk's records) of each staged message.
    staged_counts: Vec<(u16, u64, u64)>,
    /// Schemas and channels staged with the next commit (the summary lists only committed ones).
    staged_schemas: Vec<SchemaRec>,
    staged_channels: Vec<ChannelRec>,
    broken: bool,
}

impl<S: Sink> McapWriter<S> {
    /// Starts a file: magic and header, committed at once.
    pub fn new(sink: S, library: &str) -> Result<Self, CommitError> {
        let mut w = Self {
            sink,
            committed: 0,
            crc: crc32fast::Hasher::new(),
            schemas: Vec::new(),
            channels: Vec::new(),
            attachments: Vec::new(),
            chunks: Vec::new(),
            counts: BTreeMap::new(),
            times: None,
            staged: MAGIC.to_vec(),
            staged_chunk: Vec::new(),
            staged_attachments: Vec::new(),
            staged_counts: Vec::new(),
            staged_schemas: Vec::new(),
            staged_channels: Vec::new(),
            broken: false,
        };
        let mut h = Body::default();
        h.str("").str(library);
        record(&mut w.staged, op::HEADER, &h);
        w.commit()?;
        Ok(w)
    }

    /// Stages a schema; its id (kept only if the next commit succeeds).
    pub fn add_schema(&mut self, name: &str, encoding: &str, data: &[u8]) -> u16 {
        let id = (self.schemas.len() + self.staged_schemas.len()) as u16 + 1;
        let mut b = Body::default();
        b.u16(id).str(name).str(encoding).bytes32(data);
        record(&mut self.staged, op::SCHEMA, &b);
        self.staged_schemas.push(SchemaRec { id, name: name.into(), encoding: encoding.into(), data: data.to_vec() });
        id
    }

    /// Stages a channel; its id (kept only if the next commit succeeds).
    pub fn add_channel(&mut self, schema_id: u16, topic: &str, encoding: &str) -> u16 {
        let id = (self.channels.len() + self.staged_channels.len()) as u16;
        let mut b = Body::default();
        b.u16(id).u16(schema_id).str(topic).str(encoding).u32(0);
        record(&mut self.staged, op::CHANNEL, &b);
        self.staged_channels.push(ChannelRec { id, schema_id, topic: topic.into(), encoding: encoding.into() });
        id
    }

    /// Stages an attachment (with its CRC).
    pub fn attach(&mut self, log_time: u64, create_time: u64, name: &str, media_type: &str, data: &[u8]) {
        let mut b = Body::default();
        b.u64(log_time).u64(create_time).str(name).str(media_type).u64(data.len() as u64).raw(data);
        let crc = crc32fast::hash(&b.0);
        b.u32(crc);
        let offset = self.committed + self.staged.len() as u64;
        record(&mut self.staged, op::ATTACHMENT, &b);
        self.staged_attachments.push(AttachmentRef {
            offset,
            length: 9 + b.0.len() as u64,
            log_time,
            create_time,
            data_size: data.len() as u64,
            name: name.into(),
            media_type: media_type.into(),
        });
    }

    /// Stages a message (in the next commit's chunk).
    pub fn message(&mut self, m: &Message) {
        let mut b = Body::default();
        b.u16(m.channel).u32(m.sequence).u64(m.log_time).u64(m.log_time).raw(m.data);
        let offset = self.staged_chunk.len() as u64;
        record(&mut self.staged_chunk, op::MESSAGE, &b);
        self.staged_counts.push((m.channel, m.log_time, offset));
    }

    /// Appends the staged messages to `self.staged` as one chunk and its message indexes
    /// (channels in ascending order, each index's entries in message order); where it is.
    fn stage_chunk(&mut self) -> Option<ChunkRef> {
        if self.staged_counts.is_empty() {
            return None;
        }
        let records = std::mem::take(&mut self.staged_chunk);
        let start_time = self.staged_counts.iter().map(|c| c.1).min().unwrap_or(0);
        let end_time = self.staged_counts.iter().map(|c| c.1).max().unwrap_or(0);
        let offset = self.committed + self.staged.len() as u64;
        let mut chunk = Body::default();
        chunk
            .u64(start_time)
            .u64(end_time)
            .u64(records.len() as u64)
            .u32(crc32fast::hash(&records))
            .str("")
            .u64(records.len() as u64)
            .raw(&records);
        record(&mut self.staged, op::CHUNK, &chunk);
        let length = self.committed + self.staged.len() as u64 - offset;
        let mut per_channel: BTreeMap<u16, Vec<(u64, u64)>> = BTreeMap::new();
        for &(channel, time, at) in &self.staged_counts {
            per_channel.entry(channel).or_default().push((time, at));
        }
        let index_start = self.committed + self.staged.len() as u64;
        let mut index_offsets = Vec::with_capacity(per_channel.len());
        for (channel, entries) in per_channel {
            index_offsets.push((channel, self.committed + self.staged.len() as u64));
            let mut b = Body::default();
            b.u16(channel).u32(entries.len() as u32 * 16);
            for (time, at) in entries {
                b.u64(time).u64(at);
            }
            record(&mut self.staged, op::MESSAGE_INDEX, &b);
        }
        let index_length = self.committed + self.staged.len() as u64 - index_start;
        Some(ChunkRef { start_time, end_time, offset, length, index_offsets, index_length, size: records.len() as u64 })
    }

    /// Writes everything staged at the end of the last good commit and syncs. On failure
    /// the sink is cut back to the last good commit and the staged records are dropped.
    pub fn commit(&mut self) -> Result<(), CommitError> {
        if self.broken {
            return Err(CommitError {
                source: std::io::Error::other("an earlier failure could not be undone; the log is closed"),
                restored: false,
            });
        }
        let chunk = self.stage_chunk();
        let staged = std::mem::take(&mut self.staged);
        let result = self
            .sink
            .seek(SeekFrom::Start(self.committed))
            .and_then(|_| self.sink.write_all(&staged))
            .and_then(|()| self.sink.flush())
            .and_then(|()| self.sink.sync());
        match result {
            Ok(()) => {
                self.committed += staged.len() as u64;
                self.crc.update(&staged);
                self.attachments.append(&mut self.staged_attachments);
                self.schemas.append(&mut self.staged_schemas);
                self.channels.append(&mut self.staged_channels);
                self.chunks.extend(chunk);
                for (channel, t, _) in self.staged_counts.drain(..) {
                    *self.counts.entry(channel).or_default() += 1;
                    self.times = Some(self.times.map_or((t, t), |(a, b)| (a.min(t), b.max(t))));
                }
                Ok(())
            }
            Err(source) => {
                self.staged_attachments.clear();
                self.staged_counts.clear();
                self.staged_schemas.clear();
                self.staged_channels.clear();
                let restored = self.sink.truncate(self.committed).and_then(|()| self.sink.sync()).is_ok();
                self.broken = !restored;
                Err(CommitError { source, restored })
            }
        }
    }

    /// Bytes durably written.
    #[cfg(test)]
    pub(crate) fn committed_len(&self) -> u64 {
        self.committed
    }

    /// Writes the data end, the summary and the footer, and syncs. Anything staged and not
    /// committed is dropped.
    pub fn finish(mut self) -> Result<S, CommitError> {
        self.staged.clear();
        self.staged_chunk.clear();
        self.staged_counts.clear();
        self.staged_attachments.clear();
        self.staged_schemas.clear();
        self.staged_channels.clear();
        let mut out = Vec::new();
        let mut d = Body::default();
        d.u32(self.crc.clone().finalize());
        record(&mut out, op::DATA_END, &d);
        let summary_start = self.committed + out.len() as u64;
        let mut groups: Vec<(u8, u64, u64)> = Vec::new();
        let mut group = |out: &mut Vec<u8>, opcode: u8, bodies: Vec<Body>| {
            if bodies.is_empty() {
                return;
            }
            let start = self.committed + out.len() as u64;
            for b in &bodies {
                record(out, opcode, b);
            }
            groups.push((opcode, start, self.committed + out.len() as u64 - start));
        };
        let schemas = self
            .schemas
            .iter()
            .map(|s| {
                let mut b = Body::default();
                b.u16(s.id).str(&s.name).str(&s.encoding).bytes32(&s.data);
                b
            })
            .collect();
        group(&mut out, op::SCHEMA, schemas);
        let channels = self
            .channels
            .iter()
            .map(|c| {
                let mut b = Body::default();
                b.u16(c.id).u16(c.schema_id).str(&c.topic).str(&c.encoding).u32(0);
                b
            })
            .collect();
        group(&mut out, op::CHANNEL, channels);
        let mut stats = Body::default();
        let (first, last) = self.times.unwrap_or((0, 0));
        stats
            .u64(self.counts.values().sum())
            .u16(self.schemas.len() as u16)
            .u32(self.channels.len() as u32)
            .u32(self.attachments.len() as u32)
            .u32(0)
            .u32(self.chunks.len() as u32)
            .u64(first)
            .u64(last)
            .u32(self.counts.len() as u32 * 10);
        for (channel, n) in &self.counts {
            stats.u16(*channel).u64(*n);
        }
        group(&mut out, op::STATISTICS, vec![stats]);
        let chunk_indexes = self
            .chunks
            .iter()
            .map(|c| {
                let mut b = Body::default();
                b.u64(c.start_time).u64(c.end_time).u64(c.offset).u64(c.length);
                b.u32(c.index_offsets.len() as u32 * 10);
                for (channel, at) in &c.index_offsets {
                    b.u16(*channel).u64(*at);
                }
                b.u64(c.index_length).str("").u64(c.size).u64(c.size);
                b
            })
            .collect();
        group(&mut out, op::CHUNK_INDEX, chunk_indexes);
        let attachments = self
            .attachments
            .iter()
            .map(|a| {
                let mut b = Body::default();
                b.u64(a.offset)
                    .u64(a.length)
                    .u64(a.log_time)
                    .u64(a.create_time)
                    .u64(a.data_size)
                    .str(&a.name)
                    .str(&a.media_type);
                b
            })
            .collect();
        group(&mut out, op::ATTACHMENT_INDEX, attachments);
        let offsets_start = self.committed + out.len() as u64;
        for (opcode, start, len) in groups {
            let mut b = Body::default();
            b.u8(opcode).u64(start).u64(len);
            record(&mut out, op::SUMMARY_OFFSET, &b);
        }
        // The footer's CRC covers the summary through the footer's summary_offset_start.
        let footer_at = out.len();
        out.push(op::FOOTER);
        out.extend_from_slice(&20u64.to_le_bytes());
        out.extend_from_slice(&summary_start.to_le_bytes());
        out.extend_from_slice(&offsets_start.to_le_bytes());
        let summary_from = (summary_start - self.committed) as usize;
        let crc = crc32fast::hash(&out[summary_from..]);
        debug_assert!(footer_at >= summary_from);
        out.extend_from_slice(&crc.to_le_bytes());
        out.extend_from_slice(MAGIC);
        self.staged = out;
        self.commit()?;
        Ok(self.sink)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    /// A sink in memory that fails the write that would take it past `capacity` bytes,
    /// as a full disk does (having written part of it).
    struct FullDisk {
        bytes: Cursor<Vec<u8>>,
        capacity: usize,
    }

    impl Write for FullDisk {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            let pos = self.bytes.position() as usize;
            if pos + buf.len() > self.capacity {
                let room = self.capacity.saturating_sub(pos);
                if room == 0 {
                    return Err(std::io::Error::from_raw_os_error(28));
                }
                return self.bytes.write(&buf[..room]);
            }
            self.bytes.write(buf)
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Seek for FullDisk {
        fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
            self.bytes.seek(pos)
        }
    }

    impl Sink for FullDisk {
        fn sync(&mut self) -> std::io::Result<()> {
            Ok(())
        }
        fn truncate(&mut self, len: u64) -> std::io::Result<()> {
            self.bytes.get_mut().truncate(len as usize);
            Ok(())
        }
    }

    fn messages(bytes: &[u8]) -> Vec<(u32, Vec<u8>)> {
        mcap::MessageStream::new(bytes).unwrap().map(|m| m.unwrap()).map(|m| (m.sequence, m.data.to_vec())).collect()
    }

    #[test]
    fn a_finished_file_reads_back_with_valid_crcs() {
        let sink = FullDisk { bytes: Cursor::new(Vec::new()), capacity: usize::MAX };
        let mut w = McapWriter::new(sink, "test").unwrap();
        let s = w.add_schema("s", "jsonschema", b"{}");
        let c = w.add_channel(s, "/a", "json");
        w.attach(5, 5, "protocol.json", "application/json", b"{\"x\":1}");
        w.commit().unwrap();
        for i in 1..=3u32 {
            w.message(&Message { channel: c, sequence: i, log_time: 10 * u64::from(i), data: b"{}" });
            w.commit().unwrap();
        }
        let bytes = w.finish().unwrap().bytes.into_inner();
        let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
        let stats = summary.stats.expect("statistics");
        assert_eq!((stats.message_count, stats.message_start_time, stats.message_end_time), (3, 10, 30));
        assert_eq!(summary.attachment_indexes.len(), 1);
        let a = mcap::read::attachment(&bytes, &summary.attachment_indexes[0]).unwrap();
        assert_eq!(&a.data[..], b"{\"x\":1}");
        assert_eq!(messages(&bytes).len(), 3);
    }

    #[test]
    fn a_failed_commit_leaves_the_file_as_it_was_and_a_retry_writes_once() {
        let sink = FullDisk { bytes: Cursor::new(Vec::new()), capacity: usize::MAX };
        let mut w = McapWriter::new(sink, "test").unwrap();
        let s = w.add_schema("s", "jsonschema", b"{}");
        let c = w.add_channel(s, "/a", "json");
        w.message(&Message { channel: c, sequence: 1, log_time: 1, data: b"{\"n\":1}" });
        w.commit().unwrap();
        let good = w.committed_len();
        // The disk fills up in the middle of the next event's messages.
        w.sink.capacity = good as usize + 30;
        w.message(&Message { channel: c, sequence: 2, log_time: 2, data: b"{\"n\":2,\"pad\":\"xxxxxxxxxxxxxxxx\"}" });
        w.message(&Message { channel: c, sequence: 2, log_time: 2, data: b"{\"n\":2}" });
        let e = w.commit().unwrap_err();
        assert!(e.restored);
        assert_eq!(e.source.raw_os_error(), Some(28), "the OS cause is kept: {}", e.source);
        assert_eq!(w.sink.bytes.get_ref().len() as u64, good, "cut back to the last good commit");
        assert_eq!(w.committed_len(), good);
        // Space is freed; the same event is written again, once.
        w.sink.capacity = usize::MAX;
        w.message(&Message { channel: c, sequence: 2, log_time: 2, data: b"{\"n\":2}" });
        w.commit().unwrap();
        let bytes = w.finish().unwrap().bytes.into_inner();
        let got = messages(&bytes);
        assert_eq!(got, vec![(1, b"{\"n\":1}".to_vec()), (2, b"{\"n\":2}".to_vec())]);
        let stats = mcap::Summary::read(&bytes).unwrap().unwrap().stats.unwrap();
        assert_eq!(stats.message_count, 2, "the failed messages are not counted");
    }
}
