//! A real lab's logs as they come (issue 57): quaternions off unit length,
//! and the rest of what a lab's folder holds. The logs are the committed
//! NanoBench fixtures rewritten in another lab's layout (`logs::rewrite`).

use std::path::Path;

use crate::logs::{reordered_design, rewrite, spec};
use crossaudit::data::{self, load_recording, Layout, LogError};

const XYZW: &str = "quaternion xyzw qx, qy, qz, qw";

/// The rewritten logs' design with `attitude`, every flying row active
/// (the fixture flies at m1 = 1000).
fn design(dir: &Path, attitude: &str) -> crossaudit::design::DataSpec {
    spec(&reordered_design(dir, attitude).replace("active(m1 > 1000)", "active(m1 >= 1000)"))
}

/// Loads `path`, or gives the error (never a recording's Debug dump).
fn load(path: &Path, spec: &crossaudit::design::DataSpec) -> Result<crossaudit::data::Recording, LogError> {
    load_recording(path, &Layout::new(spec).unwrap())
}

/// The quaternion columns of a rewritten log multiplied by `factor` on
/// every row, as an estimator that does not renormalise logs them.
fn scale_quaternion(path: &Path, factor: f64) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let header: Vec<String> = lines[0].split(',').map(String::from).collect();
    let q: Vec<usize> = ["qx", "qy", "qz", "qw"].iter().map(|n| header.iter().position(|h| h == n).unwrap()).collect();
    for line in lines.iter_mut().skip(1) {
        let mut f: Vec<String> = line.split(',').map(String::from).collect();
        for &c in &q {
            f[c] = format!("{:.17e}", f[c].parse::<f64>().unwrap() * factor);
        }
        *line = f.join(",");
    }
    std::fs::write(path, lines.join("\n") + "\n").unwrap();
}

/// Issue 57, item 2: a logged quaternion 1.4% long is refused with the
/// file's largest deviation and the clause that accepts it; with `norm
/// within 0.02` the file loads, every quaternion has unit length, and the
/// audit reports the largest deviation it renormalised.
#[test]
fn a_quaternion_off_unit_length_is_accepted_only_as_declared_and_renormalised() {
    let tmp = tempfile::tempdir().unwrap();
    let name = "F3_oval_medium_rep1.csv";
    let plain_dir = tmp.path().join("plain");
    let long_dir = tmp.path().join("long");
    std::fs::create_dir_all(&plain_dir).unwrap();
    std::fs::create_dir_all(&long_dir).unwrap();
    let plain = rewrite(name, &plain_dir);
    let long = rewrite(name, &long_dir);
    scale_quaternion(&long, 1.014);

    // As logged: refused at the first active row, with the fix in words.
    let Err(e) = load(&long, &design(&long_dir, XYZW)) else { panic!("1.4% off unit length accepted") };
    let LogError::NotUnit { line, norm, largest, declared: false, .. } = &e else { panic!("{e:?}") };
    assert!(*line > 1 && (norm - 1.0).abs() > 0.01, "{e:?}");
    let text = e.to_string();
    assert!(text.contains("norm within 0.02") && text.contains(&format!("{largest:.4}")), "{text}");

    // A declared tolerance smaller than the deviation names itself.
    let Err(e) = load(&long, &design(&long_dir, &format!("{XYZW} norm within 0.01"))) else {
        panic!("beyond the declared tolerance accepted")
    };
    assert!(e.to_string().contains("the declared `norm within 0.01`"), "{e}");

    // Declared: loaded, renormalised to unit length; the deviation is the
    // file's own, computed here from the file's columns.
    let lenient = design(&long_dir, &format!("{XYZW} norm within 0.02"));
    let rec = load(&long, &lenient).unwrap_or_else(|e| panic!("{e}"));
    let q = rec.slots.quaternion_slots().unwrap();
    for s in &rec.state {
        let n = s[q.clone()].iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!((n - 1.0).abs() < 1e-12, "length {n} after renormalisation");
    }
    let base = load(&plain, &design(&plain_dir, XYZW)).unwrap_or_else(|e| panic!("{e}"));
    assert!(base.active_rows() > 100);
    let checked = base.tail.map_or(base.rows, |t| t.start);
    let expected = (0..checked)
        .filter(|&k| base.active[k])
        .map(|k| (1.014 * base.state[k][q.clone()].iter().map(|v| v * v).sum::<f64>().sqrt() - 1.0).abs())
        .fold(0.0, f64::max);
    let got = rec.quaternion_deviation.unwrap();
    assert!((got - expected).abs() < 1e-9 && got > 0.01, "{got} vs {expected}");
    // Renormalising the long quaternion gives the plain one's direction.
    for (a, b) in rec.state.iter().zip(&base.state) {
        let nb = b[q.clone()].iter().map(|v| v * v).sum::<f64>().sqrt();
        for (x, y) in a[q.clone()].iter().zip(&b[q.clone()]) {
            assert!((x - y / nb).abs() < 1e-12);
        }
    }
    // Only the quaternion changed.
    for (a, b) in rec.state.iter().zip(&base.state) {
        assert!(a[..q.start] == b[..q.start] && a[q.end..] == b[q.end..]);
    }

    // The audit: a column with each file's deviation, and the summary's line.
    let audit = data::audit(&lenient, &long_dir).unwrap();
    let csv = audit.to_csv();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let at = header.iter().position(|h| *h == "quaternion_max_deviation").expect("the column");
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(row[at].parse::<f64>().unwrap(), got);
    assert!(audit
        .summary()
        .contains(&format!("`norm within 0.02`): largest deviation from 1 among included recordings {got:.4}")));
    // Without the clause, no new column: every other audit is unchanged.
    let before = data::audit(&design(&plain_dir, XYZW), &plain_dir).unwrap().to_csv();
    assert!(!before.contains("quaternion_max_deviation"));
}

/// `norm within` is refused on Euler angles (they have no length) and
/// outside (0, 0.5], at its place.
#[test]
fn a_norm_tolerance_that_cannot_apply_is_refused_by_check() {
    let tmp = tempfile::tempdir().unwrap();
    for (attitude, needle) in [
        ("euler degrees roll_deg, pitch_deg, yaw_deg norm within 0.02", "norm tolerance on Euler angles"),
        (&format!("{XYZW} norm within 0.7") as &str, "bad norm tolerance"),
        (&format!("{XYZW} norm within 0") as &str, "bad norm tolerance"),
    ] {
        let design = reordered_design(tmp.path(), attitude);
        let e = crossaudit::design::from_str("study.design", &design).expect_err(attitude);
        let text = e.to_string();
        assert!(text.contains(needle) && text.contains("norm within"), "{text}");
        assert!(text.contains("study.design:8:"), "located at the attitude line: {text}");
    }
}

/// One column of a Parquet file written by [`write_parquet`].
pub(crate) enum Column {
    /// Doubles; `None` is a missing value.
    Double(Vec<Option<f64>>),
    /// Float32 values.
    Float(Vec<f32>),
    /// UTF-8 text.
    Text(Vec<String>),
    /// Nanoseconds since the epoch, as a Parquet timestamp.
    TimestampNanos(Vec<i64>),
    /// Days since 1970-01-01, as a Parquet date.
    Date(Vec<i32>),
    /// Microseconds since midnight, as a Parquet time of day.
    TimeMicros(Vec<i64>),
}

