//! A CSV file read on every core. The file is read in blocks, the next
//! while one is parsed. Each block's records are found in chunks cut at
//! line breaks, all at once; then every record is parsed on any core
//! straight into its place in the rows, in file order, so the rows are the
//! same whatever the thread count and none is copied after it is made.
//!
//! This reader only accelerates: it takes files whose records are one line
//! each (no quote, no line break but `\n` or `\r\n`), and whenever anything
//! is off (a quote, a lone `\r`, a row of the wrong length, a row the
//! caller refuses, a read that fails) it gives up, for the caller's
//! reference reader to read the file and say what and where.

use std::io::Read;
use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;

/// Bytes of text whose records are found as one task: about 12,000
/// per-cell rows.
pub const CHUNK: usize = 1 << 20;

/// Chunks read before they are parsed together: a bound on the text held.
/// A block of 4 MiB is still in the processor's cache when it is hashed
/// and parsed after its read; blocks of 16 MiB, read from memory again,
/// took 5-7% longer over a 1M-row file at 1 and at 2 threads.
const WAVE: usize = 4;

/// The rows of the CSV `reader` (at most `limit` bytes; about `size`
/// bytes expected, 0 where unknown: room for its rows is taken once, from
/// the rows of its first block), parsed in chunks of about `chunk` bytes;
/// `None` where a reference reader must read it.
/// `header` reads the header record (`None`: a header this file's reader
/// refuses); `row` reads the fields of the record on 1-based line `line`,
/// with a scratch state of its own (`None`: a row it refuses). Rows are
/// parsed on every core straight into their place in the result, so no
/// row is copied after it is made; `fill` stands in, unseen, for a row
/// refused (the whole read is then given up). Every row has the header's
/// number of fields. `seen` is given every byte read, in file order,
/// while the text before it is parsed (to hash the file as it is read);
/// where the reader gives up, it has seen only part of the file.
pub fn read<H, N, T>(
    reader: impl Read + Send,
    (limit, size, chunk): (u64, u64, usize),
    header: impl FnOnce(&csv::StringRecord) -> Option<H>,
    (row, fill): (impl Fn(&H, u64, &[&str], &mut N) -> Option<T> + Sync, &T),
    mut seen: impl FnMut(&[u8]) + Send,
) -> Option<Vec<T>>
where
    H: Sync,
    N: Default + Send,
    T: Send + Sync + Clone,
{
    let mut input = reader.take(limit.saturating_add(1));
    let want = chunk.max(1) * WAVE;
    let mut block = |buf: &mut Vec<u8>| (&mut input).take(want as u64).read_to_end(buf).ok();
    // The text held, from `old` on not yet seen; the next block is read
    // into `spare` while this one is parsed.
    let (mut text, mut spare, mut old) = (Vec::new(), Vec::new(), 0);
    let (mut rows, mut lines) = (Vec::new(), Vec::new());
    let (mut head, mut header) = (None, Some(header));
    // Line breaks before the text held.
    let (mut lines_before, mut total) = (0u64, 0u64);
    let mut got = block(&mut text)?;
    loop {
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
            old = text.len();
            got = block(&mut text)?;
            continue;
        }
        let mut from = 0;
        if let Some(read_header) = header.take() {
            let (read, end) = header_of(&text[..cut], read_header)?;
            (head, from, lines_before) = (Some(read), end, 1);
        }
        let (h, fields) = head.as_ref()?;
        lines_of(&text[..cut], split(&text[..cut], from, chunk), &mut lines_before, &mut lines)?;
        if rows.is_empty() && !at_end {
            // The rest at this block's rows per byte, and 1/16 more: one
            // allocation, not a doubling and a copy (at 10M rows, 1 GB
            // and seconds).
            let rest = size.min(limit).saturating_sub(total) as f64 * lines.len() as f64 / cut as f64 * 1.0625;
            rows.reserve_exact(lines.len().saturating_add(rest as usize));
        }
        // The unparsed end of this block begins the next.
        spare.clear();
        spare.extend_from_slice(&text[cut..]);
        let next_old = spare.len();
        // The new bytes are seen, and the next block read, on one core
        // while the others parse.
        let (held, lines) = (&text[..cut], &lines);
        let (next, parsed) = rayon::join(
            || {
                seen(&text[old..]);
                if at_end {
                    Some(0)
                } else {
                    block(&mut spare)
                }
            },
            || parse(held, lines, (h, *fields), (&row, fill), &mut rows),
        );
        parsed?;
        if at_end {
            return Some(rows);
        }
        got = next?;
        std::mem::swap(&mut text, &mut spare);
        old = next_old;
    }
}

