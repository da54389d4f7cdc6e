//! One flight log: `.csv` or `.csv.gz` (the same bytes after
//! decompression), one header row: NanoBench's 52 numeric columns, or any
//! header holding the columns a `data csv` block declares.
//!
//! The files are plain numeric CSV without quoting, so rows are split by
//! hand (the csv crate's general quoting machinery costs more than the
//! whole parse here) and floats are read with fast-float2. Every field is
//! checked; only the requested columns are kept.

use std::io::Read;
use std::path::Path;

pub use super::log_error::LogError;

mod columns;
mod hashes;
pub use columns::{from_columns, read_log};

/// The NanoBench CSV schema, in file order (shared/nanobench/README.md).
pub const NANOBENCH_COLUMNS: [&str; 52] = [
    "t",
    "px",
    "py",
    "pz",
    "qx",
    "qy",
    "qz",
    "qw",
    "roll",
    "pitch",
    "yaw",
    "vx",
    "vy",
    "vz",
    "wx_vicon",
    "wy_vicon",
    "wz_vicon",
    "imu_acc_x",
    "imu_acc_y",
    "imu_acc_z",
    "imu_gyro_x",
    "imu_gyro_y",
    "imu_gyro_z",
    "motor_motor_m1",
    "motor_motor_m2",
    "motor_motor_m3",
    "motor_motor_m4",
    "est_stateEstimate_x",
    "est_stateEstimate_y",
    "est_stateEstimate_z",
    "est_stateEstimate_vx",
    "est_stateEstimate_vy",
    "est_stateEstimate_vz",
    "est_stateEstimate_ax",
    "est_stateEstimate_ay",
    "est_stateEstimate_az",
    "att_stateEstimate_roll",
    "att_stateEstimate_pitch",
    "att_stateEstimate_yaw",
    "att_stateEstimate_qx",
    "att_stateEstimate_qy",
    "att_stateEstimate_qz",
    "att_stateEstimate_qw",
    "sp_ctrltarget_x",
    "sp_ctrltarget_y",
    "sp_ctrltarget_z",
    "sp_ctrltarget_yaw",
    "pid_controller_roll",
    "pid_controller_pitch",
    "pid_controller_yaw",
    "pid_controller_cmd_thrust",
    "pwr_pm_vbat",
];

/// A parsed log: the requested columns, row count and content hash.
#[derive(Debug, Clone)]
pub struct Log {
    /// Number of data rows.
    pub rows: usize,
    /// Requested columns, in the order requested.
    pub columns: Vec<Vec<f64>>,
    /// XXH3-128 of the values read (the declared columns, in the
    /// schema's order, row by row, each value's 8 bytes; every NaN the
    /// standard one): equal for logs the design reads the same numbers
    /// from, whatever wrote their text (CSV or Parquet, `0.10` or `0.1`)
    /// and whatever their other columns hold. A non-cryptographic hash is
    /// enough to find identical logs, and it is ten times faster than
    /// SHA-256.
    pub content_hash: String,
    /// XXH3-64 of each row's values as read (its declared columns' 8
    /// bytes each): equal rows in two logs hold the same numbers. The
    /// split audit finds shared runs of rows with them. Empty unless asked
    /// for ([`parse_with_row_hashes`]).
    pub row_hashes: Vec<u64>,
    /// For each blank line skipped, the data row it came before: a row's
    /// line is its index + 2 + the blank lines before it ([`Log::line_of`]).
    pub blank_before: Vec<usize>,
}

impl Log {
    /// The file line (1 = header) of data row `row` (0-based).
    pub fn line_of(&self, row: usize) -> usize {
        row + 2 + self.blank_before.partition_point(|&b| b <= row)
    }
}

/// Reads the file's bytes, decompressing `.gz`: every member of a
/// multi-member gzip (as `zcat` reads it), at most
/// [`crate::io::MAX_LOG_DECOMPRESSED`] bytes in all (a gzip bomb stops
/// there), and nothing after the last member (trailing bytes that are not
/// a gzip member are an error, not ignored).
pub fn read_bytes(path: &Path) -> Result<Vec<u8>, LogError> {
    let file = path.display().to_string();
    let raw = read_raw(path)?;
    if crate::io::parquet::is_parquet(path) {
        return crate::io::parquet::to_csv_text(raw, crate::io::MAX_LOG_DECOMPRESSED, "a flight log")
            .map_err(|message| LogError::Parquet { file, message });
    }
    if path.extension().is_none_or(|e| e != "gz") {
        return Ok(raw);
    }
    let limit = crate::io::MAX_LOG_DECOMPRESSED;
    let mut out = Vec::with_capacity((raw.len() * 6).min(limit as usize + 1));
    let mut dec = flate2::read::MultiGzDecoder::new(&raw[..]).take(limit + 1);
    if let Err(e) = dec.read_to_end(&mut out) {
        let line = out.iter().filter(|&&b| b == b'\n').count() + 1;
        return Err(LogError::Gzip { file, bytes: out.len(), line, message: e.to_string() });
    }
    if out.len() as u64 > limit {
        return Err(LogError::Io {
            file,
            message: format!("it decompresses to more than the {limit} bytes read from a flight log (a gzip bomb?)"),
        });
    }
    if out.is_empty() {
        return Err(LogError::Gzip { file, bytes: 0, line: 1, message: "no data in the gzip stream".into() });
    }
    Ok(out)
}