/// Writes `columns` as a Parquet file (snappy, one row group), with
/// parquet's own writer: the way a lab's pandas or polars export looks.
pub(crate) fn write_parquet(path: &Path, columns: &[(&str, Column)]) {
    use parquet::basic::{Compression, LogicalType, Repetition, TimeUnit, Type as Physical};
    use parquet::column::writer::ColumnWriter;
    use parquet::data_type::ByteArray;
    use parquet::file::properties::WriterProperties;
    use parquet::file::writer::SerializedFileWriter;
    use parquet::schema::types::Type;
    use std::sync::Arc;
    let fields = columns
        .iter()
        .map(|(name, c)| {
            let (physical, logical, repetition) = match c {
                Column::Double(_) => (Physical::DOUBLE, None, Repetition::OPTIONAL),
                Column::Float(_) => (Physical::FLOAT, None, Repetition::REQUIRED),
                Column::Text(_) => (Physical::BYTE_ARRAY, Some(LogicalType::String), Repetition::REQUIRED),
                Column::TimestampNanos(_) => {
                    (Physical::INT64, Some(LogicalType::timestamp(true, TimeUnit::NANOS)), Repetition::REQUIRED)
                }
                Column::Date(_) => (Physical::INT32, Some(LogicalType::Date), Repetition::REQUIRED),
                Column::TimeMicros(_) => {
                    (Physical::INT64, Some(LogicalType::time(true, TimeUnit::MICROS)), Repetition::REQUIRED)
                }
            };
            Arc::new(
                Type::primitive_type_builder(name, physical)
                    .with_logical_type(logical)
                    .with_repetition(repetition)
                    .build()
                    .unwrap(),
            )
        })
        .collect();
    let schema = Arc::new(Type::group_type_builder("log").with_fields(fields).build().unwrap());
    let props = Arc::new(WriterProperties::builder().set_compression(Compression::SNAPPY).build());
    let mut writer = SerializedFileWriter::new(std::fs::File::create(path).unwrap(), schema, props).unwrap();
    let mut group = writer.next_row_group().unwrap();
    let mut k = 0;
    while let Some(mut col) = group.next_column().unwrap() {
        match (col.untyped(), &columns[k].1) {
            (ColumnWriter::DoubleColumnWriter(w), Column::Double(v)) => {
                let present: Vec<f64> = v.iter().flatten().copied().collect();
                let levels: Vec<i16> = v.iter().map(|x| i16::from(x.is_some())).collect();
                w.write_batch(&present, Some(&levels), None).unwrap();
            }
            (ColumnWriter::FloatColumnWriter(w), Column::Float(v)) => {
                w.write_batch(v, None, None).unwrap();
            }
            (ColumnWriter::ByteArrayColumnWriter(w), Column::Text(v)) => {
                let v: Vec<ByteArray> = v.iter().map(|s| ByteArray::from(s.as_str())).collect();
                w.write_batch(&v, None, None).unwrap();
            }
            (ColumnWriter::Int64ColumnWriter(w), Column::TimestampNanos(v) | Column::TimeMicros(v)) => {
                w.write_batch(v, None, None).unwrap();
            }
            (ColumnWriter::Int32ColumnWriter(w), Column::Date(v)) => {
                w.write_batch(v, None, None).unwrap();
            }
            _ => panic!("column {k}: writer and values disagree"),
        }
        col.close().unwrap();
        k += 1;
    }
    group.close().unwrap();
    writer.close().unwrap();
}

/// A CSV log's columns as doubles (every field numeric).
fn numeric_columns(text: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let mut cols = vec![Vec::new(); header.len()];
    for line in lines.filter(|l| !l.is_empty()) {
        for (c, f) in line.split(',').enumerate() {
            cols[c].push(f.parse::<f64>().unwrap());
        }
    }
    (header, cols)
}

/// Item 1's must-show: each NanoBench fixture log as Parquet and as the
/// CSV text of the same values give byte-identical audits (but for the
/// file name's extension), splits and per-cell results through the real
/// binary, with no conversion script.
#[test]
fn a_parquet_log_and_the_same_log_as_csv_give_identical_audits_splits_and_cells() {
    let tmp = tempfile::tempdir().unwrap();
    let fixtures = crate::common::root().join("tests/fixtures/nanobench");
    let (pq, csv) = (tmp.path().join("parquet"), tmp.path().join("csv"));
    std::fs::create_dir_all(&pq).unwrap();
    std::fs::create_dir_all(&csv).unwrap();
    let mut converted = 0;
    for entry in std::fs::read_dir(&fixtures).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.ends_with("_metadata.yaml") {
            std::fs::copy(&path, pq.join(&name)).unwrap();
            std::fs::copy(&path, csv.join(&name)).unwrap();
            continue;
        }
        let bytes = crossaudit::data::log::read_bytes(&path).unwrap();
        let (header, cols) = numeric_columns(&String::from_utf8(bytes).unwrap());
        let stem = crossaudit::data::recording_name(&path);
        let columns: Vec<(&str, Column)> = header
            .iter()
            .zip(&cols)
            .map(|(h, c)| (h.as_str(), Column::Double(c.iter().map(|v| Some(*v)).collect())))
            .collect();
        write_parquet(&pq.join(format!("{stem}.parquet")), &columns);
        // The same values as CSV text: Rust's shortest round-trip form.
        let mut text = header.join(",") + "\n";
        for k in 0..cols[0].len() {
            text += &(cols.iter().map(|c| format!("{:?}", c[k])).collect::<Vec<_>>().join(",") + "\n");
        }
        std::fs::write(csv.join(format!("{stem}.csv")), text).unwrap();
        converted += 1;
    }
    assert!(converted >= 5);
    let design = crate::common::root().join("tests/designs/logs_generic.design");
    let run = |data: &Path, out: &str| {
        let o = crate::common::bin()
            .arg("run")
            .arg(&design)
            .arg("--data")
            .arg(data)
            .args(["--exploratory", "--workers", "2", "--out"])
            .arg(tmp.path().join(out))
            .output()
            .unwrap();
        crate::common::assert_ok(&o);
        tmp.path().join(out)
    };
    let (a, b) = (run(&pq, "from_parquet"), run(&csv, "from_csv"));
    let mut compared = 0;
    for f in crate::logs::files(&a) {
        let name = f.to_string_lossy().into_owned();
        let same_bits = name.starts_with("audit/")
            || name.starts_with("cells")
            || name.ends_with(".safetensors")
            || (name.starts_with("manifests/") && name.ends_with(".csv"))
            || name == "report/estimates.csv";
        if !same_bits {
            continue;
        }
        let (x, y) = (std::fs::read(a.join(&f)).unwrap(), std::fs::read(b.join(&f)).unwrap());
        // The audit names each file: only its extension may differ.
        let x = match name.starts_with("audit/") {
            true => String::from_utf8(x).unwrap().replace(".parquet", ".csv").into_bytes(),
            false => x,
        };
        assert!(x == y, "{name} differs between the Parquet and the CSV logs");
        compared += 1;
    }
    assert!(compared >= 15, "only {compared} files compared");
    let recordings = std::fs::read_to_string(a.join("audit/recordings.csv")).unwrap();
    assert!(recordings.contains(".parquet,") && recordings.lines().filter(|l| l.contains(",included,")).count() >= 4);
}

