//! The per-cell readers against each other: the chunked reader against
//! the streaming reference, and fast-float2 against `str::parse`.
#![cfg(test)]

use super::row::{number, trim};
use super::*;

/// The committed per-cell files of every layout: plain, with `split`,
/// with `dose`, with empty optional columns.
fn committed() -> Vec<(String, Vec<u8>)> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    [
        "examples/cells/nanobench_synthetic.csv",
        "results/quickstart/cells.csv",
        "results/dose_response/cells.csv",
        "results/multi_split/cells.csv",
        "results/lab/cells.csv",
        "results/rotorpy/cells.csv",
    ]
    .iter()
    .filter_map(|f| std::fs::read(root.join(f)).ok().map(|b| (f.to_string(), b)))
    .collect()
}

/// The chunked reader gives the reference reader's cells, lines
/// included, at any chunk size, with `\n` or `\r\n` line breaks,
/// blank lines, and no line break at the end.
#[test]
fn chunks_read_what_the_reference_reader_reads() -> Result<(), Box<dyn std::error::Error>> {
    let files = committed();
    assert_eq!(files.len(), 6, "the committed per-cell files are read");
    for (name, bytes) in files {
        let crlf: Vec<u8> = String::from_utf8(bytes.clone())?.replace('\n', "\r\n").into_bytes();
        let blank: Vec<u8> = String::from_utf8(bytes.clone())?.replacen("\n", "\n\n", 7).into_bytes();
        let bare = bytes.strip_suffix(b"\n").unwrap_or(&bytes).to_vec();
        for text in [&bytes, &crlf, &blank, &bare] {
            let reference = read_cells_from(&name, text.as_slice())?;
            for chunk in [1, 100, 4096, crate::io::chunked::CHUNK] {
                let cells = read_chunked(&name, (text.as_slice(), text.len() as u64), chunk, |_| {})
                    .unwrap_or_else(|| panic!("{name} at {chunk}"));
                assert_eq!(cells, reference, "{name}, chunks of {chunk} bytes");
            }
        }
    }
    Ok(())
}

/// A column with values in some rows and empty in others where not every
/// start diverged is refused, whichever rows each core read and at any
/// chunk size: the parallel reader gives the file up, and the reference
/// reader names the first such row and the first row with a value.
#[test]
fn a_column_empty_in_some_rows_only_is_refused_at_any_chunk_size() -> Result<(), Box<dyn std::error::Error>> {
    let name = "examples/cells/nanobench_synthetic.csv";
    let text = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(name))?;
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    // One gap, on file line 3001 (lines[3000]), in the velocity (field
    // 12): a core that reads the rows around it must not lose it.
    let mut f: Vec<&str> = lines[3000].split(',').collect();
    assert_ne!(f[7], f[8], "line 3001: not every start diverged");
    f[12] = "";
    lines[3000] = f.join(",");
    let bytes = (lines.join("\n") + "\n").into_bytes();
    for chunk in [1, 100, 4096, crate::io::chunked::CHUNK] {
        assert!(read_chunked(name, (bytes.as_slice(), 0), chunk, |_| {}).is_none(), "chunks of {chunk}");
    }
    let e = read_cells_from(name, bytes.as_slice()).err().ok_or("a gap was accepted")?.to_string();
    assert!(e.contains("line 3001, field `velocity_rmse_mps`") && e.contains("line 2 has a value"), "{e}");
    Ok(())
}

