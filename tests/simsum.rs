//! `crossaudit simsum`: anyone's replications in. Every measure and MCSE
//! against rsimsum 0.13 (scripts/reference/simsum_check.R, its values
//! committed in simsum_check.csv; rsimsum's own MIsim and relhaz studies
//! are compared there too, see simsum_check.out), pairing by replication
//! id, the paired MCSEs against a hand computation, and bad files refused
//! at their line and column.

use std::collections::BTreeMap;
use std::path::Path;

use crate::common::{assert_ok, assert_refused, root};

fn simsum(file: &Path, args: &[&str], out: &Path) -> std::process::Output {
    crate::common::bin().current_dir(root()).arg("simsum").arg(file).args(args).arg("--out").arg(out).output().unwrap()
}

/// The committed replications hold several true means per setting, each
/// its own data-generating mechanism: as in rsimsum, the true value's
/// column names no groups, so it is among the by-factors too.
const OWN: [&str; 10] = [
    "--by",
    "setting,true_mean",
    "--true",
    "true_mean",
    "--level",
    "level",
    "--ci",
    "ci_lower,ci_upper",
    "--rep",
    "rep",
];

/// setting, true, level, method, stat.
type Key = (String, String, String, String, String);

/// (group and method, stat) -> (est, mcse) from a simsum.csv-shaped file.
fn table(path: &Path) -> BTreeMap<Key, (f64, f64)> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let num = |s: &str| if s == "NA" { f64::NAN } else { s.parse::<f64>().unwrap() };
    // Columns by name: ours has the by-factors (setting, true_mean) first.
    let header = r.headers().unwrap().clone();
    let at = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name}"));
    let (setting, truth, level, method, stat, est, mcse) =
        (at("setting"), at("true"), at("level"), at("method"), at("stat"), at("est"), at("mcse"));
    r.records()
        .map(|row| {
            let row = row.unwrap();
            let key = (
                row[setting].to_string(),
                num(&row[truth]).to_string(),
                num(&row[level]).to_string(),
                row[method].to_string(),
                row[stat].to_string(),
            );
            (key, (num(&row[est]), num(&row[mcse])))
        })
        .collect()
}

#[test]
fn every_measure_matches_rsimsum_on_the_committed_replications() {
    let tmp = tempfile::tempdir().unwrap();
    let o = simsum(&root().join("results/coverage_rsimsum/replications.csv"), &OWN, tmp.path());
    assert_ok(&o);
    let ours = table(&tmp.path().join("simsum.csv"));
    let theirs = table(&root().join("scripts/reference/simsum_check.csv"));
    assert_eq!(theirs.len(), 1936);
    let undefined = |key: &Key| {
        let k = (key.0.clone(), key.1.clone(), key.2.clone(), key.3.clone(), "undefined".to_string());
        ours[&k].0
    };
    let mut rsimsum_na = 0;
    for (key, (e, m)) in &theirs {
        let (oe, om) = ours.get(key).unwrap_or_else(|| panic!("{key:?} missing"));
        // rsimsum's rbias MCSE is sd(...) / sqrt(nsim) without na.rm: NA
        // whenever one replication lacks an estimate. Here it is computed
        // over the replications scored, as every other MCSE.
        if key.4 == "rbias" && m.is_nan() && om.is_finite() {
            assert!(undefined(key) > 0.0, "{key:?}");
            rsimsum_na += 1;
            continue;
        }
        // A method with the reference's very estimates: rho = 1, so the
        // relative precision's MCSE is 0; rsimsum's cor() lands a rounding
        // below 1 and the square root of 1 - rho^2 lifts it to ~1e-7.
        let rounding = key.4 == "relprec" && *om == 0.0 && *m < 1e-6;
        for (a, b, what) in [(oe, e, "est"), (om, m, "mcse")] {
            if rounding && what == "mcse" {
                continue;
            }
            let same = (a.is_nan() && b.is_nan()) || (a - b).abs() <= 1e-10 * b.abs().max(1.0);
            assert!(same, "{key:?} {what}: {a} here, {b} in rsimsum");
        }
    }
    assert!(rsimsum_na > 0 && rsimsum_na < 20, "{rsimsum_na}");
    let report = std::fs::read_to_string(root().join("scripts/reference/simsum_check.out")).unwrap();
    assert!(report.contains("MIsim: 63 values compared") && report.contains("relhaz: 252 values compared"), "{report}");
}