/// Parquet's types as a lab writes them: a float32 column, a timestamp in
/// nanoseconds read as seconds, text and missing values in undeclared
/// columns that never refuse the file; a NaN or a missing value in a
/// declared column refused at its row and column.
#[test]
fn parquet_types_missing_values_and_nan_are_read_as_declared() {
    let tmp = tempfile::tempdir().unwrap();
    let n = 300;
    let t0: i64 = 1_772_723_827_000_000_000;
    let design = |dir: &Path| {
        format!(
            r#"study "types"
data csv {{
  path "{}"
  rate 100 Hz
  time stamp
  position x, y, z
  action m1 scale 1
  include active(m1 > 0.5) >= 20 samples
}}
factor recording {{ evaluation 2 split_seed 3; starts 3 horizon 20 }}
factor seed = 1..2
validation 60 windows from 1 recordings seed 5
arm disjoint {{ fit 100 windows seed 1 }}
arm contaminated {{ from disjoint replace 25% with evaluation windows exclude starts seed 2 }}
train {{ adam lr 1e-3 batch 64 epochs 2 cosine patience 2 action_noise 0 }}
model world = mlp(32, 32) inputs world
endpoint primary fa_position_rmse at 0.1 s cap 2 m model world
contrast contaminated - disjoint
estimate crossed_mom level 0.95 df seed - 1
decide confirmed when optimism >= 10% and upper < 0
"#,
            dir.display()
        )
    };
    let columns = |x_at_40: Option<f64>| -> Vec<(&'static str, Column)> {
        let mut x: Vec<Option<f64>> = (0..n).map(|k| Some(k as f64 * 0.01)).collect();
        x[40] = x_at_40;
        vec![
            ("stamp", Column::TimestampNanos((0..n).map(|k| t0 + k as i64 * 10_000_000).collect())),
            ("x", Column::Double(x)),
            ("y", Column::Float((0..n).map(|k| 0.1 + k as f32 * 0.001).collect())),
            ("z", Column::Double(vec![Some(1.0); n])),
            ("m1", Column::Double(vec![Some(0.7); n])),
            (
                "mode",
                Column::Text((0..n).map(|k| if k % 2 == 0 { "hover, ok" } else { "say \"go\"" }.to_string()).collect()),
            ),
            ("mocap_qw", Column::Double(vec![Some(f64::NAN); n])),
            ("battery", Column::Double((0..n).map(|k| (k % 7 != 0).then_some(4.0)).collect())),
        ]
    };
    let path = tmp.path().join("run_1.parquet");
    write_parquet(&path, &columns(Some(0.4)));
    let spec = spec(&design(tmp.path()));
    let rec = load(&path, &spec).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(rec.rows, n);
    assert!((rec.t[1] - rec.t[0] - 0.01).abs() < 1e-6 && (rec.t[0] - 1_772_723_827.0).abs() < 1e-3, "seconds");
    // The float32 column keeps its own shortest text: 0.1f32 reads as 0.1.
    assert_eq!(rec.state[0][1], 0.1);
    assert_eq!(rec.state[40][0], 0.4);
    for (bad, shown) in [(Some(f64::NAN), "NaN"), (None, "the field is empty")] {
        write_parquet(&path, &columns(bad));
        let Err(e) = load(&path, &spec) else { panic!("{shown} in a declared column accepted") };
        let text = e.to_string();
        // Row 41 of the file (0-based 40) is line 42 of its text.
        assert!(text.contains("line 42") && text.contains("column `x`") && text.contains(shown), "{text}");
    }
    // Not a Parquet file at all.
    std::fs::write(&path, b"PAR1 but not really").unwrap();
    let Err(e) = load(&path, &spec) else { panic!("a broken Parquet file accepted") };
    assert!(e.to_string().contains("run_1.parquet: not a readable Parquet file"), "{e}");
}

/// Item 1 and 6: a lab's folder as published, `train/` and `test/`, read
/// with `folders nested` and pinned with `split published folders`: the
/// audit shows each file's path, the test folder is the evaluation set,
/// validation is drawn from train, and moving a file between folders
/// makes the lock stale.
#[test]
fn a_lab_folder_of_train_and_test_is_read_and_split_by_its_folders() {
    let tmp = tempfile::tempdir().unwrap();
    let lab = tmp.path().join("lab");
    let fixtures = crate::common::root().join("tests/fixtures/nanobench");
    // Distinct recordings: the fixtures, and copies of two with the
    // position shifted by 1 mm (identical copies would be leaks).
    let place = [
        ("F1_circle_slow_rep1.csv", "train"),
        ("F2_star_fast_mell_rep1.csv", "train"),
        ("F2_star_fast_mell_rep2.csv", "train"),
        ("F4_linear_ramp_rep1.csv", "test"),
        ("F4_linear_ramp_rep2.csv", "test"),
    ];
    for (file, folder) in place {
        std::fs::create_dir_all(lab.join(folder)).unwrap();
        let from = fixtures.join(file.replace("_rep2", "_rep1"));
        let text = std::fs::read_to_string(&from).unwrap();
        let text = if file.contains("_rep2") { shift_px(&text) } else { text };
        std::fs::write(lab.join(folder).join(file), text).unwrap();
    }
    let text = std::fs::read_to_string(crate::common::root().join("tests/designs/logs_generic.design"))
        .unwrap()
        .replace("path \"../fixtures/nanobench\"", &format!("path {:?}\n  folders nested", lab.display().to_string()))
        .replace(
            "factor recording { evaluation 2 split_seed 3;",
            "split published folders { evaluation test; fit train }\nfactor recording { split_seed 3;",
        );
    let design = tmp.path().join("lab.design");
    std::fs::write(&design, &text).unwrap();
    let bin = |args: &[&str]| crate::common::bin().args(args).output().unwrap();
    let d = design.to_str().unwrap();
    crate::common::assert_ok(&bin(&["lock", d]));
    let out = tmp.path().join("run");
    crate::common::assert_ok(&bin(&["run", d, "--out", out.to_str().unwrap(), "--workers", "2"]));
    let audit = std::fs::read_to_string(out.join("audit/recordings.csv")).unwrap();
    for (file, folder) in place {
        assert!(audit.contains(&format!(",{folder}/{file},")), "{file} in {folder}/:\n{audit}");
    }
    let cells = std::fs::read_to_string(out.join("cells.csv")).unwrap();
    let evaluated: std::collections::BTreeSet<&str> =
        cells.lines().skip(1).filter_map(|l| l.split(',').nth(3)).collect();
    assert_eq!(evaluated.into_iter().collect::<Vec<_>>(), ["F4_linear_ramp_rep1", "F4_linear_ramp_rep2"]);
    let validation = std::fs::read_to_string(out.join("manifests/validation_recordings.csv"))
        .or_else(|_| std::fs::read_to_string(out.join("manifests/validation.csv")))
        .unwrap();
    assert!(
        ["F1_circle_slow_rep1", "F2_star_fast_mell_rep1", "F2_star_fast_mell_rep2"]
            .iter()
            .any(|n| validation.contains(n)),
        "validation from train:\n{validation}"
    );
    assert!(!validation.contains("F4_linear"));
    // The split is in the lock: a file moved from train to test is refused.
    std::fs::rename(lab.join("train/F2_star_fast_mell_rep2.csv"), lab.join("test/F2_star_fast_mell_rep2.csv")).unwrap();
    let again = tmp.path().join("again");
    let o = bin(&["run", d, "--out", again.to_str().unwrap(), "--workers", "2"]);
    assert!(!o.status.success());
    let said = crate::common::stderr(&o);
    assert!(said.contains("`folders of "), "{said}");
    assert!(said.contains("`, which the design refers to, changed after the lock"), "{said}");
    // Without `folders nested` there are no folders to split by.
    let flat = text.replace("\n  folders nested", "");
    let e = crossaudit::design::from_str("lab.design", &flat).unwrap_err().to_string();
    assert!(e.contains("no folders to split by") && e.contains("folders nested"), "{e}");
    // A log beside the role folders is in no role: refused by `check`,
    // named, where it was audited and silently never used.
    std::fs::copy(fixtures.join("F1_circle_slow_rep1.csv"), lab.join("stray_rep9.csv")).unwrap();
    let o = bin(&["check", d]);
    crate::common::assert_refused(&o, "logs in no role folder");
    assert!(
        crate::common::stderr(&o)
            .contains("1 log(s) lie in the data folder itself, in no role folder of the split (stray_rep9.csv)"),
        "{}",
        crate::common::stderr(&o)
    );
}

