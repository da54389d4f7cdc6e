//! Writing results so that a reader never sees half a file: atomic writes,
//! directories created with their path in the error, pretty JSON with a
//! final newline, and the SHA-256 every manifest and lock is keyed by.
//!
//! Architecture Invariant: `io` imports nothing from the crate.

/// This build: the package version and the git commit it was built from
/// (`-dirty` when tracked files differed from it, `unknown` outside a git
/// checkout). Recorded in run.json, every job record and every report; a
/// constant of the leaf module, so a stage reads it without reaching up to
/// the crate root.
pub const BUILD: &str = concat!(env!("CARGO_PKG_VERSION"), " (commit ", env!("CROSSAUDIT_GIT_COMMIT"), ")");

use std::path::Path;

use sha2::{Digest, Sha256};

/// Pretty JSON with a final newline: the form of every JSON file written.
pub fn pretty_json<T: serde::Serialize + ?Sized>(value: &T) -> String {
    // Serializing plain data structs (no maps with non-string keys) cannot fail.
    let mut s = serde_json::to_string_pretty(value).unwrap_or_default();
    s.push('\n');
    s
}

/// SHA-256 of `bytes`, lowercase hex.
///
/// ```
/// // FIPS 180-2, Appendix B.1: SHA-256("abc").
/// assert_eq!(
///     crossaudit::io::sha256_hex(b"abc"),
///     "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
/// );
/// ```
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