/// The plain-decimal reader, fast-float2 and Rust's own parser read the
/// same numbers to the same values: random strings over the characters of
/// numbers, infinities and NaN, the shortest round-trip text of random
/// doubles, and plain decimals of 1 to 20 digits.
#[test]
fn numbers_are_read_as_rusts_parser_reads_them() {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        state >> 11
    };
    let alphabet = b"0123456789012345678901234567890123456789..eE+-_ infatyINFATYx";
    let (mut read, mut checked) = (0, 0);
    for _ in 0..300_000 {
        let len = 1 + next() % 12;
        let s: String = (0..len).map(|_| alphabet[next() as usize % alphabet.len()] as char).collect();
        let (ours, std) = (number(&s), s.parse::<f64>().ok());
        assert_eq!(ours.map(f64::to_bits), std.map(f64::to_bits), "{s:?}");
        read += usize::from(std.is_some());
        checked += 1;
    }
    for _ in 0..100_000 {
        let x = f64::from_bits(next() << 11 ^ next());
        for s in [format!("{x:?}"), format!("{x}"), format!("{x:e}"), format!("{:.6}", x)] {
            assert_eq!(number(&s).map(f64::to_bits), s.parse::<f64>().ok().map(f64::to_bits), "{s:?}");
        }
    }
    // Plain decimals around the 15 digits read at once: 1 to 20 digits,
    // with and without a point.
    for _ in 0..200_000 {
        let len = 1 + next() as usize % 20;
        let mut s: String = (0..len).map(|_| char::from(b'0' + (next() % 10) as u8)).collect();
        if next() % 4 != 0 {
            s.insert(next() as usize % (len + 1), '.');
        }
        assert_eq!(number(&s).map(f64::to_bits), s.parse::<f64>().ok().map(f64::to_bits), "{s:?}");
    }
    assert!(read > 30_000 && checked == 300_000, "{read} of {checked} random strings were numbers");
}

/// On damaged files the chunked reader gives up or agrees: it never
/// returns cells the reference reader refuses, or other cells.
#[test]
fn chunks_never_accept_what_the_reference_reader_refuses() -> Result<(), Box<dyn std::error::Error>> {
    let (name, bytes) = committed().swap_remove(0);
    let bytes = bytes[..bytes.len().min(20_000)].to_vec();
    // A 64-bit LCG (Knuth's MMIX constants): positions and bytes.
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 33) as usize
    };
    let alphabet = b",\n\r\"x0.-9 e";
    let (mut refused, mut gave_up) = (0, 0);
    for _ in 0..400 {
        let mut text = bytes.clone();
        for _ in 0..1 + next() % 3 {
            let at = next() % text.len();
            text[at] = alphabet[next() % alphabet.len()];
        }
        let reference = read_cells_from(&name, text.as_slice());
        refused += usize::from(reference.is_err());
        match read_chunked(&name, (text.as_slice(), text.len() as u64), 1 + next() % 3000, |_| {}) {
            Some(cells) => assert_eq!(cells, reference?, "accepted: {:?}", String::from_utf8_lossy(&text)),
            None => gave_up += 1,
        }
    }
    assert!(refused > 100 && gave_up >= refused, "{refused} refused, {gave_up} given up");
    Ok(())
}

/// The chunked reader shows its observer every byte of the file once, in
/// order, whatever the chunk size; and a file read and hashed at once
/// has the hash of its bytes, on the parallel path, on the reference
/// reader's (a quoted field) and as Parquet.
#[test]
fn a_file_is_hashed_as_it_is_read() -> Result<(), Box<dyn std::error::Error>> {
    let (name, bytes) = committed().swap_remove(0);
    for chunk in [1, 100, 4096, crate::io::chunked::CHUNK] {
        let mut seen = Vec::new();
        let cells = read_chunked(&name, (bytes.as_slice(), 0), chunk, |b| seen.extend_from_slice(b));
        assert!(cells.is_some(), "{name} at {chunk}");
        assert!(seen == bytes, "{name} at {chunk}: {} bytes seen of {}", seen.len(), bytes.len());
    }
    let dir = tempfile::tempdir()?;
    // The first row's model name in quotes: the same cells, read by the
    // reference reader.
    let text = String::from_utf8(bytes.clone())?;
    let (head, rest) = text.split_once('\n').ok_or("no header line")?;
    let (model, rest) = rest.split_once(',').ok_or("no first field")?;
    let quoted = format!("{head}\n\"{model}\",{rest}");
    assert!(read_chunked(&name, (quoted.as_bytes(), 0), 4096, |_| {}).is_none());
    let parquet = crate::io::parquet::csv_to_parquet(&bytes)?;
    for (file, text) in [("plain.csv", bytes.clone()), ("quoted.csv", quoted.into_bytes()), ("cells.parquet", parquet)]
    {
        let path = dir.path().join(file);
        std::fs::write(&path, &text)?;
        let (cells, sha) = read_cells_hashed(&path)?;
        assert_eq!(sha, crate::io::sha256_hex(&text), "{file}");
        assert_eq!(cells, read_cells(&path)?, "{file}");
    }
    Ok(())
}