/// A NanoBench log with every position x moved by 1 mm.
fn shift_px(text: &str) -> String {
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let px = header.split(',').position(|h| h == "px").unwrap();
    let mut out = format!("{header}\n");
    for line in lines {
        let mut f: Vec<String> = line.split(',').map(String::from).collect();
        f[px] = format!("{:?}", f[px].parse::<f64>().unwrap() + 0.001);
        out += &(f.join(",") + "\n");
    }
    out
}

/// A 100 Hz log of a circle at 1 m/s, 6 s, actions varying, as CSV: `edit`
/// may change each row's (t, x, y, z) before it is written.
fn circle_log(path: &Path, edit: &dyn Fn(usize, &mut [f64; 4])) {
    let mut text = String::from("t,x,y,z,m1\n");
    for k in 0..600 {
        let t = k as f64 * 0.01;
        let mut row = [t, t.cos(), t.sin(), 1.0];
        edit(k, &mut row);
        let m1 = 0.6 + 0.1 * (3.0 * t).sin();
        text += &format!("{:?},{:?},{:?},{:?},{m1:?}\n", row[0], row[1], row[2], row[3]);
    }
    std::fs::write(path, text).unwrap();
}

/// Item 4: a crashed flight (motion capture frozen at 3.0 s while the
/// motors still change, then the onboard position drifting to 17 m) is
/// excluded by the declared rules for any layout, each exclusion in the
/// audit with its rule and what it measured; a clean flight passes them.
#[test]
fn a_crashed_flight_is_excluded_by_declared_plausibility_rules() {
    let tmp = tempfile::tempdir().unwrap();
    circle_log(&tmp.path().join("clean_1.csv"), &|_, _| {});
    circle_log(&tmp.path().join("clean_2.csv"), &|_, r| r[3] = 1.2);
    circle_log(&tmp.path().join("frozen_1.csv"), &|k, r| {
        if (300..450).contains(&k) {
            (r[1], r[2]) = (3f64.cos(), 3f64.sin());
        }
    });
    circle_log(&tmp.path().join("drift_1.csv"), &|k, r| {
        if k >= 400 {
            r[1] += (k - 400) as f64 * 0.085;
        }
    });
    let design = format!(
        r#"study "crash"
data csv {{
  path "{}"
  rate 100 Hz
  time t
  position x, y, z
  action m1 scale 1
  include active(m1 > 0.1) >= 20 samples
  exclude frozen position for 1 s
  exclude beyond position 10 m
  exclude beyond speed 5 m/s
}}
factor recording {{ evaluation 2 split_seed 3; starts 3 horizon 20 }}
factor seed = 1..2
validation 60 windows from 1 recordings seed 5
arm disjoint {{ fit 100 windows seed 1 }}
arm contaminated {{ from disjoint replace 25% with evaluation windows exclude starts seed 2 }}
train {{ adam lr 1e-3 batch 64 epochs 2 cosine patience 2 action_noise 0 }}
model world = mlp(32, 32) inputs world
endpoint primary fa_position_rmse at 0.1 s cap 2 m model world
contrast contaminated - disjoint
estimate crossed_mom level 0.95 df seed - 1
decide confirmed when optimism >= 10% and upper < 0
"#,
        tmp.path().display()
    );
    let audit = data::audit(&spec(&design), tmp.path()).unwrap_or_else(|e| panic!("{e}"));
    let row = |name: &str| audit.files.iter().find(|f| f.name == name).unwrap();
    for clean in ["clean_1", "clean_2"] {
        assert_eq!(row(clean).status, data::Status::Included, "{}", row(clean).reason);
        assert!(row(clean).verdicts.iter().all(|v| v.pass));
    }
    // Frozen from row 301 (t = 3.00 s) to row 450: 1.49 s.
    let frozen = row("frozen_1");
    assert_eq!(frozen.status, data::Status::Excluded);
    assert_eq!(frozen.reason, "`exclude frozen position for 1 s`: position unchanged for 1.49 s from row 301 (t = 3.00 s) while the actions vary");
    // The drift reaches 17.0 m at the end; its 8.5 m/s add to the circle's
    // 1 m/s, |(8.5 - sin t, cos t)| largest (9.5) where sin t = -1, at
    // t = 3 pi / 2 = 4.71 s (row 473).
    let drift = row("drift_1");
    assert_eq!(drift.status, data::Status::Excluded);
    let v: Vec<(&str, bool, &str)> =
        drift.verdicts.iter().map(|v| (v.rule.as_str(), v.pass, v.detail.as_str())).collect();
    assert!(v[1].1, "not frozen: {:?}", v[1]);
    assert_eq!(v[2].2, format!("largest |position| {:.3} m at row 600 (t = 5.99 s)", 5.99f64.cos() + 199.0 * 0.085));
    assert!(!v[2].1);
    assert!(!v[3].1 && v[3].2.starts_with("largest speed 9.50") && v[3].2.contains("row 473"), "{:?}", v[3]);
    // recordings.csv carries each rule's verdict in its own column.
    let csv = audit.to_csv();
    assert!(csv.lines().next().unwrap().contains("rule2: `exclude frozen position for 1 s`"), "{csv}");
    // A bound must be positive, at its place.
    let e = crossaudit::design::from_str("crash.design", &design.replace("speed 5 m/s", "speed -5 m/s")).unwrap_err();
    assert!(e.to_string().contains("crash.design:11:"), "{e}");
}

/// `exclude implausible` reads NanoBench's battery and setpoint columns:
/// in a layout without them it is refused by `check` at its line, with the
/// rules any layout can declare, where it used to pass `check` and stop
/// the audit.
#[test]
fn nanobench_plausibility_on_another_layout_is_refused_by_check() {
    let tmp = tempfile::tempdir().unwrap();
    let design =
        reordered_design(tmp.path(), XYZW).replace("  include active", "  exclude implausible\n  include active");
    let e = crossaudit::design::from_str("study.design", &design).unwrap_err().to_string();
    assert!(e.contains("implausible without NanoBench's columns") && e.contains("exclude frozen position"), "{e}");
    assert!(e.contains("pwr_pm_vbat and sp_ctrltarget_z") && e.contains("study.design:12:3"), "{e}");
}

/// The lab's folder of `designs/logs/lab.design`, written by
/// `simulate-lab` (seed 7) when absent, once per test process.
pub(crate) fn lab_logs() -> std::path::PathBuf {
    static ONCE: std::sync::OnceLock<std::path::PathBuf> = std::sync::OnceLock::new();
    ONCE.get_or_init(|| {
        let dir = crate::common::root().join("designs/logs/lab_logs");
        if !dir.join("test").is_dir() || !dir.join("train").is_dir() {
            crossaudit::sim::simulate_lab(&dir, 7).unwrap_or_else(|e| panic!("{e}"));
        }
        dir
    })
    .clone()
}