/// A SHA-256 digest in lowercase hex.
pub fn hex(digest: &[u8]) -> String {
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 of a file's bytes, lowercase hex: how every file a resume
/// reuses is checked against its record.
pub fn sha256_file(path: &Path) -> std::io::Result<String> {
    check_regular(path, u64::MAX, "a recorded file").map_err(ReadError::into_io)?;
    // Streamed: memory holds a block, not the file.
    let mut file = std::fs::File::open(path)?;
    let (mut hasher, mut block) = (Sha256::new(), vec![0u8; 1 << 20]);
    loop {
        match std::io::Read::read(&mut file, &mut block) {
            Ok(0) => return Ok(hex(&hasher.finalize())),
            Ok(n) => hasher.update(&block[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
}

/// Serializes an `f64` in Rust's shortest round-trip `Display` form (`1`,
/// `0.00001`), the form of every number in the CSV files written here, so
/// the same values always give the same bytes.
pub fn f64_text<S: serde::Serializer>(value: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(value)
}

/// As [`f64_text`]; `None` is an empty field.
pub fn opt_f64_text<S: serde::Serializer>(value: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match value {
        Some(v) => s.collect_str(v),
        None => s.serialize_none(),
    }
}

/// The most bytes read from a design, a lock, a metadata file or a
/// coverage spec: far above any real one (the paper's design is 3 KB).
pub const MAX_SMALL_TEXT: u64 = 4 << 20;

/// The most bytes read from a published split file (a 200,000-name list
/// is about 10 MB).
pub const MAX_SPLIT_FILE: u64 = 256 << 20;

/// The smallest nonzero magnitude a reader accepts for a value that the
/// analyses square and square again (per-cell metrics, replications,
/// declared components): below it a variance's own variance underflows
/// double precision (2.2e-308) and an interval collapses to a point, a
/// plausible-looking wrong answer. Such a value is refused with its place
/// and the advice to rescale (another unit).
pub const MIN_MAGNITUDE: f64 = 1e-60;

/// The most bytes read from a per-cell CSV (the paper's study writes about
/// 40 KB; a million cells is about 200 MB).
pub const MAX_CELLS_FILE: u64 = 1 << 30;

/// The most bytes read from one flight log file (a 100 Hz NanoBench log
/// of an hour is about 150 MB uncompressed).
pub const MAX_LOG_FILE: u64 = 2 << 30;

/// The most bytes decompressed out of one gzipped flight log, over all
/// its members: more than three hours of a 100 Hz NanoBench log (the
/// largest shared log holds 2.9 MB). A gzip bomb stops here.
pub const MAX_LOG_DECOMPRESSED: u64 = 512 << 20;

/// The longest line read from a flight log: a NanoBench row is under
/// 1 KB, so a longer line is damage, refused before it is parsed.
pub const MAX_LOG_LINE: usize = 64 << 10;

/// At most `max` characters of `s` for a message, with how much was left
/// out: an input echoed into an error or an audit table stays readable
/// however long it is.
///
/// ```
/// assert_eq!(crossaudit::io::excerpt("abc", 5), "abc");
/// assert_eq!(crossaudit::io::excerpt("abcdefgh", 3), "abc... (8 bytes in all)");
/// ```
pub fn excerpt(s: &str, max: usize) -> String {
    match s.char_indices().nth(max) {
        None => s.to_string(),
        Some((end, _)) => format!("{}... ({} bytes in all)", &s[..end], s.len()),
    }
}

/// An input file that was not read: missing, not a regular file (a FIFO
/// would block the read forever, a device such as `/dev/zero` never ends),
/// or larger than the limit for its kind.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The operating system's error (missing, no permission, ...).
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// A directory, FIFO, socket or device, possibly through a symlink.
    #[error("cannot read {path}: it is {kind}, not a regular file")]
    NotAFile {
        /// The file.
        path: String,
        /// What it is, e.g. "a FIFO (named pipe)".
        kind: String,
    },
    /// Larger than the limit for its kind.
    #[error("cannot read {path}: it holds {size}, more than the {limit} bytes read from {what}")]
    TooLarge {
        /// The file.
        path: String,
        /// Its size, e.g. "5000000 bytes" ("at least ..." when it grew
        /// while it was read).
        size: String,
        /// The limit.
        limit: u64,
        /// The kind of file, e.g. "a design file".
        what: &'static str,
    },
}

impl ReadError {
    /// As an `std::io::Error` (the operating system's own where there is
    /// one), for errors that already name the path.
    pub fn into_io(self) -> std::io::Error {
        match self {
            ReadError::Io { source, .. } => source,
            other => std::io::Error::new(std::io::ErrorKind::InvalidInput, other.reason()),
        }
    }

    /// The reason without the path, for messages that name the file first.
    pub fn reason(&self) -> String {
        match self {
            ReadError::Io { source, .. } => source.to_string(),
            ReadError::NotAFile { kind, .. } => format!("it is {kind}, not a regular file"),
            ReadError::TooLarge { size, limit, what, .. } => {
                format!("it holds {size}, more than the {limit} bytes read from {what}")
            }
        }
    }
}

/// What a file type is, in words, for [`ReadError::NotAFile`].
fn kind_of(t: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
    }
    if t.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

/// Checks that `path` (after following symlinks) is a regular file of at
/// most `limit` bytes, before anything opens it: opening a FIFO blocks
/// until a writer comes, and a device is never exhausted.
pub fn check_regular(path: &Path, limit: u64, what: &'static str) -> Result<(), ReadError> {
    let shown = path.display().to_string();
    let meta = std::fs::metadata(path).map_err(|source| ReadError::Io { path: shown.clone(), source })?;
    if !meta.is_file() {
        let mut kind = kind_of(meta.file_type()).to_string();
        if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
            if let Ok(target) = std::fs::canonicalize(path) {
                kind = format!("{kind}, {}, through a symbolic link", target.display());
            }
        }
        return Err(ReadError::NotAFile { path: shown, kind });
    }
    if meta.len() > limit {
        return Err(ReadError::TooLarge { path: shown, size: format!("{} bytes", meta.len()), limit, what });
    }
    Ok(())
}

/// Reads an input file whole: a regular file (symlinks followed) of at
/// most `limit` bytes, else a [`ReadError`] saying what it is. `what`
/// names the kind of file in the message ("a design file").
pub fn read_input(path: &Path, limit: u64, what: &'static str) -> Result<Vec<u8>, ReadError> {
    use std::io::Read;
    check_regular(path, limit, what)?;
    let shown = || path.display().to_string();
    let file = std::fs::File::open(path).map_err(|source| ReadError::Io { path: shown(), source })?;
    let mut bytes = Vec::new();
    file.take(limit + 1).read_to_end(&mut bytes).map_err(|source| ReadError::Io { path: shown(), source })?;
    if bytes.len() as u64 > limit {
        // It grew after it was measured.
        let size = format!("at least {} bytes", limit + 1);
        return Err(ReadError::TooLarge { path: shown(), size, limit, what });
    }
    Ok(bytes)
}

/// Line numbers of byte offsets in a text, counting `\r\n`, a lone `\n`
/// and a lone `\r` each as one line break, as editors and Python's csv
/// module do (the csv crate's own line count is one short after `\r\n`).
#[derive(Debug, Clone)]
pub struct LineIndex {
    /// Byte offset where each line starts; the first is 0.
    starts: Vec<usize>,
}

impl LineIndex {
    /// The index of `text`.
    ///
    /// ```
    /// let ix = crossaudit::io::LineIndex::new(b"a\r\nb\rc\nd");
    /// assert_eq!([0, 3, 5, 7].map(|b| ix.line_of(b)), [1, 2, 3, 4]);
    /// // The last byte of a line break belongs to the line after it.
    /// assert_eq!(ix.line_of(2), 2);
    /// ```
    pub fn new(text: &[u8]) -> LineIndex {
        let mut starts = vec![0];
        let mut k = 0;
        while k < text.len() {
            match text[k] {
                b'\r' if text.get(k + 1) == Some(&b'\n') => {
                    starts.push(k + 2);
                    k += 2;
                }
                b'\r' | b'\n' => {
                    starts.push(k + 1);
                    k += 1;
                }
                _ => k += 1,
            }
        }
        LineIndex { starts }
    }

    /// The 1-based line of byte `offset`. An offset on the last byte of a
    /// line break counts as the start of the next line: the csv crate
    /// reports a record after `\r\n` as starting on its `\n`.
    pub fn line_of(&self, offset: usize) -> usize {
        let k = if self.starts.binary_search(&(offset + 1)).is_ok() { offset + 1 } else { offset };
        self.starts.partition_point(|&s| s <= k)
    }
}

/// A reader that counts the lines of the bytes read through it and
/// refuses to read past `limit` bytes, so a large file can be parsed as a
/// stream and its errors still located by line. It keeps the line starts
/// of the last [`LINE_WINDOW`] bytes only (and the one before them), so
/// its memory does not grow with the file: a 500 MB file of blank lines
/// held 8 bytes per line.
pub struct LineCounting<R> {
    inner: std::io::Take<R>,
    starts: std::collections::VecDeque<usize>,
    /// Line starts dropped from the front of `starts`.
    dropped: usize,
    read: usize,
    pending_cr: bool,
    limit: u64,
}

/// How far behind the bytes read [`LineCounting::line_of`] is exact: the
/// start of any record a parser holds (the csv crate buffers 8 KiB).
pub const LINE_WINDOW: usize = 1 << 20;

impl<R: std::io::Read> LineCounting<R> {
    /// Counts lines of `inner`, reading at most `limit` bytes (a read past
    /// it fails, naming `what` was being read).
    pub fn new(inner: R, limit: u64) -> LineCounting<R> {
        LineCounting {
            inner: inner.take(limit.saturating_add(1)),
            starts: std::collections::VecDeque::from([0]),
            dropped: 0,
            read: 0,
            pending_cr: false,
            limit,
        }
    }

    /// The 1-based line of byte `offset`, among the bytes read so far (as
    /// [`LineIndex::line_of`]); exact for any offset within
    /// [`LINE_WINDOW`] bytes of the last read, and for any offset on the
    /// line that began before them.
    pub fn line_of(&self, offset: usize) -> usize {
        let k = if self.starts.binary_search(&(offset + 1)).is_ok() { offset + 1 } else { offset };
        self.dropped + self.starts.partition_point(|&s| s <= k).max(1)
    }

    /// Drops the line starts before the window, keeping the last one
    /// before it (the line the window begins on).
    fn prune(&mut self) {
        let from = self.read.saturating_sub(LINE_WINDOW);
        while self.starts.len() > 1 && self.starts[1] <= from {
            self.starts.pop_front();
            self.dropped += 1;
        }
    }
}

impl<R: std::io::Read> std::io::Read for LineCounting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        if n == 0 {
            if std::mem::take(&mut self.pending_cr) {
                self.starts.push_back(self.read);
            }
            return Ok(0);
        }
        if (self.read + n) as u64 > self.limit {
            let message = format!("it is larger than the {} bytes crossaudit reads from one such file", self.limit);
            return Err(std::io::Error::other(message));
        }
        let chunk = &buf[..n];
        let mut from = 0;
        if std::mem::take(&mut self.pending_cr) {
            if chunk[0] == b'\n' {
                self.starts.push_back(self.read + 1);
                from = 1;
            } else {
                self.starts.push_back(self.read);
            }
        }
        let mut skip = None;
        for i in memchr::memchr2_iter(b'\r', b'\n', &chunk[from..]).map(|i| i + from) {
            if skip == Some(i) {
                continue;
            }
            let at = self.read + i;
            if chunk[i] == b'\n' {
                self.starts.push_back(at + 1);
            } else if i + 1 == n {
                self.pending_cr = true;
            } else if chunk[i + 1] == b'\n' {
                self.starts.push_back(at + 2);
                skip = Some(i + 1);
            } else {
                self.starts.push_back(at + 1);
            }
        }
        self.read += n;
        self.prune();
        Ok(n)
    }
}

/// `text` with each lone `\r` (old Mac line ending) made `\n`, so parsers
/// that count only `\n` (pest, serde_json, YAML) count those lines too.
/// Byte offsets do not move, and `\r\n` is left as it is.
///
/// ```
/// assert_eq!(crossaudit::io::lone_cr_to_lf("a\rb\r\nc"), "a\nb\r\nc");
/// ```
pub fn lone_cr_to_lf(text: &str) -> std::borrow::Cow<'_, str> {
    match lone_cr_to_lf_bytes(text.as_bytes()) {
        std::borrow::Cow::Borrowed(_) => std::borrow::Cow::Borrowed(text),
        // Only ASCII `\r` became ASCII `\n`: still UTF-8.
        std::borrow::Cow::Owned(b) => std::borrow::Cow::Owned(String::from_utf8(b).unwrap_or_default()),
    }
}