/// The file's bytes as stored, at most [`crate::io::MAX_LOG_FILE`].
fn read_raw(path: &Path) -> Result<Vec<u8>, LogError> {
    crate::io::read_input(path, crate::io::MAX_LOG_FILE, "a flight log")
        .map_err(|e| LogError::Io { file: path.display().to_string(), message: e.reason() })
}

/// Index of each requested column in the NanoBench schema.
pub fn column_indices(names: &[String]) -> Result<Vec<usize>, String> {
    names
        .iter()
        .map(|n| {
            NANOBENCH_COLUMNS.iter().position(|c| c == n).ok_or_else(|| format!("`{n}` is not a NanoBench column"))
        })
        .collect()
}

/// What a log's header must be, and which columns are read.
#[derive(Debug, Clone)]
pub enum Schema {
    /// NanoBench's 52 columns exactly; every field is checked as a number.
    /// The indices of the columns read, in the order wanted.
    Nanobench(Vec<usize>),
    /// Any header holding these columns (each once); only they are read
    /// and checked. The time column, if any, is checked to never decrease.
    Named {
        /// The columns read, in the order wanted (a name may repeat).
        columns: Vec<String>,
        /// The time column.
        time: Option<String>,
    },
}

/// Parses and checks a whole log held in memory.
pub fn parse(file: &str, bytes: &[u8], schema: &Schema) -> Result<Log, LogError> {
    parse_with(file, bytes, schema, ParseOptions::default())
}

/// As [`parse`], and hashes every data row into [`Log::row_hashes`].
pub fn parse_with_row_hashes(file: &str, bytes: &[u8], schema: &Schema) -> Result<Log, LogError> {
    parse_with(file, bytes, schema, ParseOptions { hash_rows: true, ..ParseOptions::default() })
}

/// How a log is parsed beyond its schema.
#[derive(Debug, Clone, Copy, Default)]
pub struct ParseOptions {
    /// Hash every data row into [`Log::row_hashes`].
    pub hash_rows: bool,
    /// An empty or non-finite (`NaN`, `inf`) field in a column read, other
    /// than time, is read as NaN instead of refusing the file (a declared
    /// `missing values` policy then decides); text that is not a number is
    /// still refused.
    pub missing_as_nan: bool,
}

/// Parses and checks a whole log held in memory, with [`ParseOptions`].
pub fn parse_with(file: &str, bytes: &[u8], schema: &Schema, options: ParseOptions) -> Result<Log, LogError> {
    let hash_rows = options.hash_rows;
    // Lone `\r` line endings are read as lines (as pandas reads them), so
    // errors name the line an editor shows.
    let bytes = &*crate::io::lone_cr_to_lf_bytes(bytes);
    // A UTF-8 byte-order mark (Excel writes one) is not part of the first
    // name: kept, it made that column "missing" for an invisible reason.
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(LogError::Empty { file: file.to_string() });
    }
    let Header { end: header_end, names, keep, time, check_all } = header(file, bytes, schema)?;
    let body = bytes.get(header_end + 1..).unwrap_or(&[]);
    let n = names.len();
    // Positions of each schema column in `keep` (a column may be kept
    // twice, e.g. motor 1 as an action and as the active-rule column).
    let mut slots: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (k, &c) in keep.iter().enumerate() {
        slots[c].push(k);
    }
    let estimate = body.len() / 500 + 1;
    let columns = keep.iter().map(|_| Vec::with_capacity(estimate)).collect();
    let mut t = Tokenizer {
        file,
        body,
        names: &names,
        time,
        check_all,
        missing_as_nan: options.missing_as_nan,
        slots,
        columns,
        previous_t: f64::NEG_INFINITY,
        line: 1,
        i: 0,
    };
    let mut rows = 0;
    let mut blank_before = Vec::new();
    while t.i < body.len() {
        t.line += 1;
        // Blank line (`\n` or `\r\n`).
        if body[t.i] == b'\n' || (body[t.i] == b'\r' && body.get(t.i + 1) == Some(&b'\n')) {
            t.i += if body[t.i] == b'\r' { 2 } else { 1 };
            blank_before.push(rows);
            continue;
        }
        let start = t.i;
        let limit = crate::io::MAX_LOG_LINE;
        let window = &body[start..body.len().min(start + limit + 1)];
        if window.len() > limit && !window.contains(&b'\n') {
            return Err(LogError::LongLine { file: file.to_string(), line: t.line, bytes: window.len(), limit });
        }
        let fields = t.row()?;
        if fields != n {
            return Err(LogError::Ragged { file: file.to_string(), line: t.line, found: fields, expected: n });
        }
        rows += 1;
    }
    if rows == 0 {
        return Err(LogError::NoRows { file: file.to_string() });
    }
    let (content_hash, row_hashes) = hashes::hashes(&t.columns, rows, hash_rows);
    Ok(Log { rows, columns: t.columns, content_hash, row_hashes, blank_before })
}

