//! The column reader of a replications Parquet file against the reader of
//! its CSV text (`io::parquet::to_csv_text` and `simsum::from_text`): the
//! same replications, bit for bit, wherever it reads the file, and the
//! text read (with its error) wherever it does not.

use bytes::Bytes;

use super::super::rows::from_text;
use super::*;
use crate::io::parquet::typed::{typed, Typed};

const LIMIT: u64 = 1 << 30;

/// Columns named as flags name them: `--estimate est --se se --method
/// method`, the true value 0 and the level 0.95 unless `f` says otherwise.
fn flags(f: impl FnOnce(&mut Columns)) -> Columns {
    let mut c = Columns {
        estimate: "est".into(),
        se: "se".into(),
        method: "method".into(),
        rep: None,
        by: Vec::new(),
        truth: "0".into(),
        level: "0.95".into(),
        ci: None,
        df: None,
        reference: None,
        targets: Vec::new(),
    };
    f(&mut c);
    c
}

/// A replication's values as bits, so that NaN equals NaN and -0 is not 0.
fn bits(r: &Replication) -> String {
    let b = |x: f64| x.to_bits();
    format!(
        "{:?} {:?} {:?} {} {} {:?} {:?} {} {}",
        r.by,
        r.method,
        r.rep,
        b(r.estimate),
        b(r.se),
        r.limits.map(|(l, u)| (b(l), b(u))),
        r.df.map(b),
        b(r.truth),
        b(r.level)
    )
}

/// What the text of `raw` gives: its replications and notes as bits, or
/// its error's words.
fn by_text(raw: &[u8], cols: &Columns) -> Result<(Vec<String>, Vec<String>), String> {
    let text = crate::io::parquet::to_csv_text(raw.to_vec(), LIMIT, "a replications file")?;
    let text = String::from_utf8(text).map_err(|e| e.to_string())?;
    let at =
        |line: usize, column: usize, message: String| SimsumFileError::At { path: "f".into(), line, column, message };
    let (reps, notes) = from_text(&text, cols, &at).map_err(|e| e.to_string())?;
    Ok((reps.iter().map(bits).collect(), notes))
}

/// What the columns of `raw` give, `batch` rows at a time.
fn by_columns(raw: &[u8], cols: &Columns, limit: u64, batch: usize) -> Option<(Vec<String>, Vec<String>)> {
    from_columns_in(Bytes::from(raw.to_vec()), cols, limit, batch)
        .map(|(reps, notes)| (reps.iter().map(bits).collect(), notes))
}

/// The column reader reads `raw` and gives what its text gives, at every
/// batch size.
fn same(raw: &[u8], cols: &Columns, what: &str) {
    let text = by_text(raw, cols).unwrap_or_else(|e| panic!("{what}: the text is refused: {e}"));
    for batch in [1, 2, 7, BATCH] {
        let columns = by_columns(raw, cols, LIMIT, batch).unwrap_or_else(|| panic!("{what}: not read by column"));
        assert_eq!(columns, text, "{what}, batches of {batch}");
    }
}

/// The committed replications (rsimsum's reference study, 17,600 rows:
/// names with spaces and dots, `NA`s, limits and df) as Parquet in one row
/// group and in several (read 7 rows or 65,536 at a time), under the
/// flags its tests use and others.
#[test]
fn the_committed_replications_read_by_column_as_by_their_text() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read(root.join("results/coverage_rsimsum/replications.csv")).expect("committed file");
    let own = flags(|c| {
        (c.estimate, c.by, c.truth, c.level) =
            ("estimate".into(), vec!["setting".into(), "true_mean".into()], "true_mean".into(), "level".into());
        (c.rep, c.ci, c.df) = (Some("rep".into()), Some(("ci_lower".into(), "ci_upper".into())), Some("df".into()));
    });
    let plain = flags(|c| (c.estimate, c.by) = ("estimate".into(), vec!["setting".into()]));
    let mut read = 0;
    for rows in [usize::MAX, 5_000, 17] {
        let raw = crate::io::parquet::csv_to_parquet_in(&text, rows).expect("written");
        for (cols, what) in [(&own, "every column read"), (&plain, "estimate and SE only")] {
            let (reps, notes) = by_text(&raw, cols).expect("read");
            assert_eq!(reps.len(), 17_600);
            for batch in [7, BATCH] {
                let columns = by_columns(&raw, cols, LIMIT, batch);
                assert_eq!(columns, Some((reps.clone(), notes.clone())), "{what}, groups of {rows}, batch {batch}");
                read += 1;
            }
            // The notes name the columns the plain flags leave unread.
            assert_eq!(notes.is_empty(), cols.rep.is_some(), "{what}");
        }
    }
    assert_eq!(read, 12);
}