/// Stata's `simsum` references (rsimsum ships them for its own tests) and
/// rsimsum's `nlp` study, as scripts/reference/simsum_check.R compared
/// them with the binary: every measure agrees with Stata to its single
/// precision, except relprec's MCSE, which Stata divides by n - 2 where
/// rsimsum divides by n - 1, and which agrees once rescaled by that
/// factor; nlp paired by row order is rsimsum's, and pairing by id
/// changes relprec's MCSE alone, by factors the issue reported (7-118).
#[test]
fn stata_references_and_the_nlp_pairing_as_the_r_script_found_them() {
    let report = std::fs::read_to_string(root().join("scripts/reference/simsum_check.out")).unwrap();
    let value = |line: &str| line.split_whitespace().last().unwrap().parse::<f64>().unwrap();
    for (study, n) in [("MIsim", 46), ("relhaz", 184)] {
        let head = format!("part 3: {study} against Stata simsum: {n} values compared");
        let start = report.find(&head).unwrap_or_else(|| panic!("no {head:?} in {report}"));
        let block: Vec<&str> = report[start..].lines().skip(1).take_while(|l| l.starts_with("  ")).collect();
        assert_eq!(block.len(), 17, "{block:?}");
        for line in block {
            let v = value(line);
            match line.trim_start() {
                l if l.starts_with("relprec mcse x") => assert!(v < 1e-6, "{line}"),
                // sqrt(999/998) - 1 and sqrt(99/98) - 1, to 2 digits.
                l if l.starts_with("relprec mcse") => {
                    let expected =
                        if study == "MIsim" { (999f64 / 998.0).sqrt() - 1.0 } else { (99f64 / 98.0).sqrt() - 1.0 };
                    assert!((v / expected - 1.0).abs() < 0.02, "{line}: expected about {expected}");
                }
                l if l.starts_with("relerror est") => assert!(v < 2e-6, "{line}"),
                _ => assert!(v < 5e-7, "{line}"),
            }
        }
    }
    let line = |prefix: &str| report.lines().find(|l| l.starts_with(prefix)).unwrap_or_else(|| panic!("{prefix}"));
    let order = line("part 4: nlp: 150 settings; paired by row order");
    let diff: f64 =
        order.split("largest absolute difference ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!(diff < 1e-10, "{order}");
    let by_id = line("part 4: nlp: paired by replication id");
    let diff: f64 = by_id.split("largest difference ").nth(1).unwrap().trim_end_matches(')').parse().unwrap();
    assert!(diff < 1e-10, "{by_id}");
    let ratio = line("part 4: nlp: relprec of model 2");
    let min: f64 = ratio.split("min ").nth(1).unwrap().split(',').next().unwrap().parse().unwrap();
    let max = value(ratio);
    assert!(min > 5.0 && max > 100.0, "{ratio}");
}

/// Two methods over six replications, written by hand (truth 0). B is A
/// plus 0.1 in replications 1-3 and minus 0.1 in 4-6, its intervals 0.2 wider
/// throughout. A covers 0 in replications 3, 4, 5; B in 2, 3, 4. So the
/// per-replication differences (B - A) are: coverage (0, 1, 0, 0, -1, 0),
/// mean 0, sample variance 2 / 5 = 0.4, paired MCSE sqrt(0.4 / 6); bias
/// (.1, .1, .1, -.1, -.1, -.1), mean 0, variance 6 (0.01) / 5 = 0.012,
/// MCSE sqrt(0.012 / 6); width 0.2 each, MCSE 0.
const HAND: &str = "method,rep,estimate,se,lower,upper
A,1,0.5,0.3,0.2,0.8
A,2,0.5,0.3,0.1,0.9
A,3,-0.2,0.3,-0.5,0.1
A,4,0.1,0.3,-0.2,0.4
A,5,0.0,0.3,-0.3,0.3
A,6,0.4,0.3,0.1,0.7
B,1,0.6,0.3,0.2,1.0
B,2,0.6,0.3,0.0,1.0
B,3,-0.1,0.3,-0.5,0.3
B,4,0.0,0.3,-0.4,0.4
B,5,-0.1,0.3,0.05,0.85
B,6,0.3,0.3,0.1,0.9
";

/// Issue 75: where no pair of replications disagrees on covering, the SD
/// of the paired differences is 0 and the MCSE was 0. It is Agresti and
/// Min's (2005, Statistics in Medicine 24:729) half a pair in each cell of
/// the paired 2 x 2 table: sqrt((b + c) - (b - c)^2 / n) / n at b = c =
/// 1/2 and n + 2 pairs, 1 / (n + 2) (here 1 / 8).
#[test]
fn a_coverage_difference_no_pair_disagrees_on_has_agresti_and_mins_mcse() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("agree.csv");
    // A and B cover in replications 1-4 and miss in 5-6, both.
    let rows: Vec<String> = (1..=6)
        .flat_map(|r| {
            let (lo, hi) = if r <= 4 { (-0.5, 0.5) } else { (0.5, 0.9) };
            ["A", "B"].map(|m| format!("{m},{r},0.1,0.3,{lo},{hi}"))
        })
        .collect();
    std::fs::write(&file, format!("method,rep,estimate,se,lower,upper\n{}\n", rows.join("\n"))).unwrap();
    let o = simsum(&file, &["--true", "0", "--ci", "lower,upper", "--rep", "rep"], &tmp.path().join("out"));
    assert_ok(&o);
    let text = std::fs::read_to_string(tmp.path().join("out/simsum.csv")).unwrap();
    let row = text.lines().find(|l| l.starts_with("0,0.95,B,cover_diff,") || l.contains(",B,cover_diff,")).unwrap();
    let f: Vec<&str> = row.split(',').collect();
    let (est, mcse): (f64, f64) = (f[f.len() - 2].parse().unwrap(), f[f.len() - 1].parse().unwrap());
    assert_eq!(est, 0.0, "{row}");
    assert!((mcse - 1.0 / 8.0).abs() < 1e-15, "{row}");
}