/// The header record at the start of `text`, as `read` reads it, with
/// its number of fields, and where the rows begin.
fn header_of<H>(text: &[u8], read: impl FnOnce(&csv::StringRecord) -> Option<H>) -> Option<((H, usize), usize)> {
    let end = memchr::memchr(b'\n', text).map_or(text.len(), |k| k + 1);
    let mut rdr = csv::ReaderBuilder::new().has_headers(true).from_reader(&text[..end]);
    let record = rdr.headers().ok()?;
    Some(((read(record)?, record.len()), end))
}

/// A record's line in the text held: its bytes (without the line
/// break) and its 1-based line in the file.
struct Line {
    start: usize,
    end: usize,
    line: u64,
}

/// Every record of `text`'s `ranges` into `lines` (cleared first), each
/// range read on its own core, and `lines_before` advanced past `text`'s
/// line breaks; `None` where its records are not one line each: it holds
/// a quote, or a `\r` that does not begin a `\r\n`. A blank line is no
/// record, as the csv crate reads it.
fn lines_of(text: &[u8], ranges: Vec<(usize, usize)>, lines_before: &mut u64, lines: &mut Vec<Line>) -> Option<()> {
    let per_range: Vec<Option<(Vec<Line>, u64)>> = ranges
        .into_par_iter()
        .map(|(a, b)| {
            let range = &text[a..b];
            let lone_cr = memchr::memchr_iter(b'\r', range).any(|k| range.get(k + 1) != Some(&b'\n'));
            if lone_cr || memchr::memchr(b'"', range).is_some() {
                return None;
            }
            // Line numbers from the range's start, made the file's below.
            let (mut out, mut start, mut breaks) = (Vec::new(), a, 0u64);
            let ends = memchr::memchr_iter(b'\n', range).map(|k| a + k).chain((!range.ends_with(b"\n")).then_some(b));
            for end in ends {
                let line = &text[start..end];
                let stripped = line.strip_suffix(b"\r").map_or(end, |l| start + l.len());
                if stripped > start {
                    out.push(Line { start, end: stripped, line: breaks + 1 });
                }
                start = end + 1;
                breaks += 1;
            }
            // The last line of a text without a final line break ends at
            // no line break.
            Some((out, breaks - u64::from(!range.ends_with(b"\n"))))
        })
        .collect();
    lines.clear();
    for r in per_range {
        let (mut found, breaks) = r?;
        found.iter_mut().for_each(|l| l.line += *lines_before);
        lines.append(&mut found);
        *lines_before += breaks;
    }
    Some(())
}

/// The records `lines` of `text`, each of `fields` fields, read by `row`
/// (with `header`'s reading `h`) on every core and appended to `rows` in
/// their order, each made in its place; `None` where one is refused (and
/// `fill` stands in for it).
fn parse<H, N, T>(
    text: &[u8],
    lines: &[Line],
    (h, fields): (&H, usize),
    (row, fill): (&(impl Fn(&H, u64, &[&str], &mut N) -> Option<T> + Sync), &T),
    rows: &mut Vec<T>,
) -> Option<()>
where
    H: Sync,
    N: Default + Send,
    T: Send + Sync + Clone,
{
    let refused = AtomicBool::new(false);
    let one = |(state, record): &mut (N, Vec<_>), l: &Line| {
        let parsed = (!refused.load(Ordering::Relaxed)).then(|| fields_of(text, l, record)).flatten();
        match parsed.filter(|record| record.len() == fields) {
            Some(record) => row(h, l.line, record, state),
            None => None,
        }
        .unwrap_or_else(|| {
            refused.store(true, Ordering::Relaxed);
            fill.clone()
        })
    };
    rows.par_extend(lines.par_iter().map_init(|| (N::default(), Vec::with_capacity(fields)), one));
    (!refused.into_inner()).then_some(())
}