/// Fields the text writes specially: missing values of every spelling,
/// values with a comma, quotes, spaces around them or a line break,
/// numbers in a column of text, infinite df, an integer replication id, a
/// negative zero, a column read both as a by-factor and as the true value.
#[test]
fn fields_written_specially_are_read_as_their_text_reads_them() {
    let csv = "method,rep,by,est,se,df,lo,hi,truth,level\n\
        \"a, b\",1,x,0.5,0.1,inf,0.3,0.7,0.4,0.9\n\
        \" quoted \"\"q\"\" \",1,\"two\nlines\",NA,,NaN,,,0.4,0.9\n\
        c,2, y ,-0.0,1e-7,3,-1,1,-0.0,0.95\n\
        \"a, b\",2,x,nan,0.2,12,0.1,0.2,0.4,0.8\n";
    let cols = flags(|c| {
        (c.rep, c.by, c.df) = (Some("rep".into()), vec!["by".into(), "truth".into()], Some("df".into()));
        (c.ci, c.truth, c.level) = (Some(("lo".into(), "hi".into())), "truth".into(), "level".into());
    });
    let raw = crate::io::parquet::csv_to_parquet(csv.as_bytes()).expect("written");
    same(&raw, &cols, "special fields");
    let (reps, _) = by_columns(&raw, &cols, LIMIT, BATCH).expect("read");
    assert!(reps[1].contains("[\"two lines\", \"0.4\"]"), "a line break read as a space: {}", reps[1]);
    // The replication ids as text too (`est` is already a column of
    // text, for its `NA`).
    let texts = csv.replace("\",1,", "\",r1,").replace("\",2,", "\",r2,").replace("c,2,", "c,r2,");
    assert_eq!(texts.matches(",r1,").count() + texts.matches(",r2,").count(), 4);
    let raw = crate::io::parquet::csv_to_parquet(texts.as_bytes()).expect("written");
    same(&raw, &cols, "replication ids as text");
}

/// Column names the text writes specially, as its reader reads them
/// back: with a comma or a quote (quoted), spaces around them (trimmed),
/// a line break (a space), and a name given twice (the first read).
#[test]
fn names_written_specially_are_read_as_their_text_reads_them() {
    let csv = "\"me\"\"thod\",\"e,st\", se ,\"by\nx\",se\na,0.5,0.1,p,9\nb,0.4,0.2,q,9\n";
    let cols = flags(|c| {
        (c.method, c.estimate, c.by) = ("me\"thod".into(), "e,st".into(), vec!["by x".into()]);
    });
    let raw = crate::io::parquet::csv_to_parquet(csv.as_bytes()).expect("written");
    same(&raw, &cols, "special names");
    let (reps, _) = by_columns(&raw, &cols, LIMIT, BATCH).expect("read");
    // The first `se` (0.1), trimmed, not the second (9).
    assert!(reps[0].contains(&format!(" {} ", 0.1f64.to_bits())), "{}", reps[0]);
}

/// A NaN of any sign or payload in a column of doubles is the NaN its
/// text `NaN` reads as, bit for bit (numpy's 0/0 has its sign bit set).
#[test]
fn every_nan_is_the_nan_its_text_reads_as() {
    let nans = [f64::from_bits(0xfff8_0000_0000_0000), f64::from_bits(0x7ff8_0000_0000_0001), f64::NAN];
    let raw = typed(&[
        ("method", Typed::Text(vec![Some(b"a".to_vec()); 3])),
        ("est", Typed::Double(nans.iter().copied().map(Some).collect())),
        ("se", Typed::Double(vec![Some(0.1); 3])),
    ]);
    same(&raw, &flags(|_| {}), "NaNs");
    let (reps, _) = by_columns(&raw, &flags(|_| {}), LIMIT, BATCH).expect("read");
    assert!(reps.iter().all(|r| r.contains(&format!(" {} ", f64::NAN.to_bits()))), "{reps:?}");
}