/// Item 7: the lab's folder to a report with no conversion script. The
/// committed run (results/lab) comes out byte for byte from the generated
/// Parquet folder; its audit excludes the frozen flight by its rule and the
/// stalled logger's file as unreadable at its gap, and reports the
/// quaternions it renormalised.
#[test]
fn the_lab_design_reproduces_its_committed_run() {
    let dir = lab_logs();
    // The generator writes the same logs for the same seed.
    let again = tempfile::tempdir().unwrap();
    let written = crossaudit::sim::simulate_lab(again.path(), 7).unwrap();
    assert_eq!(written.len(), 21);
    for rel in &written {
        assert!(std::fs::read(dir.join(rel)).unwrap() == std::fs::read(again.path().join(rel)).unwrap(), "{rel}");
    }
    let compared = crate::logs::reproduces_committed_run("designs/logs/lab.design", "results/lab");
    assert!(compared > 20, "{compared} files compared");
    let audit = std::fs::read_to_string(crate::common::root().join("results/lab/audit/recordings.csv")).unwrap();
    let row = |name: &str| audit.lines().find(|l| l.starts_with(&format!("{name},"))).unwrap().to_string();
    assert!(row("lab-star-take3").contains("excluded,`exclude frozen position for 2 s`: position unchanged for"));
    // The stalled flight is kept and cut at its gap (`gaps over 0.1 s segment`).
    let stalled = row("lab-oval-take1");
    assert!(stalled.contains("pass: 1 gap(s), cut there (first line 1022: the time jumps by 5.010 s)"), "{stalled}");
    assert!(stalled.contains(",included,"), "{stalled}");
    assert!(row("lab-circle-take2").contains(",test/lab-circle-take2.parquet,"));
    assert_eq!(audit.lines().filter(|l| l.contains(",included,")).count(), 20);
    let header: Vec<&str> = audit.lines().next().unwrap().split(',').collect();
    let at = header.iter().position(|h| *h == "quaternion_max_deviation").unwrap();
    let deviation: f64 = row("lab-circle-take1").split(',').nth(at).unwrap().parse().unwrap();
    assert!((0.011..0.02).contains(&deviation), "{deviation}");
}

/// `exclude beyond rate L rad/s` bounds how fast the attitude turns: a log
/// yawing at a constant 2 rad/s measures 2 rad/s (the angle between
/// consecutive quaternions over the step, 2 acos(cos(w dt / 2)) / dt = w),
/// so 1 rad/s excludes it and 3 rad/s keeps it; a layout without an
/// attitude refuses the rule at its line.
#[test]
fn an_attitude_turning_too_fast_is_excluded_by_a_rate_bound() {
    let tmp = tempfile::tempdir().unwrap();
    let mut text = String::from("t,x,y,z,qw,qx,qy,qz,m1\n");
    for k in 0..400 {
        let t = k as f64 * 0.01;
        let yaw = 2.0 * t;
        let m1 = 0.6 + 0.1 * (3.0 * t).sin();
        text +=
            &format!("{t:?},{:?},0.0,1.0,{:?},0.0,0.0,{:?},{m1:?}\n", 0.1 * t, (yaw / 2.0).cos(), (yaw / 2.0).sin());
    }
    std::fs::write(tmp.path().join("yaw_1.csv"), text).unwrap();
    let design = |bound: &str, attitude: &str| {
        format!(
            r#"study "rate"
data csv {{
  path "{}"
  rate 100 Hz
  time t
  position x, y, z
  {attitude}
  action m1 scale 1
  include active(m1 > 0.1) >= 20 samples
  exclude beyond rate {bound} rad/s
}}
factor recording {{ evaluation 2 split_seed 3; starts 3 horizon 20 }}
factor seed = 1..2
validation 60 windows from 1 recordings seed 5
arm disjoint {{ fit 100 windows seed 1 }}
arm contaminated {{ from disjoint replace 25% with evaluation windows exclude starts seed 2 }}
train {{ adam lr 1e-3 batch 64 epochs 2 cosine patience 2 action_noise 0 }}
model world = mlp(32, 32) inputs world
endpoint primary fa_position_rmse at 0.1 s cap 2 m model world
contrast contaminated - disjoint
estimate crossed_mom level 0.95 df seed - 1
decide confirmed when optimism >= 10% and upper < 0
"#,
            tmp.path().display()
        )
    };
    let attitude = "attitude quaternion wxyz qw, qx, qy, qz";
    let verdict = |bound: &str| {
        let audit = data::audit(&spec(&design(bound, attitude)), tmp.path()).unwrap_or_else(|e| panic!("{e}"));
        let v = audit.files[0].verdicts[1].clone();
        (v.pass, v.detail)
    };
    let (pass, detail) = verdict("1");
    assert!(!pass && detail.starts_with("largest attitude rate 2.000 rad/s"), "{detail}");
    assert!(verdict("3").0);
    let e = crossaudit::design::from_str("rate.design", &design("1", "")).unwrap_err().to_string();
    assert!(e.contains("rate without an attitude") && e.contains("rate.design:10:"), "{e}");
}

/// Issue 77, class 1: an undeclared Parquet date or time-of-day column
/// holding a value no calendar can show (a date of day i32::MAX, a time of
/// i64::MAX microseconds) panicked inside the Parquet reader, which
/// rendered it as a calendar date to build the CSV text. Every such value
/// is now written as the number it stores (days since 1970-01-01; seconds
/// since midnight): the log is read, and the extreme values are the
/// numbers they are.
#[test]
fn an_extreme_parquet_date_or_time_is_read_as_its_number_without_a_panic() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("extreme.parquet");
    write_parquet(
        &path,
        &[
            ("x", Column::Double(vec![Some(1.0), Some(2.0)])),
            ("day", Column::Date(vec![i32::MAX, 19_000])),
            ("clock", Column::TimeMicros(vec![i64::MAX, 1_500_000])),
        ],
    );
    let bytes = std::fs::read(&path).unwrap();
    let text = crossaudit::io::parquet::to_csv_text(bytes, 1 << 20, "a log").unwrap();
    let text = String::from_utf8(text).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "x,day,clock", "{text}");
    assert_eq!(lines[1], format!("1.0,{},{:?}", i32::MAX, i64::MAX as f64 / 1e6), "{text}");
    assert_eq!(lines[2], "2.0,19000,1.5", "{text}");
}

/// Undeclared columns never refuse or exclude anything, whatever their
/// names and values: the fixture logs as Parquet, one with an undeclared
/// text column named with a comma and one whose text holds a line break,
/// audit exactly as without them (every recording's status and reason).
#[test]
fn undeclared_columns_with_commas_and_line_breaks_decide_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let fixtures = crate::common::root().join("tests/fixtures/nanobench");
    let (plain, noted) = (tmp.path().join("plain"), tmp.path().join("noted"));
    std::fs::create_dir_all(&plain).unwrap();
    std::fs::create_dir_all(&noted).unwrap();
    for entry in std::fs::read_dir(&fixtures).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.ends_with("_metadata.yaml") {
            continue;
        }
        let bytes = crossaudit::data::log::read_bytes(&path).unwrap();
        let (header, cols) = numeric_columns(&String::from_utf8(bytes).unwrap());
        let stem = crossaudit::data::recording_name(&path);
        let n = cols[0].len();
        let mut columns: Vec<(&str, Column)> = header
            .iter()
            .zip(&cols)
            .map(|(h, c)| (h.as_str(), Column::Double(c.iter().map(|v| Some(*v)).collect())))
            .collect();
        write_parquet(&plain.join(format!("{stem}.parquet")), &columns);
        columns.push(("note, pilot's", Column::Text(vec!["calm, no wind".to_string(); n])));
        columns.push(("remark", Column::Text((0..n).map(|k| format!("row {k}\nsecond line\r\n")).collect())));
        write_parquet(&noted.join(format!("{stem}.parquet")), &columns);
    }
    let spec =
        crossaudit::design::load(&crate::common::root().join("tests/designs/logs_generic.design")).unwrap().design.data;
    let status = |dir: &Path| -> Vec<String> {
        let a = crossaudit::data::audit(&spec, dir).unwrap();
        let at = dir.display().to_string();
        a.files.iter().map(|f| format!("{} {:?} {}", f.name, f.status, f.reason.replace(&at, "DIR"))).collect()
    };
    let (a, b) = (status(&plain), status(&noted));
    assert!(a.len() >= 5, "{a:?}");
    assert_eq!(a, b);
}