#[test]
fn paired_differences_and_their_mcses_by_hand() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("hand.csv");
    std::fs::write(&file, HAND).unwrap();
    let o = simsum(&file, &["--true", "0", "--ci", "lower,upper", "--rep", "rep"], &tmp.path().join("out"));
    assert_ok(&o);
    let rows: BTreeMap<String, (f64, f64)> = csv::Reader::from_path(tmp.path().join("out/simsum.csv"))
        .unwrap()
        .records()
        .map(|r| r.unwrap())
        .filter(|r| &r[2] == "B")
        .map(|r| (r[3].to_string(), (r[4].parse().unwrap_or(f64::NAN), r[5].parse().unwrap_or(f64::NAN))))
        .collect();
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    let (c, cm) = rows["cover_diff"];
    assert!(close(c, 0.0) && close(cm, (0.4f64 / 6.0).sqrt()), "{c} {cm}");
    let (b, bm) = rows["bias_diff"];
    assert!(close(b, 0.0) && close(bm, (0.012f64 / 6.0).sqrt()), "{b} {bm}");
    let (w, wm) = rows["width_diff"];
    assert!(close(w, 0.2) && wm.abs() < 1e-12, "{w} {wm}");
    // Each coverage is 1/2 with MCSE sqrt(0.25 / 6) = 0.204: two unpaired
    // MCSEs combine to sqrt(2) 0.204 = 0.289, the paired one is 0.258.
    let (cov, cov_mcse) = rows["cover"];
    assert!(close(cov, 0.5) && close(cov_mcse, (0.25f64 / 6.0).sqrt()), "{cov} {cov_mcse}");
    // Agresti-Coull: 3 of 6 cover, (3 + 2) / (6 + 4) = 0.5, SE sqrt(0.25 / 10).
    let (ac, ac_mcse) = rows["cover_ac"];
    assert!(close(ac, 0.5) && close(ac_mcse, 0.025f64.sqrt()), "{ac} {ac_mcse}");
    // Interval scores at alpha = 0.05 (width + 40 x the miss), by hand:
    // A: 0.6 + 8, 0.8 + 4, 0.6, 0.6, 0.6, 0.6 + 4; B: 0.8 + 8, 1.0, 0.8,
    // 0.8, 0.8 + 2, 0.8 + 4. B - A: 0.2, -3.8, 0.2, 0.2, 2.2, 0.2.
    let b_scores = [8.8, 1.0, 0.8, 0.8, 2.8, 4.8];
    let diffs = [0.2, -3.8, 0.2, 0.2, 2.2, 0.2];
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let mcse = |v: &[f64]| (v.iter().map(|x| (x - mean(v)).powi(2)).sum::<f64>() / 5.0 / 6.0).sqrt();
    let (is, is_mcse) = rows["interval_score"];
    assert!(close(is, mean(&b_scores)) && close(is_mcse, mcse(&b_scores)), "{is} {is_mcse}");
    let (isd, isd_mcse) = rows["interval_score_diff"];
    assert!(close(isd, mean(&diffs)) && close(isd_mcse, mcse(&diffs)), "{isd} {isd_mcse}");
}