/// Columns of the types a CSV export never gives (32-bit integers and
/// floats, timestamps, booleans), with nulls, read as their text reads
/// them: a float as the number its shortest text writes, a timestamp in
/// seconds, a boolean's `true` as a by-factor.
#[test]
fn typed_columns_with_nulls_read_as_their_text_reads_them() {
    let cols = flags(|c| {
        (c.rep, c.by, c.df) = (Some("rep".into()), vec!["when".into(), "flag".into()], Some("df".into()));
        c.truth = "truth".into();
    });
    let raw = typed(&[
        (
            "method",
            Typed::Text(vec![Some(b"a".to_vec()), Some(b"b".to_vec()), Some(b"a".to_vec()), Some(b"b".to_vec())]),
        ),
        ("rep", Typed::Int32(vec![Some(1), Some(1), Some(-2_147_483_648), Some(-2_147_483_648)])),
        ("when", Typed::Millis(vec![Some(1_700_000_000_123), None, Some(-1), Some(1_700_000_000_123)])),
        ("flag", Typed::Bool(vec![Some(true), Some(false), None, Some(true)])),
        ("est", Typed::Float(vec![Some(0.1), None, Some(f32::NAN), Some(171_404.62)])),
        ("se", Typed::Float(vec![Some(0.3), Some(1e-6), Some(2.5), Some(3.0e-5)])),
        ("truth", Typed::Float(vec![Some(0.1), Some(0.2), Some(-0.0), Some(1e12)])),
        ("df", Typed::Int32(vec![Some(4), None, Some(30), Some(7)])),
    ]);
    same(&raw, &cols, "typed columns");
    let (reps, _) = by_columns(&raw, &cols, LIMIT, BATCH).expect("read");
    // The float 0.1 is the double its text "0.1" reads as, not the
    // float's own value widened.
    assert!(reps[0].contains(&format!(" {} ", 0.1f64.to_bits())), "{}", reps[0]);
    assert!(reps[0].contains("[\"1700000000.123\", \"true\"]"), "{}", reps[0]);
}