/// The fast trim is `str::trim`: on random strings of ASCII, Unicode
/// spaces (U+00A0, U+2003, U+3000), control characters and accents.
#[test]
fn fields_are_trimmed_as_str_trim_trims() {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 33) as usize
    };
    let alphabet =
        ['a', 'Z', '0', '.', ' ', '\t', '\n', '\u{a0}', '\u{2003}', '\u{3000}', '\u{85}', 'é', '~', '\u{7f}'];
    for _ in 0..200_000 {
        let s: String = (0..next() % 6).map(|_| alphabet[next() % alphabet.len()]).collect();
        assert_eq!(trim(&s), s.trim(), "{s:?}");
    }
}

/// A cell holds its counts in 4 bytes: the largest count is read, one more
/// is refused by line and field, by both readers, not wrapped around.
#[test]
fn counts_above_four_bytes_are_refused_by_line_and_field() -> Result<(), Box<dyn std::error::Error>> {
    let header = HEADER.join(",");
    let row = |starts: &str| format!("world,disjoint,1,r01,lemniscate,fast,1,{starts},0,0.2,0.2,0,0.1,1.5");
    let largest = format!("{header}\n{}\n", row("4294967295"));
    let cells = read_cells_from("largest.csv", largest.as_bytes())?;
    assert_eq!(cells[0].n_starts, u32::MAX);
    let chunked = read_chunked("largest.csv", (largest.as_bytes(), largest.len() as u64), 64, |_| {});
    assert_eq!(chunked.as_deref(), Some(&cells[..]));
    let over = format!("{header}\n{}\n", row("4294967296"));
    let e = read_cells_from("over.csv", over.as_bytes()).err().ok_or("4294967296 starts were read")?.to_string();
    assert!(e.contains("over.csv: line 2, field `n_starts`: is larger than 4294967295"), "{e}");
    // The parallel reader gives such a file up to the reference reader.
    assert!(read_chunked("over.csv", (over.as_bytes(), over.len() as u64), 64, |_| {}).is_none());
    Ok(())
}

/// A per-cell Parquet file read from its columns gives the cells its CSV
/// text gives (`io::parquet::to_csv_text`, then the reference reader):
/// every committed layout (plain, `split`, `dose`, empty optional
/// columns), names with spaces around them, commas and quotes, in one row
/// group or in groups of 1,000 rows, read 1, 7, 4,096 or 65,536 rows at a
/// time, and taken from the columns (not from the text) every time.
#[test]
fn parquet_cells_read_from_their_columns_are_the_cells_their_text_gives() -> Result<(), Box<dyn std::error::Error>> {
    let mut files = committed();
    assert_eq!(files.len(), 6, "the committed per-cell files are read");
    let (name, bytes) = files[0].clone();
    let text = String::from_utf8(bytes)?;
    let names = text.replacen("\nworld,", "\n  world ,", 40).replacen("\nworld,", "\n\"wo,rld\",", 40);
    let names = names.replacen("\nworld,", "\n\"say \"\"hi\"\"\",", 40);
    assert!(names.contains("\"wo,rld\"") && names.contains("say \"\"hi"), "{name}: names edited");
    files.push((format!("{name}, names edited"), names.into_bytes()));
    // Nulls where the text has empty fields: a row where every start
    // diverged (its conditional RMSE empty), and a layout with no velocity
    // or attitude (those columns empty in every row).
    let header: Vec<&str> = text.lines().next().ok_or("no header")?.split(',').collect();
    let at = |field: &str| header.iter().position(|h| *h == field).ok_or(format!("no {field}"));
    let (starts, divergent, rate, conditional) =
        (at("n_starts")?, at("n_divergent")?, at("divergence_rate")?, at("conditional_position_rmse_m")?);
    let (velocity, attitude) = (at("velocity_rmse_mps")?, at("attitude_rmse_deg")?);
    let mut diverged: Vec<String> = text.lines().map(String::from).collect();
    let mut f: Vec<String> = diverged[40].split(',').map(String::from).collect();
    f[divergent] = f[starts].clone();
    f[rate] = "1".into();
    f[conditional] = String::new();
    diverged[40] = f.join(",");
    files.push((format!("{name}, a row all diverged"), (diverged.join("\n") + "\n").into_bytes()));
    let without: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(k, l)| {
            let mut f: Vec<&str> = l.split(',').collect();
            if k > 0 {
                (f[velocity], f[attitude]) = ("", "");
            }
            f.join(",")
        })
        .collect();
    files.push((format!("{name}, no velocity or attitude"), (without.join("\n") + "\n").into_bytes()));
    let dir = tempfile::tempdir()?;
    let mut taken = 0;
    for (name, bytes) in &files {
        for group in [usize::MAX, 1000] {
            let parquet = crate::io::parquet::csv_to_parquet_in(bytes, group)?;
            let text = crate::io::parquet::to_csv_text(parquet.clone(), u64::MAX, "a per-cell file")?;
            let reference = rows_of(read_cells_from(name, text.as_slice())?);
            let file = crate::io::parquet::open_columns(parquet.clone().into(), u64::MAX).ok_or("opened by column")?;
            for batch in [1, 7, 4096, 65_536] {
                let cells = columns::from_columns_in(&file, batch, u64::MAX)
                    .ok_or_else(|| format!("{name}: not read by column"))?;
                // Debug, so that -0.0 and 0.0 differ.
                assert_eq!(format!("{cells:?}"), format!("{reference:?}"), "{name}, groups of {group}, batch {batch}");
                taken += 1;
            }
            let path = dir.path().join("cells.parquet");
            std::fs::write(&path, &parquet)?;
            assert_eq!(read_cells(&path)?, reference, "{name}");
        }
    }
    assert_eq!(taken, 9 * 2 * 4);
    Ok(())
}