/// Rows of one method in another order: pairing by id gives the same
/// result; without ids (rsimsum's pairing by order) the relative
/// precision's MCSE changes, and the report says how it paired.
/// The replications planner against closed forms on the hand-written
/// study: B's coverage is 1/2, so an MCSE of 0.01 needs p (1 - p) / 0.01^2
/// = 2,500 replications; its bias MCSE is SD / sqrt(n), so 0.01 needs
/// var(estimates) / 0.01^2, here with the variance computed from B's six
/// estimates.
#[test]
fn replications_for_a_target_mcse_match_the_closed_forms() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("hand.csv");
    std::fs::write(&file, HAND).unwrap();
    let args = ["--true", "0", "--ci", "lower,upper", "--rep", "rep", "--target-mcse", "cover=0.01,bias=0.01"];
    assert_ok(&simsum(&file, &args, &tmp.path().join("out")));
    let text = std::fs::read_to_string(tmp.path().join("out/simsum.csv")).unwrap();
    let get = |stat: &str| -> f64 {
        let l = text.lines().find(|l| l.starts_with("0,0.95,B,") && l.contains(&format!(",{stat},"))).unwrap();
        l.split(',').nth(4).unwrap().parse().unwrap()
    };
    assert_eq!(get("reps_for_cover_mcse_0.01"), 2500.0);
    let b = [0.6, 0.6, -0.1, 0.0, -0.1, 0.3];
    let mean = b.iter().sum::<f64>() / 6.0;
    let var = b.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 5.0;
    assert_eq!(get("reps_for_bias_mcse_0.01"), (var / 1e-4).ceil());
    let md = std::fs::read_to_string(tmp.path().join("out/simsum.md")).unwrap();
    assert!(md.contains("| method | cover to 0.01 | bias to 0.01 |"), "{md}");
    let o = simsum(&file, &["--true", "0", "--target-mcse", "coverage=0.01"], &tmp.path().join("bad"));
    assert_refused(&o, "`coverage` is not a measure with an MCSE");
    let o = simsum(&file, &["--true", "0", "--target-mcse", "cover=0"], &tmp.path().join("bad"));
    assert_refused(&o, "the target is not a number above 0");
}

/// Every interval covers: rsimsum's MCSE is 0, Agresti and Coull's is
/// sqrt(0.8 x 0.2 / 10) for 6 of 6 ((6 + 2) / (6 + 4) = 0.8).
#[test]
fn a_coverage_of_one_still_has_an_mcse() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("all.csv");
    let rows: String = (1..=6).map(|r| format!("A,{r},0.1,0.3,-0.5,0.7\n")).collect();
    std::fs::write(&file, format!("method,rep,estimate,se,lower,upper\n{rows}")).unwrap();
    assert_ok(&simsum(&file, &["--true", "0", "--ci", "lower,upper", "--rep", "rep"], &tmp.path().join("out")));
    let text = std::fs::read_to_string(tmp.path().join("out/simsum.csv")).unwrap();
    assert!(text.contains("\n0,0.95,A,cover,1,0\n"), "{text}");
    let ac = text.lines().find(|l| l.contains(",cover_ac,")).unwrap();
    let mcse: f64 = ac.rsplit(',').next().unwrap().parse().unwrap();
    assert!((mcse - (0.8f64 * 0.2 / 10.0).sqrt()).abs() < 1e-15, "{ac}");
}

#[test]
fn methods_are_paired_by_replication_id_not_row_order() {
    let tmp = tempfile::tempdir().unwrap();
    let mut lines: Vec<&str> = HAND.lines().collect();
    lines[7..].reverse();
    let shuffled = tmp.path().join("shuffled.csv");
    std::fs::write(&shuffled, lines.join("\n") + "\n").unwrap();
    let plain = tmp.path().join("plain.csv");
    std::fs::write(&plain, HAND).unwrap();
    let run = |file: &Path, rep: bool, out: &str| {
        let mut args = vec!["--true", "0", "--ci", "lower,upper"];
        if rep {
            args.extend(["--rep", "rep"]);
        }
        assert_ok(&simsum(file, &args, &tmp.path().join(out)));
        std::fs::read_to_string(tmp.path().join(out).join("simsum.csv")).unwrap()
    };
    // The same numbers but for the last bits of sums taken in another order.
    let same = |x: &str, y: &str| {
        x.lines().zip(y.lines()).all(|(a, b)| {
            a.split(',').zip(b.split(',')).all(|(u, v)| match (u.parse::<f64>(), v.parse::<f64>()) {
                (Ok(p), Ok(q)) => (p - q).abs() <= 1e-12 * p.abs().max(1.0),
                _ => u == v,
            })
        })
    };
    assert!(same(&run(&plain, true, "a"), &run(&shuffled, true, "b")));
    assert!(!same(&run(&plain, false, "c"), &run(&shuffled, false, "d")));
    let md = std::fs::read_to_string(tmp.path().join("d/simsum.md")).unwrap();
    assert!(md.contains("paired by order within each group"), "{md}");
    let md = std::fs::read_to_string(tmp.path().join("b/simsum.md")).unwrap();
    assert!(md.contains("paired by replication id"), "{md}");
}