/// Rows and files the column reader gives to the text (which refuses
/// each, or reads it otherwise); a refused file gives, from its Parquet,
/// the error its CSV gives, line and column included.
#[test]
fn what_the_columns_cannot_give_goes_to_the_text() {
    let good = "method,est,se\na,0.5,0.1\nb,0.4,0.2\n";
    let cols = flags(|_| {});
    let raw = crate::io::parquet::csv_to_parquet(good.as_bytes()).expect("written");
    same(&raw, &cols, "the good file");
    let refused = [
        ("a row's SE negative", "method,est,se\na,0.5,0.1\nb,0.4,-0.2\n"),
        ("an estimate no number", "method,est,se\na,0.5,0.1\nb,x,0.2\n"),
        ("an estimate infinite", "method,est,se\na,inf,0.1\nb,0.4,0.2\n"),
        ("an estimate past 1e75", "method,est,se\na,1e80,0.1\nb,0.4,0.2\n"),
        ("an empty method", "method,est,se\na,0.5,0.1\n,0.4,0.2\n"),
        ("no column named", "method,estimate,se\na,0.5,0.1\n"),
        ("a header and no rows", "method,est,se\n"),
    ];
    for (what, csv) in refused {
        let raw = crate::io::parquet::csv_to_parquet(csv.as_bytes()).expect("written");
        assert_eq!(by_columns(&raw, &cols, LIMIT, BATCH), None, "{what}");
        assert!(by_text(&raw, &cols).is_err(), "{what}: the text refuses it too");
        let dir = tempfile::tempdir().expect("scratch folder");
        let (parquet, twin) = (dir.path().join("f.parquet"), dir.path().join("f.csv"));
        std::fs::write(&parquet, &raw).expect("written");
        std::fs::write(&twin, csv).expect("written");
        let error = |p: &std::path::Path| super::super::read(p, &cols).err().map(|e| e.to_string());
        let (a, b) = (error(&parquet).expect("refused"), error(&twin).expect("refused"));
        assert_eq!(a.replace("f.parquet", "f.csv"), b, "{what}");
    }
    // Read otherwise by the text: a first name beginning with a
    // byte-order mark (removed from the text), a single column (whose
    // empty fields are blank lines), text that is not UTF-8.
    let bom =
        typed(&[("\u{feff}method", Typed::Text(vec![Some(b"a".to_vec())])), ("est", Typed::Int32(vec![Some(1)]))]);
    let bom_flags = flags(|c| (c.method, c.se) = ("\u{feff}method".into(), "est".into()));
    assert_eq!(by_columns(&bom, &bom_flags, LIMIT, BATCH), None, "a byte-order mark");
    assert!(by_text(&bom, &bom_flags).is_err(), "the text has no name with a byte-order mark");
    let one = crate::io::parquet::csv_to_parquet(b"est\n1\n2\n").expect("written");
    let one_flags = flags(|c| (c.method, c.se) = ("est".into(), "est".into()));
    assert_eq!(by_columns(&one, &one_flags, LIMIT, BATCH), None, "one column");
    assert!(by_text(&one, &one_flags).is_ok(), "one column: read by its text");
    for unread in [false, true] {
        let bad = typed(&[
            ("method", Typed::Text(vec![Some(b"a".to_vec())])),
            ("est", Typed::Int32(vec![Some(1)])),
            (if unread { "note" } else { "se" }, Typed::Text(vec![Some(b"0.5\xff".to_vec())])),
        ]);
        let cols = flags(|c| c.se = if unread { "est".into() } else { "se".into() });
        assert_eq!(by_columns(&bad, &cols, LIMIT, BATCH), None, "not UTF-8, unread: {unread}");
    }
    // A file whose text could pass the limit is read as text, which
    // refuses it.
    assert_eq!(by_columns(&raw, &cols, 20, BATCH), None, "the limit");
    assert!(by_columns(&raw, &cols, 200, BATCH).is_some(), "within the limit");
}

/// Damaged files: 3,000 copies of a small file, each with one to four
/// bytes changed at random (seeded), in its pages or its footer.
/// Wherever the columns give replications, the text gives the same ones
/// (a damaged page the decoder reads without a word is read the same
/// way by both); wherever they do not, the text reads the file or
/// refuses it. No copy makes either reader panic.
#[test]
fn damaged_files_give_from_their_columns_what_their_text_gives() {
    use crate::io::parquet::typed::damaged;
    use rand::SeedableRng;
    let mut csv = String::from("method,rep,by,est,se\n");
    for k in 0..60u32 {
        let est = if k % 7 == 3 { "NA".to_string() } else { format!("{}", 0.01 * f64::from(k) - 0.2) };
        csv += &format!("m{},{},{},{est},{}\n", k % 3, k / 3, ["x", "y y"][k as usize % 2], 0.1 + 0.001 * f64::from(k));
    }
    let raw = crate::io::parquet::csv_to_parquet_in(csv.as_bytes(), 25).expect("written");
    let cols = flags(|c| (c.rep, c.by) = (Some("rep".into()), vec!["by".into()]));
    same(&raw, &cols, "the undamaged file");
    let undamaged = by_columns(&raw, &cols, LIMIT, 7);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(76);
    let (mut by_column, mut changed) = (0, 0);
    for _ in 0..3_000 {
        let bad = damaged(&raw, &mut rng);
        let text = by_text(&bad, &cols);
        if let Some(columns) = by_columns(&bad, &cols, LIMIT, 7) {
            by_column += 1;
            assert_eq!(Ok(&columns), text.as_ref(), "a damaged file read by column");
            changed += usize::from(Some(&columns) != undamaged.as_ref());
        }
    }
    // Most damage refuses the file or goes to the text; enough is read
    // by column, with values the damage changed, for the comparison to
    // mean something.
    assert!(by_column > 300 && changed > 50, "{by_column} read by column, {changed} of them changed");
}