/// A per-cell Parquet file whose CSV text might pass the reader's limit
/// goes to that text, which its reader refuses past the limit: the
/// columns are read only where a bound on the text (each number at its
/// longest, each name quoted with every quote doubled) keeps within it.
#[test]
fn parquet_cells_whose_text_might_pass_the_limit_are_read_from_their_text() -> Result<(), Box<dyn std::error::Error>> {
    let (name, bytes) = committed().swap_remove(0);
    let parquet = crate::io::parquet::csv_to_parquet(&bytes)?;
    let text = crate::io::parquet::to_csv_text(parquet.clone(), u64::MAX, "a per-cell file")?;
    let file = crate::io::parquet::open_columns(parquet.into(), u64::MAX).ok_or("opened by column")?;
    let read = |limit: u64| columns::from_columns_in(&file, 65_536, limit).is_some();
    assert!(read(u64::MAX), "{name}");
    assert!(read(text.len() as u64 * 4), "{name}: read within four times its text's length");
    assert!(!read(text.len() as u64), "{name}: at its text's length, the bound passes the limit");
    Ok(())
}

/// What the columns cannot give as the text's reader reads it goes to
/// that reader: a row it refuses (refused with the same words, line and
/// field), a name with a line break (read with a space) or a control
/// character, names that are numbers, a seed that is no integer.
#[test]
fn parquet_cells_the_columns_cannot_give_are_read_from_their_text() -> Result<(), Box<dyn std::error::Error>> {
    let (_, bytes) = committed().swap_remove(0);
    let text = String::from_utf8(bytes)?;
    let header: Vec<&str> = text.lines().next().ok_or("no header")?.split(',').collect();
    let at = |field: &str| header.iter().position(|h| *h == field).unwrap_or(usize::MAX);
    // Row 40 (line 41) with `field` set to `value`.
    let edit = |field: &str, value: &str| -> String {
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        let mut f: Vec<String> = lines[40].split(',').map(String::from).collect();
        f[at(field)] = value.to_string();
        lines[40] = f.join(",");
        lines.join("\n") + "\n"
    };
    let every = |field: &str, value: &dyn Fn(&str) -> String| -> String {
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        for line in lines.iter_mut().skip(1) {
            let mut f: Vec<String> = line.split(',').map(String::from).collect();
            f[at(field)] = value(&f[at(field)]);
            *line = f.join(",");
        }
        lines.join("\n") + "\n"
    };
    let cases = [
        (edit("fa_position_rmse_m", "-0.5"), false),
        (edit("fa_position_rmse_m", "1e-70"), false),
        (edit("fa_position_rmse_m", ""), false),
        (edit("n_divergent", "60"), false),
        (edit("n_starts", "0"), false),
        (edit("divergence_rate", "0.5"), false),
        (edit("horizon_s", "0"), false),
        (edit("conditional_position_rmse_m", ""), false),
        (edit("velocity_rmse_mps", ""), false),
        (edit("model", ""), false),
        (edit("model", "\"a\tb\""), false),
        (edit("seed", "1.5"), false),
        (edit("seed", "-1"), false),
        (edit("model", "\"two\nlines\""), true),
        (every("recording", &|r| r.bytes().map(|b| char::from(b'1' + b % 9)).collect()), true),
    ];
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("cells.parquet");
    let name = path.display().to_string();
    for (k, (edited, reads)) in cases.iter().enumerate() {
        let parquet = crate::io::parquet::csv_to_parquet(edited.as_bytes())?;
        let file = crate::io::parquet::open_columns(parquet.clone().into(), u64::MAX).ok_or("opened by column")?;
        assert!(columns::from_columns(&file, u64::MAX).is_none(), "case {k} is taken from the columns");
        let text = crate::io::parquet::to_csv_text(parquet.clone(), u64::MAX, "a per-cell file")?;
        let reference = read_cells_from(&name, text.as_slice());
        std::fs::write(&path, &parquet)?;
        // The same cells and errors, each line of the text named as the
        // file's row (line L is row L - 1).
        match (read_cells(&path), reference) {
            (Ok(cells), Ok(mut want)) if *reads => {
                want.iter_mut().for_each(|c| c.origin = c.origin.in_parquet());
                assert_eq!(cells, want, "case {k}");
                assert_eq!(cells[40].origin.to_string(), "row 41", "case {k}");
            }
            (Err(e), Err(want)) if !*reads => {
                assert_eq!(e.to_string(), want.in_parquet().to_string(), "case {k}");
                // A seed of 1.5 makes the column one of doubles, which
                // its first row's text ("100.0") already fails.
                let row = if k == 11 { "row 1," } else { "row 40," };
                assert!(e.to_string().contains(row) && !e.to_string().contains("line"), "case {k}: {e}");
            }
            (got, want) => panic!("case {k}: {got:?} against {want:?}"),
        }
    }
    Ok(())
}