/// What a log's header gives the parser under a schema.
struct Header {
    /// Where the header line ends.
    end: usize,
    /// Every column's name.
    names: Vec<String>,
    /// The columns read, in the order wanted.
    keep: Vec<usize>,
    /// The time column.
    time: Option<usize>,
    /// Whether columns not read are checked as numbers too (NanoBench).
    check_all: bool,
}

/// The header of a log, read as the schema says: NanoBench's exact
/// header, or any header holding the named columns once each.
fn header(file: &str, bytes: &[u8], schema: &Schema) -> Result<Header, LogError> {
    Ok(match schema {
        Schema::Nanobench(keep) => {
            let end = check_header(file, bytes)?;
            let names = NANOBENCH_COLUMNS.iter().map(|c| c.to_string()).collect();
            Header { end, names, keep: keep.clone(), time: Some(0), check_all: true }
        }
        Schema::Named { columns, time } => {
            let (end, names) = read_header(file, bytes)?;
            let find = |want: &String| -> Result<usize, LogError> {
                let mut at = names.iter().enumerate().filter(|(_, n)| *n == want).map(|(k, _)| k);
                match (at.next(), at.next()) {
                    (Some(k), None) => Ok(k),
                    (first, _) => Err(LogError::MissingColumn {
                        file: file.to_string(),
                        column: want.clone(),
                        found: if first.is_some() { "twice".into() } else { header_excerpt(&names) },
                    }),
                }
            };
            let keep = columns.iter().map(find).collect::<Result<Vec<_>, _>>()?;
            let time = time.as_ref().map(find).transpose()?;
            Header { end, names, keep, time, check_all: false }
        }
    })
}

/// The header of a log of any schema: where it ends, and its names
/// (surrounding spaces and quotes trimmed).
fn read_header(file: &str, bytes: &[u8]) -> Result<(usize, Vec<String>), LogError> {
    let limit = crate::io::MAX_LOG_LINE;
    let header_end = bytes.iter().take(limit + 1).position(|&b| b == b'\n').unwrap_or(bytes.len());
    if header_end > limit {
        return Err(LogError::LongLine { file: file.to_string(), line: 1, bytes: limit + 1, limit });
    }
    let header = String::from_utf8_lossy(&bytes[..header_end]);
    Ok((header_end, header_names(header.trim_end_matches('\r'))))
}

/// A header line's names, CSV-quoted names read whole (`"a,b"` is one
/// name, `""` a quote inside it), surrounding spaces trimmed.
fn header_names(header: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut name = String::new();
    let mut quoted = false;
    let mut chars = header.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                name.push('"');
                chars.next();
            }
            '"' => quoted = !quoted,
            ',' if !quoted => names.push(std::mem::take(&mut name).trim().to_string()),
            _ => name.push(c),
        }
    }
    names.push(name.trim().to_string());
    names
}

/// A header as an error quotes it: its first names.
fn header_excerpt(names: &[String]) -> String {
    let shown: Vec<&str> = names.iter().take(12).map(|n| n.as_str()).collect();
    let more = if names.len() > 12 { format!(", ... ({} in all)", names.len()) } else { String::new() };
    crate::io::excerpt(&format!("{}{more}", shown.join(", ")), 400)
}