#[test]
fn bad_replication_files_are_refused_where_they_are() {
    let tmp = tempfile::tempdir().unwrap();
    let cases: [(&str, &[&str], &str); 6] = [
        ("method,estimate,se\nA,x,1\n", &["--true", "0"], "bad.csv:2:2: estimate \"x\" is not a number"),
        ("method,estimate,se\nA,1,1\n", &["--true", "truth"], "no column `truth` (--true)"),
        (
            "method,estimate,se,lvl\nA,1,1,95\n",
            &["--true", "0", "--level", "lvl"],
            "bad.csv:2:4: level 95 is not between 0 and 1",
        ),
        (
            "method,estimate,se\nA,1,1\n",
            &["--true", "0", "--ci", "lower"],
            "give the two interval-limit columns as LOWER,UPPER",
        ),
        (
            "method,rep,estimate,se\nA,1,1,1\nA,1,2,1\n",
            &["--true", "0", "--rep", "rep"],
            "replication 1 of method `A` occurs twice",
        ),
        ("method,estimate,se\nA,1,1\n", &["--true", "0", "--ref", "B"], "the reference method `B` has no replications"),
    ];
    for (k, (text, args, needle)) in cases.iter().enumerate() {
        let file = tmp.path().join("bad.csv");
        std::fs::write(&file, text).unwrap();
        let o = simsum(&file, args, &tmp.path().join(format!("out{k}")));
        assert_refused(&o, needle);
    }
}

/// One column of a Parquet file written by [`write_parquet`]: text or
/// doubles, either with nulls.
enum ParquetColumn {
    Text(Vec<Option<String>>),
    Double(Vec<Option<f64>>),
}

/// Writes `columns` as a Parquet file of OPTIONAL columns (a null where a
/// value is `None`), with the parquet crate's own writer.
fn write_parquet(path: &Path, columns: &[(String, ParquetColumn)]) {
    use parquet::basic::{LogicalType, Repetition, Type as Physical};
    use parquet::column::writer::ColumnWriter;
    use parquet::data_type::ByteArray;
    use parquet::file::properties::WriterProperties;
    use parquet::file::writer::SerializedFileWriter;
    use parquet::schema::types::Type;
    use std::sync::Arc;
    let fields = columns
        .iter()
        .map(|(name, c)| {
            let (physical, logical) = match c {
                ParquetColumn::Double(_) => (Physical::DOUBLE, None),
                ParquetColumn::Text(_) => (Physical::BYTE_ARRAY, Some(LogicalType::String)),
            };
            Arc::new(
                Type::primitive_type_builder(name, physical)
                    .with_logical_type(logical)
                    .with_repetition(Repetition::OPTIONAL)
                    .build()
                    .unwrap(),
            )
        })
        .collect();
    let schema = Arc::new(Type::group_type_builder("replications").with_fields(fields).build().unwrap());
    let file = std::fs::File::create(path).unwrap();
    let mut writer = SerializedFileWriter::new(file, schema, Arc::new(WriterProperties::builder().build())).unwrap();
    let mut group = writer.next_row_group().unwrap();
    let mut k = 0;
    while let Some(mut col) = group.next_column().unwrap() {
        let levels = |present: Vec<bool>| present.into_iter().map(i16::from).collect::<Vec<_>>();
        match (col.untyped(), &columns[k].1) {
            (ColumnWriter::DoubleColumnWriter(w), ParquetColumn::Double(v)) => {
                let values: Vec<f64> = v.iter().flatten().copied().collect();
                w.write_batch(&values, Some(&levels(v.iter().map(Option::is_some).collect())), None).unwrap()
            }
            (ColumnWriter::ByteArrayColumnWriter(w), ParquetColumn::Text(v)) => {
                let values: Vec<ByteArray> = v.iter().flatten().map(|s| ByteArray::from(s.as_str())).collect();
                w.write_batch(&values, Some(&levels(v.iter().map(Option::is_some).collect())), None).unwrap()
            }
            _ => unreachable!("column {k}: type and writer disagree"),
        };
        col.close().unwrap();
        k += 1;
    }
    group.close().unwrap();
    writer.close().unwrap();
}