/// As [`lone_cr_to_lf`], on bytes (a flight log).
pub fn lone_cr_to_lf_bytes(bytes: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    let lone = |k: usize| bytes[k] == b'\r' && bytes.get(k + 1) != Some(&b'\n');
    // One pass over the `\r`s only: most files have none, or only `\r\n`.
    let mut crs = bytes.iter().enumerate().filter(|(_, &b)| b == b'\r');
    if !crs.any(|(k, _)| lone(k)) {
        return std::borrow::Cow::Borrowed(bytes);
    }
    let out = (0..bytes.len()).map(|k| if lone(k) { b'\n' } else { bytes[k] }).collect();
    std::borrow::Cow::Owned(out)
}

/// The most bytes read from a file crossaudit wrote itself and reads back
/// (run and job records, manifests, curves, the simulation record).
pub const MAX_OWN_FILE: u64 = 1 << 30;

/// Reads a file crossaudit wrote and reads back, as [`read_input`] does
/// (a FIFO or a device put in its place is refused, not read), with the
/// operating system's error kind kept (a missing record is no error).
pub fn read_own(path: &Path) -> std::io::Result<Vec<u8>> {
    read_input(path, MAX_OWN_FILE, "a file crossaudit wrote").map_err(ReadError::into_io)
}

mod caught;
pub mod chunked;
pub mod float_text;
mod input;
pub use input::{read_text, text_of, Text, TextError};
pub mod parquet;
pub mod seal;
mod text;
pub use text::{escape_controls, formula_like, md_code, md_line, md_plain, md_text, one_line, spreadsheet_text};
pub mod walk;
mod write;
pub use write::{create_dir_all, protect_input, refuse_protected_in, staged, write_atomic, WriteError};

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;

    /// Hands out at most `step` bytes per read, so line breaks (`\r\n`
    /// above all) fall across reads.
    struct Trickle<'a> {
        text: &'a [u8],
        step: usize,
    }

    impl Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = self.step.min(buf.len()).min(self.text.len());
            buf[..n].copy_from_slice(&self.text[..n]);
            self.text = &self.text[n..];
            Ok(n)
        }
    }

    proptest::proptest! {
        /// The streamed count agrees with the whole-text index at every
        /// offset, however the text arrives.
        #[test]
        fn line_counting_agrees_with_the_line_index(
            text in proptest::collection::vec(proptest::sample::select(vec![b'a', b',', b'\r', b'\n']), 0..60),
            step in 1usize..5,
        ) {
            let whole = LineIndex::new(&text);
            let mut counted = LineCounting::new(Trickle { text: &text, step }, 1000);
            let mut sink = Vec::new();
            proptest::prop_assert!(counted.read_to_end(&mut sink).is_ok());
            proptest::prop_assert_eq!(&sink, &text);
            for k in 0..=text.len() {
                proptest::prop_assert_eq!(counted.line_of(k), whole.line_of(k), "offset {}", k);
            }
        }
    }

    /// Issue 56, class 2: the count keeps the line starts of its window
    /// only (it held 8 bytes per line of the whole file), and stays exact
    /// within it, against the whole-text index.
    #[test]
    fn line_counting_holds_a_window_not_the_file() -> Result<(), Box<dyn std::error::Error>> {
        let mut text = b"\r\n".repeat(LINE_WINDOW);
        text.extend(b"a\rb\n".repeat(LINE_WINDOW / 2));
        let whole = LineIndex::new(&text);
        let mut counted = LineCounting::new(Trickle { text: &text, step: 8191 }, u64::MAX);
        std::io::copy(&mut counted, &mut std::io::sink())?;
        assert!(counted.starts.len() <= LINE_WINDOW / 2 + 2, "{} line starts kept", counted.starts.len());
        for k in (text.len() - LINE_WINDOW..=text.len()).step_by(997).chain([text.len()]) {
            assert_eq!(counted.line_of(k), whole.line_of(k), "offset {k}");
        }
        Ok(())
    }

    #[test]
    fn line_counting_refuses_to_read_past_its_limit() -> Result<(), Box<dyn std::error::Error>> {
        let mut counted = LineCounting::new(&b"0123456789"[..], 9);
        let e = counted.read_to_end(&mut Vec::new()).unwrap_err();
        assert!(e.to_string().contains("larger than the 9 bytes"), "{e}");
        let mut exact = LineCounting::new(&b"012345678"[..], 9);
        assert_eq!(exact.read_to_end(&mut Vec::new())?, 9);
        Ok(())
    }
}
