//! Corrupt Parquet files: the parquet crate panics on some (a bit flipped
//! in a data page or in the footer) where it should return an error.
//! Before `io::caught`, each such file ended the whole command with a
//! panic (exit 101: a study's `data audit`, `check` or `run` stopped at
//! one bad log); now the file is refused as any unreadable file is, with
//! the decoder's words and the file's name. The corruptions below were
//! found by mutating the committed files with the release binary (random
//! byte changes over the whole file and over its footer).

use std::error::Error;
use std::path::Path;

use crate::common::{assert_ok, crossaudit, root, said};
use crossaudit::io::parquet::{decode_columns, to_csv_text};

/// One byte of the simulated lab's circle flight
/// (`test/lab-circle-take2.parquet` of the folder `simulate-lab` writes,
/// designs/logs/lab.design's fixture; the same bytes on every run) set to
/// a value, and the panic message it gave: in a
/// data page (an RLE run's length), and in the footer (a column chunk's
/// offset, a dictionary page's place).
const LOG_CORRUPTIONS: [(usize, u8, &str); 3] = [
    (138_794, 123, "Num of bytes exceed MAX_VLQ_BYTE_LEN"),
    (384_858, 255, "column start and length should not be negative"),
    (385_350, 165, "Decoder for dict should have been set"),
];

const CIRCLE: &str = "lab_logs/test/lab-circle-take2.parquet";

/// The simulated lab's folder written into `dir/lab_logs` (git keeps no
/// copy) and designs/logs/lab.design copied beside it; the design's path.
fn lab(dir: &Path) -> Result<String, Box<dyn Error>> {
    assert_ok(&crossaudit(&["simulate-lab", "--out", path(&dir.join("lab_logs"))?]));
    let design = dir.join("lab.design");
    std::fs::copy(root().join("designs/logs/lab.design"), &design)?;
    Ok(path(&design)?.to_string())
}

#[test]
fn a_corrupt_parquet_log_is_excluded_with_the_decoders_words_and_the_audit_goes_on() -> Result<(), Box<dyn Error>> {
    let dir = tempfile::tempdir()?;
    let design = lab(dir.path())?;
    let raw = std::fs::read(dir.path().join(CIRCLE))?;
    for (at, byte, words) in LOG_CORRUPTIONS {
        let mut bad = raw.clone();
        bad[at] = byte;
        std::fs::write(dir.path().join(CIRCLE), &bad)?;
        // The library: an error with the decoder's words, not a panic.
        let why = to_csv_text(bad.clone(), u64::MAX, "a flight log").err().ok_or("read")?;
        assert!(why.contains("cannot be decoded") && why.contains(words), "{why}");
        assert!(decode_columns(bytes::Bytes::from(bad), u64::MAX).is_none());
        // The binary: the flight excluded, named, with why; the other 20
        // logs audited.
        // Its recordings.csv into the temporary folder (by default
        // `audit/` of the working directory: the repository's root).
        let audit = path(&dir.path().join("audit"))?.to_string();
        let out = crossaudit(&["data", "audit", &design, "--out", &audit]);
        assert_ok(&out);
        let text = said(&out);
        assert!(!text.contains("panicked"), "{text}");
        assert!(text.contains("21 log files, 19 included, 2 excluded"), "{text}");
        let line = text.lines().find(|l| l.trim_start().starts_with("lab-circle-take2:")).unwrap_or("");
        assert!(
            line.contains("lab-circle-take2.parquet: not a readable Parquet file") && line.contains(words),
            "{text}"
        );
    }
    Ok(())
}

#[test]
fn no_byte_of_a_parquet_footer_set_to_any_of_three_values_panics_a_reader() -> Result<(), Box<dyn Error>> {
    // A per-cell file as a run writes it (cells.parquet: text, integer and
    // double columns, one row group) and a lab's log: every byte of the
    // footer (the Thrift metadata: offsets, sizes, counts, types) set to
    // 0x00, 0xff and its complement in turn. Each read ends in a value or
    // an error; none panics (a panic would fail this test). Some are the
    // decoder's own panics, caught: counted, so the test shows it met them.
    let csv = std::fs::read(root().join("results/quickstart/cells.csv"))?;
    let cells = crossaudit::io::parquet::csv_to_parquet(&csv)?;
    let dir = tempfile::tempdir()?;
    lab(dir.path())?;
    let log = std::fs::read(dir.path().join(CIRCLE))?;
    let mut caught = 0;
    for raw in [cells, log] {
        for at in footer(&raw)? {
            for byte in [0x00, 0xff, !raw[at]] {
                let mut bad = raw.clone();
                bad[at] = byte;
                decode_columns(bytes::Bytes::from(bad.clone()), 1 << 30);
                if let Err(why) = to_csv_text(bad, 1 << 30, "a file") {
                    caught += usize::from(why.contains("cannot be decoded"));
                }
            }
        }
    }
    assert!(caught > 0, "no corruption reached a panic of the decoder");
    Ok(())
}

#[test]
fn a_corrupt_parquet_cells_file_is_refused_at_its_name() -> Result<(), Box<dyn Error>> {
    let csv = std::fs::read(root().join("results/quickstart/cells.csv"))?;
    let mut raw = crossaudit::io::parquet::csv_to_parquet(&csv)?;
    // A footer byte that makes the decoder panic, found as the test above
    // finds them (the last one), so this stays true if the writer changes
    // how it lays the file out.
    let at = footer(&raw)?.rev().flat_map(|at| [0x00, 0xff].map(|b| (at, b))).find(|&(at, b)| {
        let mut bad = raw.clone();
        bad[at] = b;
        to_csv_text(bad, 1 << 30, "a file").is_err_and(|why| why.contains("cannot be decoded"))
    });
    let (at, byte) = at.ok_or("no footer byte the decoder panics on")?;
    raw[at] = byte;
    let dir = tempfile::tempdir()?;
    let cells = dir.path().join("cells.parquet");
    std::fs::write(&cells, &raw)?;
    let report = dir.path().join("report");
    let args = ["analyze", "designs/quickstart.design", "--cells", path(&cells)?, "--out", path(&report)?];
    let out = crossaudit(&args);
    let text = said(&out);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(!text.contains("panicked"), "{text}");
    let named = format!("{}: not a readable Parquet file: it cannot be decoded", cells.display());
    assert!(text.contains(&named), "{text}");
    assert!(!report.exists());
    Ok(())
}

/// The byte range of a Parquet file's footer (its Thrift metadata).
fn footer(raw: &[u8]) -> Result<std::ops::Range<usize>, Box<dyn Error>> {
    let end = raw.len().checked_sub(8).ok_or("short")?;
    let length = u32::from_le_bytes(raw[end..end + 4].try_into()?) as usize;
    Ok(end.checked_sub(length).ok_or("footer")?..end)
}

fn path(p: &Path) -> Result<&str, Box<dyn Error>> {
    Ok(p.to_str().ok_or("a path that is not UTF-8")?)
}
