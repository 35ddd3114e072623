//! Opening the files a command is given or finds: only regular files, never blocking on the
//! open (a FIFO or a device named like a log is refused, not waited on), and never more bytes
//! than a budget; JSON with nothing after its one document and no byte-order mark.

use std::fs::File;
use std::io::Read;
use std::path::Path;

/// The most bytes read from a table a command merges (a shard's CSV).
pub(crate) const MAX_TABLE_BYTES: u64 = 256 << 20;

/// What kind of file a non-regular one is, for a message.
fn kind(m: &std::fs::Metadata) -> &'static str {
    let t = m.file_type();
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
        if t.is_block_device() || t.is_char_device() {
            return "a device";
        }
    }
    if t.is_dir() { "a directory" } else { "not a regular file" }
}

/// Opens `path` for reading if it is a regular file. On Unix the open is non-blocking, so a
/// FIFO without a writer is refused at once rather than hanging the command.
pub fn open_regular(path: &Path) -> std::io::Result<File> {
    let mut o = std::fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NONBLOCK);
    }
    let f = o.open(path)?;
    let m = f.metadata()?;
    if !m.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("is {}, expected a regular file", kind(&m)),
        ));
    }
    Ok(f)
}

/// Whether `path` is a regular file, without following a final symbolic link and without
/// opening it (for walks through a folder: a link, FIFO or device found there is skipped).
pub fn is_plain_file(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_file())
}

/// The bytes of a regular file of at most `max` bytes.
pub fn read_regular(path: &Path, max: u64) -> std::io::Result<Vec<u8>> {
    let f = open_regular(path)?;
    let mut bytes = Vec::new();
    f.take(max + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("is over {max} bytes, the most read from such a file"),
        ));
    }
    Ok(bytes)
}

/// A regular file read as a stream of at most `max` bytes: one byte more is an error (not a
/// silent cut), so a CSV reader never takes more than the budget.
pub fn open_bounded(path: &Path, max: u64) -> std::io::Result<Bounded> {
    Ok(Bounded { file: open_regular(path)?, left: max, max })
}

/// See [`open_bounded`].
pub struct Bounded {
    file: File,
    left: u64,
    max: u64,
}

impl Read for Bounded {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        // One byte past the budget is read to tell "exactly the budget" from "over it".
        let want = buf.len().min(usize::try_from(self.left + 1).unwrap_or(usize::MAX));
        let n = self.file.read(&mut buf[..want])?;
        if n as u64 > self.left {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("is over {} bytes, the most read from such a file", self.max),
            ));
        }
        self.left -= n as u64;
        Ok(n)
    }
}

/// The largest magnitude a number in a merged table may have: far beyond any value a run
/// computes, and small enough that sums and sums of squares over a whole run stay finite.
pub(crate) const MAX_TABLE_NUMBER: f64 = 1e100;

/// The rows of a CSV file this program wrote (a shard's table), read back untrusted: a
/// regular file of at most [`MAX_TABLE_BYTES`], at most `max_rows` rows, every number finite
/// and at most [`MAX_TABLE_NUMBER`] in magnitude (NaN, inf or 1e308 would pass into a merged
/// summary silently). Errors name the file, the row and the column.
pub fn read_csv_rows<T: serde::de::DeserializeOwned>(path: &Path, max_rows: usize) -> Result<Vec<T>, String> {
    let name = path.display();
    let file = open_bounded(path, MAX_TABLE_BYTES).map_err(|e| format!("{name}: {e}"))?;
    let mut reader = csv::Reader::from_reader(file);
    let header = reader.headers().map_err(|e| format!("{name}: header: {e}"))?.clone();
    let mut out = Vec::new();
    for (i, record) in reader.records().enumerate() {
        let row = i + 2;
        let record = record.map_err(|e| format!("{name}: row {row}: {e}"))?;
        if out.len() == max_rows {
            return Err(format!("{name}: more than the {max_rows} rows the run has"));
        }
        for (column, field) in header.iter().zip(record.iter()) {
            if let Ok(v) = field.trim().parse::<f64>()
                && !(v.is_finite() && v.abs() <= MAX_TABLE_NUMBER)
            {
                return Err(format!(
                    "{name}: row {row}: {column} is {field}, expected a finite number of magnitude at most {MAX_TABLE_NUMBER:e}"
                ));
            }
        }
        out.push(record.deserialize(Some(&header)).map_err(|e| format!("{name}: row {row}: {e}"))?);
    }
    Ok(out)
}

/// Why a JSON file's text cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum JsonTextError {
    #[error("is not UTF-8 text ({0})")]
    NotUtf8(#[from] std::str::Utf8Error),
    /// Named, since a parser would only say "expected value at line 1 column 1".
    #[error(
        "starts with a UTF-8 byte-order mark (EF BB BF), expected JSON text without one: save it as UTF-8 without BOM"
    )]
    ByteOrderMark,
    #[error("{0}")]
    Json(#[from] serde_json::Error),
}

/// Checks that JSON text does not start with a byte-order mark.
pub fn check_no_bom(text: &str) -> Result<(), JsonTextError> {
    if text.starts_with('\u{feff}') { Err(JsonTextError::ByteOrderMark) } else { Ok(()) }
}

/// Parses one JSON document from UTF-8 bytes: no byte-order mark, nothing after the document
/// but white space.
pub fn parse_json_bytes<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> Result<T, JsonTextError> {
    let text = std::str::from_utf8(bytes)?;
    check_no_bom(text)?;
    Ok(serde_json::from_str(text)?)
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    #[test]
    fn a_fifo_is_refused_without_blocking() {
        let dir = std::env::temp_dir().join(format!("handover-fifo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("x.mcap");
        let c = std::ffi::CString::new(fifo.as_os_str().as_encoded_bytes()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let e = read_regular(&fifo, 10).unwrap_err();
        assert!(e.to_string().contains("FIFO"), "{e}");
        assert!(!is_plain_file(&fifo));
        let e = read_regular(&dir, 10).unwrap_err();
        assert!(e.to_string().contains("directory"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_bounded_read_fails_past_its_budget() {
        let dir = std::env::temp_dir().join(format!("handover-bounded-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("f.csv");
        std::fs::write(&f, b"0123456789").unwrap();
        let mut all = Vec::new();
        open_bounded(&f, 10).unwrap().read_to_end(&mut all).unwrap();
        assert_eq!(all.len(), 10);
        let e = open_bounded(&f, 9).unwrap().read_to_end(&mut Vec::new()).unwrap_err();
        assert!(e.to_string().contains("over 9 bytes"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn json_with_a_bom_or_a_second_document_is_refused() {
        assert!(parse_json_bytes::<serde_json::Value>(b"{} ").is_ok());
        assert!(parse_json_bytes::<serde_json::Value>(b"{} {}").unwrap_err().to_string().contains("trailing"));
        let bom = parse_json_bytes::<serde_json::Value>("\u{feff}{}".as_bytes()).unwrap_err();
        assert!(matches!(bom, JsonTextError::ByteOrderMark) && bom.to_string().contains("byte-order mark"));
        assert!(matches!(parse_json_bytes::<serde_json::Value>(b"\xff"), Err(JsonTextError::NotUtf8(_))));
    }
}