/// A lab's file names (`lab-circle-take1`) are not NanoBench's
/// (`B9_trefoil_slow_mell_rep3`): they say nothing of the controller, so
/// the audit says `unknown` where it once defaulted to NanoBench's PID.
#[test]
fn a_foreign_name_says_nothing_of_the_controller() {
    let audit = std::fs::read_to_string(crate::common::root().join("results/lab/audit/recordings.csv")).unwrap();
    let mut rows = csv::Reader::from_reader(audit.as_bytes());
    let at = rows.headers().unwrap().iter().position(|h| h == "controller").unwrap();
    let mut n = 0;
    for r in rows.records() {
        assert_eq!(&r.unwrap()[at], "unknown");
        n += 1;
    }
    assert!(n >= 20, "{n} lab recordings");
}

/// Parquet read by column gives the text of parquet's record API, byte for
/// byte: the simulated lab's 21 logs (doubles with NaN, floats, text,
/// nanosecond timestamps), and a file with nulls, a float32 column and
/// text holding commas, quotes and line breaks. A file with a column the
/// columns do not read (a date) is left to the record API, and reads the
/// same.
#[test]
fn parquet_read_by_column_gives_the_record_apis_text() {
    use crossaudit::io::parquet::{columns_to_csv_text, decode_columns, rows_to_csv_text, to_csv_text};
    let tmp = tempfile::tempdir().unwrap();
    crossaudit::sim::lab::simulate_lab(tmp.path(), 7).unwrap();
    let mut files: Vec<std::path::PathBuf> = ["train", "test"]
        .iter()
        .flat_map(|d| std::fs::read_dir(tmp.path().join(d)).unwrap().map(|e| e.unwrap().path()))
        .filter(|p| p.extension().is_some_and(|e| e == "parquet"))
        .collect();
    assert_eq!(files.len(), 21, "{files:?}");
    let mixed = tmp.path().join("mixed.parquet");
    write_parquet(
        &mixed,
        &[
            (
                "t",
                Column::TimestampNanos(vec![
                    1_700_000_000_000_000_000,
                    1_700_000_000_010_000_000,
                    1_700_000_000_020_000_000,
                ]),
            ),
            ("x", Column::Double(vec![Some(0.1), None, Some(-1e-7)])),
            ("g", Column::Float(vec![1.5, f32::NAN, 3.25e-5])),
            ("note, quoted", Column::Text(vec!["a,b".into(), "say \"hi\"".into(), "two\nlines".into()])),
        ],
    );
    files.push(mixed);
    for f in &files {
        let raw = std::fs::read(f).unwrap();
        let columns = columns_to_csv_text(bytes::Bytes::from(raw.clone()), u64::MAX)
            .unwrap_or_else(|| panic!("{} is read by column", f.display()));
        let rows = rows_to_csv_text(bytes::Bytes::from(raw), u64::MAX, "a log").unwrap();
        assert!(
            columns == rows,
            "{}: by column\n{}\nby record\n{}",
            f.display(),
            String::from_utf8_lossy(&columns),
            String::from_utf8_lossy(&rows)
        );
    }
    // What `read_log` checks instead of writing the text
    // (`DecodedColumns::fits`): a bound, so whenever it holds at a limit
    // the text keeps to it; every file here fits with room, none where
    // the text itself passes the limit.
    for f in &files {
        let raw = bytes::Bytes::from(std::fs::read(f).unwrap());
        let len = columns_to_csv_text(raw.clone(), u64::MAX).unwrap().len() as u64;
        assert!(decode_columns(raw.clone(), u64::MAX).unwrap().fits(usize::MAX), "{}", f.display());
        for limit in [len - 1, len, 2 * len, 40 * len] {
            if decode_columns(raw.clone(), limit).unwrap().fits(usize::MAX) {
                assert!(columns_to_csv_text(raw.clone(), limit).is_some(), "{} at {limit}", f.display());
            }
        }
        assert!(!decode_columns(raw.clone(), len - 1).unwrap().fits(usize::MAX), "{}", f.display());
        assert!(decode_columns(raw.clone(), 40 * len).unwrap().fits(usize::MAX), "{}", f.display());
        assert!(columns_to_csv_text(raw, len - 1).is_none(), "{}", f.display());
    }
    let dated = tmp.path().join("dated.parquet");
    write_parquet(&dated, &[("x", Column::Double(vec![Some(1.0)])), ("day", Column::Date(vec![19_000]))]);
    let raw = std::fs::read(&dated).unwrap();
    assert!(columns_to_csv_text(bytes::Bytes::from(raw.clone()), u64::MAX).is_none(), "a date is the record API's");
    assert_eq!(to_csv_text(raw.clone(), u64::MAX, "a log").unwrap(), b"x,day\n1.0,19000\n");
    // Past the limit: the record API words the refusal.
    let e = to_csv_text(raw, 8, "a log").unwrap_err();
    assert!(e.contains("exceed the 8 bytes read from a log"), "{e}");
}