/// Checks the header against the NanoBench schema; returns where it ends.
fn check_header(file: &str, bytes: &[u8]) -> Result<usize, LogError> {
    let limit = crate::io::MAX_LOG_LINE;
    let header_end = bytes.iter().take(limit + 1).position(|&b| b == b'\n').unwrap_or(bytes.len());
    if header_end > limit {
        return Err(LogError::LongLine { file: file.to_string(), line: 1, bytes: limit + 1, limit });
    }
    let header = std::str::from_utf8(&bytes[..header_end]).unwrap_or("").trim_end_matches('\r');
    let names: Vec<&str> = header.split(',').collect();
    for (index, expected) in NANOBENCH_COLUMNS.iter().enumerate() {
        let found = names.get(index).copied().unwrap_or("");
        if found != *expected {
            return Err(LogError::Header {
                file: file.to_string(),
                index: index + 1,
                expected: expected.to_string(),
                found: if found.is_empty() { "(nothing)".into() } else { crate::io::excerpt(found, 80) },
            });
        }
    }
    if names.len() > NANOBENCH_COLUMNS.len() {
        return Err(LogError::Header {
            file: file.to_string(),
            index: NANOBENCH_COLUMNS.len() + 1,
            expected: "(end of header)".into(),
            found: names[NANOBENCH_COLUMNS.len()].to_string(),
        });
    }
    Ok(header_end)
}

fn is_delim(b: u8) -> bool {
    b == b',' || b == b'\n' || b == b'\r'
}

/// A hand-rolled tokenizer over the data rows: each field is validated
/// (and, if kept, converted) in the same pass that finds its end.
struct Tokenizer<'a> {
    file: &'a str,
    body: &'a [u8],
    /// The header's names.
    names: &'a [String],
    /// The time column's index, checked to never decrease.
    time: Option<usize>,
    /// Whether columns not read are checked as numbers too (NanoBench).
    check_all: bool,
    /// [`ParseOptions::missing_as_nan`].
    missing_as_nan: bool,
    /// For each schema column, its positions in `columns`.
    slots: Vec<Vec<usize>>,
    columns: Vec<Vec<f64>>,
    previous_t: f64,
    /// Line number of the current row (1 = header).
    line: usize,
    /// Byte offset into `body`.
    i: usize,
}

impl Tokenizer<'_> {
    /// The end of the field starting at `from`.
    fn field_end(&self, from: usize) -> usize {
        from + self.body[from..].iter().position(|&b| is_delim(b)).unwrap_or(self.body.len() - from)
    }

    /// Reads one row; returns the number of fields it had.
    fn row(&mut self) -> Result<usize, LogError> {
        let n = self.names.len();
        let body = self.body;
        let mut col = 0;
        // The cursor stays in a local until the row ends.
        let mut i = self.i;
        loop {
            let start = i;
            if col < n && !self.slots[col].is_empty() {
                i = self.kept(col, i)?;
            } else if !self.check_all && body.get(i) == Some(&b'"') {
                // Not kept and quoted (text, as a spreadsheet writes it): a
                // comma inside the quotes is not a delimiter.
                i = quoted_end(body, i).ok_or_else(|| LogError::NonNumeric {
                    file: self.file.to_string(),
                    line: self.line,
                    column: self.names[col.min(n - 1)].clone(),
                    value: value_excerpt(&body[start..self.field_end(start)]),
                })?;
            } else {
                // Not kept: check it is a plain finite number without
                // converting it; anything unusual goes to the full parser.
                let (end, plain) = scan_plain(body, i);
                if col < n && !plain && self.check_all {
                    number(self.file, self.line, &self.names[col], &body[start..end])?;
                }
                i = end;
            }
            col += 1;
            match body.get(i) {
                Some(b',') => i += 1,
                Some(b'\r') if body.get(i + 1) == Some(&b'\n') => {
                    self.i = i + 2;
                    return Ok(col);
                }
                Some(b'\n') => {
                    self.i = i + 1;
                    return Ok(col);
                }
                None => {
                    self.i = i;
                    return Ok(col);
                }
                Some(_) => {
                    // A lone `\r` inside a line.
                    let end = self.field_end(i + 1);
                    return Err(LogError::NonNumeric {
                        file: self.file.to_string(),
                        line: self.line,
                        column: self.names[(col - 1).min(n - 1)].clone(),
                        value: value_excerpt(&body[start..end]),
                    });
                }
            }
        }
    }

    /// Converts the kept field at byte `i` in column `col` and stores it;
    /// returns where the field ends.
    #[inline(always)]
    fn kept(&mut self, col: usize, i: usize) -> Result<usize, LogError> {
        let body = self.body;
        let missing_ok = self.missing_as_nan && self.time != Some(col);
        if missing_ok && body.get(i).is_none_or(|&b| is_delim(b)) {
            // An empty field: missing, for the declared policy to judge.
            for &k in &self.slots[col] {
                self.columns[k].push(f64::NAN);
            }
            return Ok(i);
        }
        let (v, used) = match fast_float2::parse_partial::<f64, _>(&body[i..]) {
            Ok((v, used)) if used > 0 && (i + used == body.len() || is_delim(body[i + used])) => (v, used),
            _ => {
                let end = self.field_end(i);
                number(self.file, self.line, &self.names[col], &body[i..end])?;
                // `number` accepted what parse_partial refused: unreachable
                // in practice; report it as non-numeric all the same.
                return Err(LogError::NonNumeric {
                    file: self.file.to_string(),
                    line: self.line,
                    column: self.names[col].clone(),
                    value: value_excerpt(&body[i..end]),
                });
            }
        };
        if !v.is_finite() {
            if missing_ok {
                for &k in &self.slots[col] {
                    self.columns[k].push(f64::NAN);
                }
                return Ok(i + used);
            }
            number(self.file, self.line, &self.names[col], &body[i..i + used])?;
        }
        // Time may be in nanoseconds since the epoch (1.7e18); no other
        // quantity comes near 1e15 in SI units, and beyond it sums of
        // squares over a recording could overflow.
        if v.abs() > MAX_MAGNITUDE && self.time != Some(col) {
            return Err(LogError::TooLarge {
                file: self.file.to_string(),
                line: self.line,
                column: self.names[col].clone(),
                value: value_excerpt(&body[i..i + used]),
            });
        }
        if self.time == Some(col) {
            if v < self.previous_t {
                return Err(LogError::NonMonotonicTime {
                    file: self.file.to_string(),
                    column: self.names[col].clone(),
                    line: self.line,
                    t: v,
                    previous: self.previous_t,
                });
            }
            self.previous_t = v;
        }
        for &k in &self.slots[col] {
            self.columns[k].push(v);
        }
        Ok(i + used)
    }
}