/// The committed replications written as Parquet (text columns as
/// strings, numbers as doubles, every `NA` a null) give the same
/// simsum.csv, byte for byte, as the CSV: Parquet's doubles are read back
/// as the shortest text that round-trips, so every value is the same bits.
#[test]
fn a_parquet_replications_file_gives_what_its_csv_twin_gives() {
    let tmp = tempfile::tempdir().unwrap();
    let csv_path = root().join("results/coverage_rsimsum/replications.csv");
    let mut reader = csv::Reader::from_path(&csv_path).unwrap();
    let header: Vec<String> = reader.headers().unwrap().iter().map(str::to_string).collect();
    let rows: Vec<csv::StringRecord> = reader.records().map(|r| r.unwrap()).collect();
    let columns: Vec<(String, ParquetColumn)> = header
        .iter()
        .enumerate()
        .map(|(c, name)| {
            let cells = rows.iter().map(|r| Some(r[c].to_string()).filter(|v| v != "NA" && !v.is_empty()));
            let column = if matches!(name.as_str(), "setting" | "method") {
                ParquetColumn::Text(cells.collect())
            } else {
                ParquetColumn::Double(cells.map(|v| v.map(|v| v.parse::<f64>().unwrap())).collect())
            };
            (name.clone(), column)
        })
        .collect();
    let nulls = columns.iter().filter_map(|(_, c)| match c {
        ParquetColumn::Double(v) => Some(v.iter().filter(|x| x.is_none()).count()),
        ParquetColumn::Text(_) => None,
    });
    assert!(nulls.sum::<usize>() > 100, "the file should hold missing values");
    let parquet = tmp.path().join("replications.parquet");
    write_parquet(&parquet, &columns);
    let (from_csv, from_parquet) = (tmp.path().join("csv"), tmp.path().join("parquet"));
    assert_ok(&simsum(&csv_path, &OWN, &from_csv));
    assert_ok(&simsum(&parquet, &OWN, &from_parquet));
    let a = std::fs::read(from_csv.join("simsum.csv")).unwrap();
    assert!(a.len() > 10_000);
    assert!(a == std::fs::read(from_parquet.join("simsum.csv")).unwrap(), "simsum.csv differs between CSV and Parquet");
    // A damaged Parquet file is refused by name, not read as CSV.
    let damaged = tmp.path().join("damaged.parquet");
    std::fs::write(&damaged, b"PAR1 not really").unwrap();
    let o = simsum(&damaged, &OWN, &tmp.path().join("damaged"));
    assert_refused(&o, "damaged.parquet");
    assert_refused(&o, "not a readable Parquet file");
}

/// simsum.svg: each group's coverage per method, as coverage.svg draws a
/// coverage study; names from the file are text in it, never markup, and
/// a file with more groups than one figure's key holds says so instead.
#[test]
fn the_coverage_figure_draws_every_method_and_keeps_names_as_text() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("reps.csv");
    std::fs::write(
        &file,
        "method,rep,estimate,se\n\"<b>&x\",1,0.1,0.2\n\"<b>&x\",2,-0.3,0.2\n\"<b>&x\",3,0.2,0.25\nB\u{1},1,0.1,0.3\nB\u{1},2,0.2,0.3\nB\u{1},3,-0.1,0.3\n",
    )
    .unwrap();
    let out = tmp.path().join("out");
    assert_ok(&simsum(&file, &["--true", "0", "--rep", "rep"], &out));
    let svg = std::fs::read_to_string(out.join("simsum.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert!(svg.contains("&lt;b&gt;&amp;x") && !svg.contains("<b>"), "a name became markup");
    assert!(svg.contains("B\\u{1}") && !svg.contains('\u{1}'), "a control character reached the figure");
    assert!(svg.contains("true 0, level 0.95"), "the group's key");
    // 61 groups: no figure, and simsum.md says why.
    let mut many = String::from("method,g,rep,estimate,se\n");
    for g in 0..61 {
        for r in 1..=3 {
            many.push_str(&format!("A,{g},{r},0.{r},0.2\n"));
        }
    }
    std::fs::write(&file, many).unwrap();
    let out = tmp.path().join("many");
    assert_ok(&simsum(&file, &["--true", "0", "--rep", "rep", "--by", "g"], &out));
    assert!(!out.join("simsum.svg").exists());
    let md = std::fs::read_to_string(out.join("simsum.md")).unwrap();
    assert!(md.contains("simsum.svg is not drawn: 61 groups, more than the 60"), "{md}");
}

/// Issue 75: a negative true value is taken as written (`--true -1`, as
/// `--true=-1`), and `--df` beside `--ci` is refused (the given limits
/// would leave the df unread; rsimsum refuses the pair too).
#[test]
fn a_negative_truth_is_taken_and_df_beside_ci_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("hand.csv");
    std::fs::write(&file, HAND).unwrap();
    let (spaced, joined) = (tmp.path().join("spaced"), tmp.path().join("joined"));
    assert_ok(&simsum(&file, &["--true", "-1", "--ci", "lower,upper", "--rep", "rep"], &spaced));
    assert_ok(&simsum(&file, &["--true=-1", "--ci", "lower,upper", "--rep", "rep"], &joined));
    let read = |d: &Path| std::fs::read_to_string(d.join("simsum.csv")).unwrap();
    assert_eq!(read(&spaced), read(&joined));
    assert!(read(&spaced).lines().skip(1).all(|l| l.starts_with("-1,")), "{}", read(&spaced));
    let o = simsum(&file, &["--true", "0", "--ci", "lower,upper", "--df", "rep"], &tmp.path().join("bad"));
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--df") && err.contains("--ci"), "{err}");
}