/// The fields of line `l` of `text` (split at commas, as the csv crate
/// splits a line without quotes) into `record`; `None` where it is not
/// UTF-8. The commas are found eight bytes at a time ([`commas`]).
fn fields_of<'t, 'r>(text: &'t [u8], l: &Line, record: &'r mut Vec<&'t str>) -> Option<&'r [&'t str]> {
    let line = std::str::from_utf8(&text[l.start..l.end]).ok()?;
    record.clear();
    // Commas are ASCII: every cut is a char boundary.
    let mut from = 0;
    let mut cut = |at: usize, mut found: u64| {
        while found != 0 {
            let comma = at + (found.trailing_zeros() / 8) as usize;
            record.push(&line[from..comma]);
            from = comma + 1;
            found &= found - 1;
        }
    };
    let mut words = line.as_bytes().chunks_exact(8);
    let mut at = 0;
    for w in &mut words {
        cut(at, commas(u64::from_le_bytes([w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]])));
        at += 8;
    }
    // The last bytes, and zeros (no comma) after them.
    let tail = words.remainder().iter().rev().fold(0u64, |w, &b| w << 8 | u64::from(b));
    cut(at, commas(tail));
    record.push(&line[from..]);
    Some(record)
}

/// The top bit of each byte of `word` that is a comma, and no other bit.
/// (Per byte y of word ^ ",,,,,,,,": (y & 0x7f) + 0x7f sets the top bit
/// unless y's low seven bits are zero, without a carry out of the byte;
/// `| y` sets it where y's own top bit is set; so it stays clear exactly
/// where y is zero.)
fn commas(word: u64) -> u64 {
    const LOW: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    let x = word ^ 0x2c2c_2c2c_2c2c_2c2c;
    !(((x & LOW).wrapping_add(LOW)) | x | LOW)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The fields found eight bytes at a time are `str::split(',')`'s,
    /// for lines of every length around the word size, commas at every
    /// place, and bytes that differ from a comma only in the top bit
    /// (0xAC, inside "¬" and "€") or are zero.
    #[test]
    fn fields_are_the_lines_split_at_commas() {
        let pieces = [",", "a", "¬", "€,", "\0", ",,", "0.980943", " ", "R00001"];
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..5000 {
            let mut record = Vec::new();
            let mut line = String::new();
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            for k in 0..(rng % 24) {
                line.push_str(pieces[((rng >> (2 * k)) % pieces.len() as u64) as usize]);
            }
            let l = Line { start: 0, end: line.len(), line: 1 };
            let got = fields_of(line.as_bytes(), &l, &mut record).map(<[&str]>::to_vec);
            assert_eq!(got, Some(line.split(',').collect::<Vec<_>>()), "{line:?}");
        }
        // Not UTF-8: refused.
        let bad = b"a,\xff,b";
        assert_eq!(fields_of(bad, &Line { start: 0, end: 5, line: 1 }, &mut Vec::new()), None);
    }

    #[test]
    fn commas_marks_exactly_the_comma_bytes() {
        for b in 0..=255u8 {
            for at in 0..8 {
                let mut word = [b'x'; 8];
                word[at] = b;
                let want = if b == b',' { 0x80u64 << (8 * at) } else { 0 };
                assert_eq!(commas(u64::from_le_bytes(word)), want, "byte {b:#x} at {at}");
            }
        }
        assert_eq!(commas(u64::from_le_bytes(*b",,,,,,,,")), 0x8080_8080_8080_8080);
        assert_eq!(commas(0), 0);
    }
}