/// The end of the quoted field opening at `i` (`""` is a quote inside
/// it): the byte after its closing quote, or `None` when the line ends
/// first (a field spanning lines is not a log's).
fn quoted_end(body: &[u8], i: usize) -> Option<usize> {
    let mut k = i + 1;
    loop {
        match body.get(k)? {
            b'"' if body.get(k + 1) == Some(&b'"') => k += 2,
            b'"' => return Some(k + 1),
            b'\n' | b'\r' => return None,
            _ => k += 1,
        }
    }
}

/// The largest magnitude a value other than time may have.
const MAX_MAGNITUDE: f64 = 1e15;

/// Finds the end of the field starting at `i` and, in the same pass,
/// whether it is `[+-]digits[.digits]` with at least one digit (always a
/// finite number, recognised without converting it). Anything else
/// (exponents, `inf`, `nan`, junk) goes through the full parser, which
/// decides and reports.
fn scan_plain(body: &[u8], i: usize) -> (usize, bool) {
    let mut k = i;
    if matches!(body.get(k), Some(b'-') | Some(b'+')) {
        k += 1;
    }
    let mut digits = 0usize;
    let mut dots = 0usize;
    let mut other = false;
    while let Some(&b) = body.get(k) {
        match b {
            b'0'..=b'9' => digits += 1,
            b'.' => dots += 1,
            b',' | b'\n' | b'\r' => break,
            _ => other = true,
        }
        k += 1;
    }
    // 300+ digits could overflow to infinity; let the parser decide.
    (k, !other && digits > 0 && dots <= 1 && digits < 300)
}

/// A field as an error quotes it: at most 80 characters.
fn value_excerpt(field: &[u8]) -> String {
    let head = String::from_utf8_lossy(&field[..field.len().min(400)]);
    match head.char_indices().nth(80) {
        None if field.len() <= 400 => head.into_owned(),
        None => format!("{head}... ({} bytes in all)", field.len()),
        Some((end, _)) => format!("{}... ({} bytes in all)", &head[..end], field.len()),
    }
}

fn number(file: &str, line: usize, column: &str, field: &[u8]) -> Result<f64, LogError> {
    let text = || value_excerpt(field);
    match fast_float2::parse::<f64, _>(field) {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(LogError::NonFinite { file: file.to_string(), line, column: column.into(), value: text() }),
        Err(_) => Err(LogError::NonNumeric { file: file.to_string(), line, column: column.into(), value: text() }),
    }
}