/// A per-cell Parquet file of the types a CSV export never gives (32-bit
/// integers for the seed and the counts, floats for the errors, a
/// timestamp in milliseconds for the attitude error, nulls for empty
/// fields, as a file written with Arrow's types could hold them) is read
/// from its columns, and gives the cells its text gives.
#[test]
fn parquet_cells_of_32_bit_columns_floats_and_timestamps_are_their_texts_cells(
) -> Result<(), Box<dyn std::error::Error>> {
    use crate::io::parquet::typed::{typed, Typed};
    let (name, bytes) = committed().swap_remove(1);
    let mut reader = csv::Reader::from_reader(bytes.as_slice());
    let header: Vec<String> = reader.headers()?.iter().map(String::from).collect();
    let mut rows: Vec<csv::StringRecord> = reader.records().collect::<Result<_, _>>()?;
    // Nulls: a row where every start diverged (its conditional RMSE
    // empty), and no velocity in any row.
    let at = |field: &str| header.iter().position(|h| h == field).ok_or(format!("no {field}"));
    let (starts, divergent, rate) = (at("n_starts")?, at("n_divergent")?, at("divergence_rate")?);
    let (conditional, velocity) = (at("conditional_position_rmse_m")?, at("velocity_rmse_mps")?);
    for (k, row) in rows.iter_mut().enumerate() {
        let mut f: Vec<String> = row.iter().map(String::from).collect();
        if k == 40 {
            (f[divergent], f[rate], f[conditional]) = (f[starts].clone(), "1".into(), String::new());
        }
        f[velocity] = String::new();
        *row = csv::StringRecord::from(f);
    }
    let column = |c: usize| -> Result<Typed, Box<dyn std::error::Error>> {
        let fields = rows.iter().map(|r| Some(&r[c]).filter(|f| !f.is_empty()));
        Ok(match header[c].as_str() {
            "seed" | "n_starts" | "n_divergent" => {
                Typed::Int32(fields.map(|f| f.map(str::parse).transpose()).collect::<Result<_, _>>()?)
            }
            "attitude_rmse_deg" => Typed::Millis(
                fields
                    .map(|f| f.map(|f| f.parse::<f64>().map(|x| (x * 1e3).round() as i64)).transpose())
                    .collect::<Result<_, _>>()?,
            ),
            "horizon_s" | "divergence_rate" => {
                Typed::Double(fields.map(|f| f.map(str::parse).transpose()).collect::<Result<_, _>>()?)
            }
            h if h.ends_with("_m") || h.ends_with("_mps") => {
                Typed::Float(fields.map(|f| f.map(str::parse).transpose()).collect::<Result<_, _>>()?)
            }
            _ => Typed::Text(fields.map(|f| f.map(|f| f.as_bytes().to_vec())).collect()),
        })
    };
    let columns = (0..header.len())
        .map(|c| Ok((header[c].as_str(), column(c)?)))
        .collect::<Result<Vec<_>, Box<dyn std::error::Error>>>()?;
    let kinds = |k: fn(&Typed) -> bool| columns.iter().filter(|(_, c)| k(c)).count();
    assert_eq!(kinds(|c| matches!(c, Typed::Int32(_))), 3, "{name}");
    assert_eq!(kinds(|c| matches!(c, Typed::Float(_))), 3, "{name}");
    assert_eq!(kinds(|c| matches!(c, Typed::Millis(_))), 1, "{name}");
    let nulls = |c: usize| rows.iter().filter(|r| r[c].is_empty()).count();
    assert_eq!((nulls(conditional), nulls(velocity)), (1, rows.len()), "{name}");
    let parquet = typed(&columns);
    let text = crate::io::parquet::to_csv_text(parquet.clone(), u64::MAX, "a per-cell file")?;
    let reference = rows_of(read_cells_from(&name, text.as_slice())?);
    assert_eq!(reference.len(), rows.len());
    let file = crate::io::parquet::open_columns(parquet.into(), u64::MAX).ok_or("opened by column")?;
    for batch in [1, 7, 65_536] {
        let cells =
            columns::from_columns_in(&file, batch, u64::MAX).ok_or_else(|| format!("{name}: not read by column"))?;
        assert_eq!(format!("{cells:?}"), format!("{reference:?}"), "{name}, batch {batch}");
    }
    Ok(())
}