/// A method or group named like a spreadsheet formula (`=HYPERLINK(...)`,
/// `@SUM(...)`) is written into simsum.csv as text a spreadsheet shows,
/// with a leading `'` (OWASP's advice), while numbers keep their sign.
#[test]
fn names_that_a_spreadsheet_would_run_are_written_as_text() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("formula.csv");
    let text = HAND
        .replace("\nA,", "\n\"=HYPERLINK(\"\"http://x\"\")\",")
        .replace("method,rep", "grp,method,rep")
        .lines()
        .enumerate()
        .map(|(k, l)| if k == 0 { l.to_string() } else { format!("@SUM(A1),{l}") })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(&file, text).unwrap();
    let o =
        simsum(&file, &["--by", "grp", "--true=-1", "--ci", "lower,upper", "--rep", "rep"], &tmp.path().join("out"));
    assert_ok(&o);
    let csv = std::fs::read_to_string(tmp.path().join("out/simsum.csv")).unwrap();
    let mut rows = csv::Reader::from_reader(csv.as_bytes());
    let mut methods = std::collections::BTreeSet::new();
    for r in rows.records() {
        let r = r.unwrap();
        assert_eq!(&r[0], "'@SUM(A1)");
        assert_eq!(&r[1], "-1", "a number keeps its sign");
        methods.insert(r[3].to_string());
    }
    assert_eq!(methods.into_iter().collect::<Vec<_>>(), ["'=HYPERLINK(\"http://x\")", "B"]);
}

/// Numbers the measures cannot use are refused at their row and column,
/// not scored: a negative SE, df of 0 or below, a lower limit above the
/// upper (a negative width), an estimate whose square overflows. A method
/// with a single usable replication has no empirical SE (NA, as R's `var`
/// of one value), not 0.
#[test]
fn numbers_that_are_not_usable_are_refused_where_they_are() {
    let tmp = tempfile::tempdir().unwrap();
    let ci = ["--true", "0", "--ci", "lower,upper", "--rep", "rep"];
    let df = ["--true", "0", "--df", "df", "--rep", "rep"];
    let cases = [
        ("A,1,0.5,-0.3,0.2,0.8,5", &ci, ":2:4: ", "SE -0.3 is negative"),
        ("A,1,0.5,0.3,0.2,0.8,0", &df, ":2:7: ", "df 0 is not positive"),
        ("A,1,0.5,0.3,0.8,0.2,5", &ci, ":2:5: ", "lower limit 0.8 is above the upper limit 0.2"),
        ("A,1,1e300,0.3,0.2,0.8,5", &ci, ":2:3: ", "would overflow"),
    ];
    for (k, (row, args, at, why)) in cases.iter().enumerate() {
        let file = tmp.path().join(format!("bad{k}.csv"));
        std::fs::write(&file, format!("method,rep,estimate,se,lower,upper,df\n{row}\nA,2,0.5,0.3,0.2,0.8,5\n"))
            .unwrap();
        let o = simsum(&file, &args[..], &tmp.path().join("o"));
        crate::common::assert_refused(&o, why);
        assert!(crate::common::stderr(&o).contains(at), "{at}: {}", crate::common::stderr(&o));
    }
    let file = tmp.path().join("one.csv");
    std::fs::write(&file, "method,rep,estimate,se\nA,1,0.5,0.3\nA,2,NA,0.3\nB,1,0.4,0.3\nB,2,0.6,0.3\n").unwrap();
    let o = simsum(&file, &["--true", "0", "--rep", "rep"], &tmp.path().join("one"));
    assert_ok(&o);
    let empse: Vec<(String, String)> = csv::Reader::from_path(tmp.path().join("one/simsum.csv"))
        .unwrap()
        .records()
        .map(|r| r.unwrap())
        .filter(|r| &r[3] == "empse")
        .map(|r| (r[2].to_string(), r[4].to_string()))
        .collect();
    assert_eq!(empse[0], ("A".to_string(), "NA".to_string()));
    assert_eq!(empse[1].0, "B");
    assert!((empse[1].1.parse::<f64>().unwrap() - 0.02f64.sqrt()).abs() < 1e-15, "{empse:?}");
}