/// A Parquet log read from its decoded columns (`data::log::read_log`) is
/// the log its CSV text gives (`parse_with`, the reference): the same
/// columns bit for bit, content hash and row hashes, or the same error,
/// under every combination of row hashes and missing values read as NaN.
/// The simulated lab's 21 logs and a clean file of every type the columns
/// read are taken from the columns; nulls, NaN and infinity, time going
/// back, a value too large, a declared text column (numbers or not), a
/// line too long or bounded past the limit, and a one-column file (whose
/// empty rows are blank lines) are each either taken from the columns
/// equal to the text's log or left to the text.
#[test]
fn a_parquet_log_read_from_its_columns_is_the_log_its_text_gives() -> Result<(), Box<dyn std::error::Error>> {
    use crossaudit::data::log::{from_columns, parse_with, read_log, Log, ParseOptions, Schema};
    let tmp = tempfile::tempdir()?;
    crossaudit::sim::lab::simulate_lab(tmp.path(), 7)?;
    let lab: Vec<std::path::PathBuf> = ["train", "test"]
        .iter()
        .flat_map(|d| std::fs::read_dir(tmp.path().join(d)).into_iter().flatten().flatten().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "parquet"))
        .collect();
    assert_eq!(lab.len(), 21, "{lab:?}");
    let named = |columns: &[&str], time: Option<&str>| Schema::Named {
        columns: columns.iter().map(|c| c.to_string()).collect(),
        time: time.map(str::to_string),
    };
    let lab_schema = named(&["timestamp", "pos_x", "vel_z", "quat_w", "cmd_m1", "cmd_m4", "pos_x"], Some("timestamp"));
    let t =
        |n: usize| Column::TimestampNanos((0..n as i64).map(|k| 1_700_000_000_000_000_000 + k * 10_000_000).collect());
    let file = |name: &str, columns: &[(&str, Column)]| {
        let path = tmp.path().join(format!("{name}.parquet"));
        write_parquet(&path, columns);
        path
    };
    let xs = |v: &[f64]| Column::Double(v.iter().map(|x| Some(*x)).collect());
    let clean = file(
        "clean",
        &[
            ("t", t(4)),
            ("x", xs(&[0.1, -1e-7, 3.0, 1e15])),
            ("y", Column::Float(vec![1.5, 0.1, -3.25e-5, 7.0])),
            ("note", Column::Text(vec!["a,b".into(), "say \"hi\"".into(), "two\nlines".into(), "".into()])),
        ],
    );
    let with_x =
        |name: &str, x: Column| file(name, &[("t", t(3)), ("x", x), ("y", Column::Float(vec![1.0, 2.0, 3.0]))]);
    let nulls = with_x("nulls", Column::Double(vec![Some(1.0), None, Some(3.0)]));
    let nan = with_x("nan", xs(&[f64::NAN, 2.0, f64::INFINITY]));
    let large = with_x("large", xs(&[1.0, 2e15, 3.0]));
    let back = file("back", &[("t", Column::TimestampNanos(vec![3, 2, 1])), ("x", xs(&[1.0, 2.0, 3.0]))]);
    let numbers_as_text = file("text", &[("t", t(2)), ("x", Column::Text(vec!["1.5".into(), "2".into()]))]);
    let words = file("words", &[("t", t(2)), ("x", Column::Text(vec!["calm".into(), "2".into()]))]);
    let single = file("single", &[("x", Column::Double(vec![Some(1.0), None, Some(2.0)]))]);
    // A note not read whose line passes the reader's 64 KiB (refused), and
    // one whose line keeps to it but whose bound does not (read): both
    // left to the text, which decides.
    let noted = |name: &str, n: usize| {
        file(name, &[("t", t(2)), ("x", xs(&[1.0, 2.0])), ("note", Column::Text(vec!["a".repeat(n), "b".into()]))])
    };
    let (long, near) = (noted("long", 70_000), noted("near", 40_000));
    let xy = named(&["x", "y"], Some("t"));
    let mut cases: Vec<(&std::path::Path, &Schema, bool)> =
        lab.iter().map(|p| (p.as_path(), &lab_schema, true)).collect();
    cases.push((&clean, &xy, true));
    let (x_only, no_time) = (named(&["x"], Some("t")), named(&["x"], None));
    for p in [&nulls, &nan, &large, &back, &numbers_as_text, &words, &long, &near] {
        cases.push((p, &x_only, false));
    }
    cases.push((&back, &no_time, true));
    cases.push((&single, &no_time, false));
    let bits = |log: &Log| {
        let columns: Vec<Vec<u64>> = log.columns.iter().map(|c| c.iter().map(|v| v.to_bits()).collect()).collect();
        (log.rows, columns, log.content_hash.clone(), log.row_hashes.clone(), log.blank_before.clone())
    };
    let mut taken = 0;
    for (path, schema, from_the_columns) in cases {
        let raw = std::fs::read(path)?;
        let text = crossaudit::io::parquet::to_csv_text(raw.clone(), u64::MAX, "a flight log")?;
        let decoded = crossaudit::io::parquet::decode_columns(bytes::Bytes::from(raw), u64::MAX);
        for (hash_rows, missing_as_nan) in [(false, false), (true, false), (false, true), (true, true)] {
            let options = ParseOptions { hash_rows, missing_as_nan };
            let name = path.display().to_string();
            let reference = parse_with(&name, &text, schema, options);
            let read = read_log(path, &name, schema, options);
            let fast = decoded.as_ref().and_then(|d| from_columns(&name, d, schema, options));
            let what = format!("{name}, {options:?}");
            match (&reference, &read) {
                (Ok(a), Ok(b)) => assert!(bits(a) == bits(b), "{what}: {a:?} against {b:?}"),
                (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "{what}"),
                _ => panic!("{what}: {reference:?} against {read:?}"),
            }
            if let Some(fast) = &fast {
                let reference = reference.as_ref().map_err(|e| format!("{what}: the text is refused: {e}"))?;
                assert!(bits(fast) == bits(reference), "{what}");
                taken += 1;
            }
            if from_the_columns {
                assert!(fast.is_some(), "{what} is taken from its columns");
            }
            if path == long.as_path() || path == near.as_path() {
                assert!(fast.is_none(), "{what}: its line is bounded past the limit");
                let long_refused = reference.as_ref().is_err_and(|e| e.to_string().contains("65536"));
                assert_eq!(long_refused, path == long.as_path(), "{what}: {reference:?}");
            }
        }
    }
    // The nulls and NaN read as missing (and the time going back where no
    // time is declared) are taken from the columns too.
    assert!(taken >= 22 * 4 + 3, "{taken} reads from the columns");
    Ok(())
}

/// Under NanoBench's header, where every field must be a finite number,
/// read or not: the committed NanoBench fixtures as Parquet are taken from
/// their columns, to the log their text gives (its content and row hashes
/// included); a column not read that holds a null, a NaN or a word sends
/// the file to the text's reader, which refuses it as it refuses that
/// text.
#[test]
fn nanobench_parquet_logs_are_read_from_their_columns_unless_a_field_is_no_number(
) -> Result<(), Box<dyn std::error::Error>> {
    use crossaudit::data::log::{
        column_indices, from_columns, parse_with, read_bytes, read_log, Log, ParseOptions, Schema,
    };
    use crossaudit::io::parquet::{csv_to_parquet, decode_columns, to_csv_text};
    let tmp = tempfile::tempdir()?;
    let fixtures = crate::common::root().join("tests/fixtures/nanobench");
    let mut logs = Vec::new();
    for e in std::fs::read_dir(&fixtures)? {
        let p = e?.path();
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("").to_string();
        if name.ends_with(".csv") || name.ends_with(".csv.gz") {
            logs.push((name.split('.').next().unwrap_or("").to_string(), read_bytes(&p)?));
        }
    }
    logs.sort();
    assert_eq!(logs.len(), 5, "the committed NanoBench fixtures");
    // `roll` (column 8) is not read: a field there that is no finite number.
    let edited = |field: &str| -> String {
        let text = String::from_utf8_lossy(&logs[0].1).into_owned();
        let mut lines: Vec<String> = text.lines().map(String::from).collect();
        let mut f: Vec<String> = lines[3].split(',').map(String::from).collect();
        f[8] = field.to_string();
        lines[3] = f.join(",");
        lines.join("\n") + "\n"
    };
    let mut cases = Vec::new();
    for (stem, text) in logs.iter().map(|(s, t)| (s.clone(), t.clone())).chain([
        ("null_roll".to_string(), edited("").into_bytes()),
        ("nan_roll".to_string(), edited("nan").into_bytes()),
        ("word_roll".to_string(), edited("calm").into_bytes()),
    ]) {
        let path = tmp.path().join(format!("{stem}.parquet"));
        std::fs::write(&path, csv_to_parquet(&text)?)?;
        cases.push((path, !stem.ends_with("_roll")));
    }
    let read: Vec<String> =
        ["t", "px", "py", "pz", "qx", "qy", "qz", "qw", "vx", "vy", "vz", "motor_motor_m1", "motor_motor_m4", "px"]
            .iter()
            .map(|c| c.to_string())
            .collect();
    let schema = Schema::Nanobench(column_indices(&read)?);
    let bits = |log: &Log| {
        let columns: Vec<Vec<u64>> = log.columns.iter().map(|c| c.iter().map(|v| v.to_bits()).collect()).collect();
        (log.rows, columns, log.content_hash.clone(), log.row_hashes.clone(), log.blank_before.clone())
    };
    for (path, clean) in &cases {
        let raw = std::fs::read(path)?;
        let text = to_csv_text(raw.clone(), u64::MAX, "a flight log")?;
        let decoded = decode_columns(bytes::Bytes::from(raw), u64::MAX).ok_or("decoded by column")?;
        for (hash_rows, missing_as_nan) in [(false, false), (true, false), (false, true), (true, true)] {
            let options = ParseOptions { hash_rows, missing_as_nan };
            let name = path.display().to_string();
            let what = format!("{name}, {options:?}");
            let reference = parse_with(&name, &text, &schema, options);
            let got = read_log(path, &name, &schema, options);
            let fast = from_columns(&name, &decoded, &schema, options);
            if *clean {
                let (reference, got) = (reference?, got?);
                assert!(bits(&got) == bits(&reference), "{what}");
                assert!(reference.rows > 100, "{what}: {} rows", reference.rows);
                let fast = fast.ok_or_else(|| format!("{what} is not taken from its columns"))?;
                assert!(bits(&fast) == bits(&reference), "{what}");
            } else {
                assert!(fast.is_none(), "{what} is taken from its columns");
                let (Err(want), Err(e)) = (&reference, &got) else {
                    panic!("{what}: {reference:?} against {got:?}, where the text's reader refuses the roll");
                };
                assert_eq!(e.to_string(), want.to_string(), "{what}");
                assert!(want.to_string().contains("roll"), "{what}: {want}");
            }
        }
    }
    Ok(())
}

