//! A CSV file read on every core. The file is read in blocks; each block
//! is cut at line breaks into chunks, and the chunks are parsed at once,
//! their rows kept in file order, so the rows are the same whatever the
//! thread count.
//!
//! This reader only accelerates: it takes files whose records are one line
//! each (no quote, no line break but `\n` or `\r\n`), and whenever anything
//! is off (a quote, a lone `\r`, a row of the wrong length, a row the
//! caller refuses, a read that fails) it gives up, for the caller's
//! reference reader to read the file and say what and where.

use std::io::Read;

use rayon::prelude::*;

/// Bytes of text parsed as one task: about 12,000 per-cell rows.
pub const CHUNK: usize = 1 << 20;

/// Chunks read before they are parsed together: a bound on the text held.
const WAVE: usize = 16;

/// The rows of the CSV `reader` (at most `limit` bytes; about `size`
/// bytes expected, 0 where unknown: room for its rows is taken once, from
/// the rows of its first block), parsed in chunks of about `chunk` bytes,
/// with what each chunk's rows left in their state (in file order);
/// `None` where a reference reader must read it.
/// `header` reads the header record (`None`: a header this file's reader
/// refuses); `row` reads the fields of the record on 1-based line `line`,
/// with its chunk's state (`None`: a row it refuses). Every row has the
/// header's number of fields. `seen` is given every byte read, in file
/// order, while the text before it is parsed (to hash the file as it is
/// read); where the reader gives up, it has seen only part of the file.
pub fn read<H, S, T>(
    reader: impl Read,
    (limit, size, chunk): (u64, u64, usize),
    header: impl FnOnce(&csv::StringRecord) -> Option<H>,
    row: impl Fn(&H, u64, &[&str], &mut S) -> Option<T> + Sync,
    mut seen: impl FnMut(&[u8]) + Send,
) -> Option<(Vec<T>, Vec<S>)>
where
    H: Sync,
    S: Default + Send,
    T: Send,
{
    let mut input = reader.take(limit.saturating_add(1));
    let (mut text, mut rows, mut states) = (Vec::new(), Vec::new(), Vec::new());
    let (mut head, mut header) = (None, Some(header));
    // Line breaks before the text held.
    let (mut lines_before, mut total) = (0u64, 0u64);
    loop {
        let want = chunk.max(1) * WAVE;
        let old = text.len();
        let got = (&mut input).take(want as u64).read_to_end(&mut text).ok()?;
        total += got as u64;
        if total > limit {
            return None;
        }
        let at_end = got < want;
        // The text up to its last line break is parsed now; the rest
        // waits for the next block (all of it at the end).
        let cut = if at_end { text.len() } else { memchr::memrchr(b'\n', &text).map_or(0, |k| k + 1) };
        if cut == 0 && !at_end {
            // Not one whole line yet.
            seen(&text[old..]);
            continue;
        }
        let mut from = 0;
        if let Some(read_header) = header.take() {
            let end = memchr::memchr(b'\n', &text[..cut]).map_or(cut, |k| k + 1);
            let mut rdr = csv::ReaderBuilder::new().has_headers(true).from_reader(&text[..end]);
            let record = rdr.headers().ok()?;
            head = Some((read_header(record)?, record.len()));
            (from, lines_before) = (end, 1);
        }
        let (h, fields) = head.as_ref()?;
        let ranges = split(&text[..cut], from, chunk);
        let first = first_lines(&text, &ranges, &mut lines_before)?;
        // The new bytes are seen on one core while the others parse.
        let ((), parsed) = rayon::join(
            || seen(&text[old..]),
            || -> Vec<Option<(Vec<T>, S)>> {
                ranges
                    .par_iter()
                    .zip(first)
                    .map(|(&(a, b), (before, breaks))| {
                        parse(&text[a..b], (before, breaks), *fields, |line, rec, s| row(h, line, rec, s))
                    })
                    .collect()
            },
        );
        let parsed: Vec<(Vec<T>, S)> = parsed.into_iter().collect::<Option<_>>()?;
        let n: usize = parsed.iter().map(|p| p.0.len()).sum();
        if rows.is_empty() && !at_end {
            // The rest at this block's rows per byte, and 1/16 more: one
            // allocation, not a doubling and a copy (at 10M rows, 1 GB
            // and seconds).
            let rest = size.min(limit).saturating_sub(total) as f64 * n as f64 / cut as f64 * 1.0625;
            rows.reserve_exact(n.saturating_add(rest as usize));
        }
        rows.reserve(n);
        for (r, s) in parsed {
            rows.extend(r);
            states.push(s);
        }
        text.drain(..cut);
        if at_end {
            return Some((rows, states));
        }
    }
}