/// A study with very many methods (50,000, one replication each) is
/// summarised in one pass over its rows (methods found by name, the
/// reference indexed once: before, each method rescanned every row and the
/// key drew every method, minutes at 100,000), and simsum.md says why
/// simsum.svg is not drawn.
#[test]
fn a_study_of_very_many_methods_is_summarised_and_says_why_there_is_no_figure() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("many.csv");
    let mut text = String::from("method,rep,estimate,se\n");
    for m in 0..50_000 {
        text += &format!("m{m},1,{},1\n", (m % 7) as f64 / 10.0);
    }
    std::fs::write(&file, text).unwrap();
    let o = simsum(&file, &["--true", "0", "--rep", "rep"], &tmp.path().join("out"));
    assert_ok(&o);
    let md = std::fs::read_to_string(tmp.path().join("out/simsum.md")).unwrap();
    assert!(md.contains("simsum.svg is not drawn: 50000 methods in a group"), "{}", &md[md.len() - 300..]);
    assert!(!tmp.path().join("out/simsum.svg").exists());
    let csv = std::fs::read_to_string(tmp.path().join("out/simsum.csv")).unwrap();
    let bias: Vec<&str> = csv.lines().filter(|l| l.contains(",bias,")).collect();
    assert_eq!(bias.len(), 50_000);
    // m3's estimate 0.3 against the truth 0: bias 0.3.
    assert!(bias.iter().any(|l| l.starts_with("0,0.95,m3,bias,0.3,")), "{:?}", &bias[..4]);
}

/// With `--rep`, a row without a replication id is refused at its row and
/// column, not reported as "an empty id occurring twice".
#[test]
fn an_empty_replication_id_is_refused_where_it_is() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("ids.csv");
    std::fs::write(&file, "method,rep,estimate,se\nA,1,0.5,0.3\nA,,0.4,0.3\nA,,0.6,0.3\n").unwrap();
    let o = simsum(&file, &["--true", "0", "--rep", "rep"], &tmp.path().join("out"));
    crate::common::assert_refused(&o, ":3:2: the replication id is empty");
}

/// Issue 77, class 5: a true value that differs between replications
/// (rsimsum's `true` as a column) is each replication's own in one group,
/// as rsimsum groups by `by` only; it used to split the study into one
/// group per replication. Expected values: scripts/reference/simsum_truth_column.py,
/// rsimsum's formulas (R/performance.R) computed independently in Python,
/// its output committed in scripts/reference/simsum_truth_column.out.
#[test]
fn a_true_value_that_varies_by_replication_is_each_replications_own_in_one_group() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let o =
        simsum(&root().join("tests/fixtures/simsum_truth_column.csv"), &["--true", "true_value", "--rep", "rep"], &out);
    assert_ok(&o);
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(said.contains("the true value differs between this group's replications"), "{said}");
    let mut r = csv::Reader::from_path(out.join("simsum.csv")).unwrap();
    let rows: Vec<csv::StringRecord> = r.records().map(Result::unwrap).collect();
    // One group: every row's true value is NA (no one value).
    assert!(rows.iter().all(|row| &row[0] == "NA"), "{rows:?}");
    let ours = |method: &str, stat: &str| -> (f64, f64) {
        let row = rows.iter().find(|row| &row[2] == method && &row[3] == stat).unwrap();
        let num = |s: &str| if s == "NA" { f64::NAN } else { s.parse::<f64>().unwrap() };
        (num(&row[4]), num(&row[5]))
    };
    let reference = std::fs::read_to_string(root().join("scripts/reference/simsum_truth_column.out")).unwrap();
    let mut compared = 0;
    for line in reference.lines().filter(|l| !l.starts_with('#')) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let (want, want_mcse): (f64, f64) = (f[2].parse().unwrap(), f[3].parse().unwrap());
        let (got, got_mcse) = ours(f[0], f[1]);
        assert!((got - want).abs() <= 1e-12 * want.abs().max(1.0), "{} {}: {got} against {want}", f[0], f[1]);
        if want_mcse.is_nan() {
            assert!(got_mcse.is_nan(), "{} {} MCSE: {got_mcse}", f[0], f[1]);
        } else {
            assert!(
                (got_mcse - want_mcse).abs() <= 1e-12 * want_mcse.abs().max(1.0),
                "{} {} MCSE: {got_mcse} against {want_mcse}",
                f[0],
                f[1]
            );
        }
        compared += 1;
    }
    assert_eq!(compared, 18);
    let md = std::fs::read_to_string(out.join("simsum.md")).unwrap();
    assert!(md.contains("true value each replication's own") && md.contains("add their column to `--by`"), "{md}");
}

/// A replication id twice in a group whose rows have different true
/// values: the refusal says how rsimsum would have the study written (the
/// true value's column among the by-factors).
#[test]
fn ids_repeated_across_true_values_are_told_to_group_by_the_true_value() {
    let tmp = tempfile::tempdir().unwrap();
    let mut args = OWN;
    args[1] = "setting";
    let o = simsum(&root().join("results/coverage_rsimsum/replications.csv"), &args, &tmp.path().join("out"));
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("occurs twice in group") && e.contains("with different true values"), "{e}");
    assert!(e.contains("add the true value's column to the by-factors"), "{e}");
}