/// The same, on 300 small random files: each column a double (with nulls,
/// NaN, infinities and values too large), a float, a timestamp (rising or
/// not) or text (numbers or words, with commas, quotes and line breaks),
/// under a random declaration of some of
/// them, with and without a time column, under every parse option.
#[test]
fn random_parquet_logs_read_from_their_columns_are_the_logs_their_text_gives() -> Result<(), Box<dyn std::error::Error>>
{
    use crossaudit::data::log::{from_columns, parse_with, read_log, Log, ParseOptions, Schema};
    let tmp = tempfile::tempdir()?;
    // A 64-bit LCG (Knuth's MMIX constants).
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move |n: u64| {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 33) % n
    };
    let bits = |log: &Log| {
        let columns: Vec<Vec<u64>> = log.columns.iter().map(|c| c.iter().map(|v| v.to_bits()).collect()).collect();
        (log.rows, columns, log.content_hash.clone(), log.row_hashes.clone())
    };
    // Text with commas, quotes and line breaks, a lone `\r` among them.
    const WORDS: [&str; 6] = ["calm", "a,b", "", "say \"hi\"", "cr\ralone", "two\r\nlines"];
    let (mut taken, mut refused) = (0, 0);
    for f in 0..300 {
        let rows = 1 + next(6) as usize;
        let names = ["t", "a", "b", "c"];
        let mut columns = Vec::new();
        for name in names {
            let column = match next(5) {
                0 => Column::Double(
                    (0..rows)
                        .map(|_| match next(12) {
                            0 => None,
                            1 => Some(f64::NAN),
                            2 => Some(f64::NEG_INFINITY),
                            3 => Some(3e15),
                            _ => Some((next(2_000_001) as f64 - 1e6) / 10f64.powi(next(9) as i32)),
                        })
                        .collect(),
                ),
                1 => Column::Float((0..rows).map(|_| (next(20_001) as f32 - 1e4) / 64.0).collect()),
                2 => {
                    let rising = next(4) > 0;
                    Column::TimestampNanos(
                        (0..rows as i64).map(|k| if rising { k * 5_000_000 } else { (k % 2) * 7_000_000 }).collect(),
                    )
                }
                3 => Column::Text((0..rows).map(|k| format!("{}.5", k as u64 + next(9))).collect()),
                _ => Column::Text((0..rows).map(|_| WORDS[next(WORDS.len() as u64) as usize].into()).collect()),
            };
            columns.push((name, column));
        }
        let path = tmp.path().join(format!("r{f}.parquet"));
        write_parquet(&path, &columns);
        let declared: Vec<String> = names[1..].iter().filter(|_| next(2) == 0).map(|s| s.to_string()).collect();
        let declared = if declared.is_empty() { vec!["a".to_string()] } else { declared };
        let time = (next(2) == 0).then(|| "t".to_string());
        let schema = Schema::Named { columns: declared, time };
        let raw = std::fs::read(&path)?;
        let text = crossaudit::io::parquet::to_csv_text(raw.clone(), u64::MAX, "a flight log")?;
        let decoded = crossaudit::io::parquet::decode_columns(bytes::Bytes::from(raw), u64::MAX);
        for (hash_rows, missing_as_nan) in [(false, false), (true, false), (false, true), (true, true)] {
            let options = ParseOptions { hash_rows, missing_as_nan };
            let name = path.display().to_string();
            let what = format!("{name}, {schema:?}, {options:?}");
            let reference = parse_with(&name, &text, &schema, options);
            let read = read_log(&path, &name, &schema, options);
            match (&reference, &read) {
                (Ok(a), Ok(b)) => assert!(bits(a) == bits(b), "{what}"),
                (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "{what}"),
                _ => panic!("{what}: {reference:?} against {read:?}"),
            }
            refused += usize::from(reference.is_err());
            if let Some(fast) = decoded.as_ref().and_then(|d| from_columns(&name, d, &schema, options)) {
                let reference = reference.as_ref().map_err(|e| format!("{what}: the text is refused: {e}"))?;
                assert!(bits(&fast) == bits(reference), "{what}");
                taken += 1;
            }
        }
    }
    // Both paths are exercised, and some files are refused.
    assert!(taken > 200 && refused > 100, "{taken} read from the columns, {refused} refused");
    Ok(())
}

/// Damaged Parquet logs: 1,500 copies of a small log (200 rows: a
/// timestamp, doubles with nulls, floats, a note), each with one to four
/// bytes changed at random (seeded), in its pages or its footer. Wherever
/// the columns give a log, its text gives the same one, values, content
/// hash and row hashes included; no copy makes either reader panic.
#[test]
fn damaged_parquet_logs_give_from_their_columns_what_their_text_gives() -> Result<(), Box<dyn std::error::Error>> {
    use crossaudit::data::log::{from_columns, parse_with, ParseOptions, Schema};
    use rand::{Rng, SeedableRng};
    let tmp = tempfile::tempdir()?;
    let path = tmp.path().join("log.parquet");
    let n = 200;
    let x = (0..n).map(|k| Some(0.01 * k as f64 - 0.5).filter(|_| k % 17 != 5)).collect();
    write_parquet(
        &path,
        &[
            ("t", Column::TimestampNanos((0..n as i64).map(|k| 1_700_000_000_000_000_000 + k * 10_000_000).collect())),
            ("x", Column::Double(x)),
            ("y", Column::Float((0..n).map(|k| k as f32 * 0.25).collect())),
            ("note", Column::Text((0..n).map(|k| ["calm", "gust"][k % 2].to_string()).collect())),
        ],
    );
    let raw = std::fs::read(&path)?;
    let schema = Schema::Named { columns: vec!["x".into(), "y".into()], time: Some("t".into()) };
    let options = ParseOptions { hash_rows: true, missing_as_nan: true };
    let read = |raw: &[u8]| {
        let text = crossaudit::io::parquet::to_csv_text(raw.to_vec(), u64::MAX, "a flight log")
            .map_err(|e| e.to_string())
            .and_then(|t| parse_with("log.parquet", &t, &schema, options).map_err(|e| e.to_string()));
        let decoded = crossaudit::io::parquet::decode_columns(bytes::Bytes::from(raw.to_vec()), u64::MAX);
        let fast = decoded.as_ref().and_then(|d| from_columns("log.parquet", d, &schema, options));
        (fast, text)
    };
    let bits = |log: &crossaudit::data::log::Log| {
        let columns: Vec<Vec<u64>> = log.columns.iter().map(|c| c.iter().map(|v| v.to_bits()).collect()).collect();
        (log.rows, columns, log.content_hash.clone(), log.row_hashes.clone())
    };
    let undamaged = read(&raw).0.map(|l| bits(&l)).ok_or("the undamaged log is read by column")?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(76);
    let (mut by_column, mut changed) = (0, 0);
    for _ in 0..1_500 {
        let mut bad = raw.clone();
        let footer = rng.gen_bool(0.3);
        for _ in 0..rng.gen_range(1..=4) {
            let at = if footer {
                rng.gen_range(raw.len().saturating_sub(400)..raw.len())
            } else {
                rng.gen_range(0..raw.len())
            };
            bad[at] = rng.gen();
        }
        if let (Some(fast), text) = read(&bad) {
            by_column += 1;
            let text = text.map_err(|e| format!("read by column, refused as text: {e}"))?;
            assert!(bits(&fast) == bits(&text), "a damaged log read by column");
            changed += usize::from(bits(&fast) != undamaged);
        }
    }
    assert!(by_column > 100 && changed > 20, "{by_column} read by column, {changed} of them changed");
    Ok(())
}