/// Damaged per-cell Parquet files: 2,000 copies of a small one (the first
/// 120 cells of a committed file), each with one to four bytes changed at
/// random (seeded), in its pages or its footer. Wherever the columns give
/// cells, the text gives the same ones; no copy makes either reader panic.
#[test]
fn damaged_parquet_cells_give_from_their_columns_what_their_text_gives() -> Result<(), Box<dyn std::error::Error>> {
    use crate::io::parquet::typed::damaged;
    use rand::SeedableRng;
    let (name, bytes) = committed().swap_remove(1);
    let text: String = String::from_utf8(bytes)?.lines().take(121).map(|l| format!("{l}\n")).collect();
    let raw = crate::io::parquet::csv_to_parquet_in(text.as_bytes(), 50)?;
    let read = |raw: &[u8]| {
        let file = crate::io::parquet::open_columns(raw.to_vec().into(), u64::MAX)?;
        columns::from_columns_in(&file, 7, u64::MAX)
    };
    let undamaged = read(&raw).ok_or("the undamaged file is read by column")?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(76);
    let (mut by_column, mut changed) = (0, 0);
    for _ in 0..2_000 {
        let bad = damaged(&raw, &mut rng);
        let text = crate::io::parquet::to_csv_text(bad.clone(), u64::MAX, "a per-cell file")
            .map_err(|e| e.to_string())
            .and_then(|t| read_cells_from(&name, t.as_slice()).map(rows_of).map_err(|e| e.to_string()));
        if let Some(cells) = read(&bad) {
            by_column += 1;
            // Debug, so that -0.0 and 0.0 differ.
            assert_eq!(Ok(format!("{cells:?}")), text.map(|c| format!("{c:?}")), "a damaged file read by column");
            changed += usize::from(cells != undamaged);
        }
    }
    assert!(by_column > 200 && changed > 20, "{by_column} read by column, {changed} of them changed");
    Ok(())
}

/// Cells read from a Parquet file's CSV text, placed as the file's rows
/// (line L of the text is row L - 1), as a reader of the file places them.
fn rows_of(mut cells: Vec<Cell>) -> Vec<Cell> {
    cells.iter_mut().for_each(|c| c.origin = c.origin.in_parquet());
    cells
}