/// For each range of `text`, the line breaks before it (from
/// `lines_before`, which it advances) and in it, counted at once; `None`
/// where a range's records are not one line each.
fn first_lines(text: &[u8], ranges: &[(usize, usize)], lines_before: &mut u64) -> Option<Vec<(u64, u64)>> {
    let breaks: Vec<Option<u64>> = ranges.par_iter().map(|&(a, b)| line_breaks(&text[a..b])).collect();
    let mut first = Vec::with_capacity(ranges.len());
    for b in breaks {
        let b = b?;
        first.push((*lines_before, b));
        *lines_before += b;
    }
    Some(first)
}

/// The line breaks of `text`; `None` where its records are not one line
/// each: it holds a quote, or a `\r` that does not begin a `\r\n`.
fn line_breaks(text: &[u8]) -> Option<u64> {
    let lone_cr = memchr::memchr_iter(b'\r', text).any(|k| text.get(k + 1) != Some(&b'\n'));
    if lone_cr || memchr::memchr(b'"', text).is_some() {
        return None;
    }
    Some(memchr::memchr_iter(b'\n', text).count() as u64)
}

/// `text[from..]` cut into ranges of about `chunk` bytes, each ending
/// after a line break (the last at the end of the text).
fn split(text: &[u8], mut from: usize, chunk: usize) -> Vec<(usize, usize)> {
    let mut ranges = Vec::new();
    while from < text.len() {
        let aim = (from + chunk.max(1)).min(text.len());
        let end = match memchr::memchr(b'\n', &text[aim - 1..]) {
            Some(k) => aim + k,
            None => text.len(),
        };
        ranges.push((from, end));
        from = end;
    }
    ranges
}

/// The rows of one chunk of whole lines, `before` lines into the file and
/// holding `breaks` line breaks, each of `fields` fields, and the state
/// they left; `None` at the first row refused. A chunk holds no quote and
/// no lone `\r`, so its records are its lines split at commas, as the csv
/// crate splits them: a blank line is no record, text that is not UTF-8
/// is refused.
fn parse<S: Default, T>(
    text: &[u8],
    (before, breaks): (u64, u64),
    fields: usize,
    row: impl Fn(u64, &[&str], &mut S) -> Option<T>,
) -> Option<(Vec<T>, S)> {
    let text = std::str::from_utf8(text).ok()?;
    // At most one row per line (one more without a final line break).
    let (mut rows, mut state) = (Vec::with_capacity(breaks as usize + 1), S::default());
    let mut record: Vec<&str> = Vec::with_capacity(fields);
    let mut start = 0;
    let ends = memchr::memchr_iter(b'\n', text.as_bytes()).chain((!text.ends_with('\n')).then_some(text.len()));
    for (k, end) in ends.enumerate() {
        let line = &text[start..end];
        start = end + 1;
        let line = line.strip_suffix('\r').unwrap_or(line);
        if line.is_empty() {
            continue;
        }
        record.clear();
        let mut from = 0;
        // Commas and line breaks are ASCII: every cut is a char boundary.
        for comma in memchr::memchr_iter(b',', line.as_bytes()) {
            record.push(&line[from..comma]);
            from = comma + 1;
        }
        record.push(&line[from..]);
        if record.len() != fields {
            return None;
        }
        rows.push(row(before + 1 + k as u64, &record, &mut state)?);
    }
    Some((rows, state))
}
