//! Reading a Parquet flight log against its CSV twin, in one run, one
//! thread, under two headers:
//!   - the simulated lab's 21 Parquet logs (`crossaudit simulate-lab`, the
//!     fixture of designs/logs/lab.design) under the lab design's 18
//!     named columns;
//!   - NanoBench's first 20 real logs (../shared/nanobench/recordings,
//!     where present) written as Parquet (`io::parquet::csv_to_parquet`),
//!     under NanoBench's header (52 columns, every field checked as a
//!     number, 18 of them read);
//!
//! each against the CSV text crossaudit renders for it (the twin: the same
//! columns, values, content hash and row hashes, checked here; NanoBench's
//! own gzipped CSV, whose numbers are written with other digits, gives
//! them too):
//!   - Parquet read by column (`data::log::read_log` as `run` reads a log:
//!     the declared columns taken from the decoded values, the hashes
//!     those values' own, its text never written);
//!   - Parquet read by column, then its text parsed (`io::parquet::to_csv_text`
//!     and the CSV reader, as builds before 2026-12-07 read one under
//!     NanoBench's header);
//!   - Parquet through parquet's record API (`io::parquet::rows_to_csv_text`,
//!     how every earlier build read it; the lab's logs only);
//!   - the CSV twin.
//!
//! Median and min of RUNS passes over all the files (default 15).
//!
//!     cargo bench --bench parquet_logs [-- RUNS]

use std::path::{Path, PathBuf};
use std::time::Instant;

use crossaudit::data::log::{parse_with, ParseOptions, Schema};

fn main() {
    let runs: usize = std::env::args().skip(1).find_map(|a| a.parse().ok()).unwrap_or(15);
    let tmp = std::env::temp_dir().join(format!("crossaudit-parquet-logs-{}", std::process::id()));
    crossaudit::sim::simulate_lab(&tmp, 7).expect("simulate the lab");
    let parquet: Vec<PathBuf> = ["train", "test"]
        .iter()
        .flat_map(|d| std::fs::read_dir(tmp.join(d)).expect("lab folder").map(|e| e.expect("entry").path()))
        .filter(|p| p.extension().is_some_and(|e| e == "parquet"))
        .collect();
    let twins = write_twins(&parquet);
    let lab_columns = [
        "timestamp",
        "pos_x",
        "pos_y",
        "pos_z",
        "vel_x",
        "vel_y",
        "vel_z",
        "quat_w",
        "quat_x",
        "quat_y",
        "quat_z",
        "ref_x",
        "ref_y",
        "ref_z",
        "cmd_m1",
        "cmd_m2",
        "cmd_m3",
        "cmd_m4",
    ];
    let columns = lab_columns.iter().map(|s| s.to_string()).collect();
    let schema = Schema::Named { columns, time: Some("timestamp".into()) };
    println!(
        "machine: {}; 1 thread",
        std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|c| c.lines().find(|l| l.starts_with("model name")).map(|l| l
                .split(':')
                .nth(1)
                .unwrap_or("")
                .trim()
                .to_string()))
            .unwrap_or_default()
    );
    compare("Parquet logs", &parquet, &twins, &schema, runs, true);
    let recordings = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/nanobench/recordings");
    let mut logs: Vec<PathBuf> = std::fs::read_dir(&recordings)
        .map(|d| d.flatten().map(|e| e.path()).filter(|p| p.to_string_lossy().ends_with(".csv.gz")).collect())
        .unwrap_or_default();
    logs.sort();
    logs.truncate(20);
    if logs.is_empty() {
        println!("NanoBench's header: {} is absent, not measured", recordings.display());
    } else {
        let dir = tmp.join("nanobench");
        std::fs::create_dir_all(&dir).expect("scratch folder");
        let parquet: Vec<PathBuf> = logs
            .iter()
            .map(|log| {
                let text = crossaudit::data::log::read_bytes(log).expect("NanoBench log");
                let stem = log.file_name().unwrap().to_string_lossy().trim_end_matches(".csv.gz").to_string();
                let path = dir.join(format!("{stem}.parquet"));
                std::fs::write(&path, crossaudit::io::parquet::csv_to_parquet(&text).expect("as Parquet"))
                    .expect("write Parquet");
                path
            })
            .collect();
        let twins = write_twins(&parquet);
        // Time, position and quaternion (columns 0-7), velocity and the
        // motion capture's body rates (11-16), the four motors (23-26).
        let read = (0..8).chain(11..17).chain(23..27).collect();
        let schema = Schema::Nanobench(read);
        // NanoBench's own text (nine digits after the point, `0.015879000`
        // where the twin writes `0.015879`) holds the same values: the
        // same hashes.
        let options = ParseOptions { hash_rows: true, missing_as_nan: true };
        for (log, p) in logs.iter().zip(&parquet) {
            let log_of = |f: &Path| crossaudit::data::log::read_log(f, "log", &schema, options).expect("log");
            let (own, ours) = (log_of(log), log_of(p));
            assert!((own.content_hash, own.row_hashes) == (ours.content_hash, ours.row_hashes), "{}", log.display());
        }
        compare("NanoBench logs as Parquet (NanoBench's header, 52 columns)", &parquet, &twins, &schema, runs, false);
    }
    let _ = std::fs::remove_dir_all(&tmp);
}

/// Each Parquet log's CSV twin beside it: the text crossaudit renders for it.
fn write_twins(parquet: &[PathBuf]) -> Vec<PathBuf> {
    parquet
        .iter()
        .map(|p| {
            let text = crossaudit::data::log::read_bytes(p).expect("parquet log");
            let twin = p.with_extension("csv");
            std::fs::write(&twin, text).expect("write twin");
            twin
        })
        .collect()
}

/// The median and min of `runs` timings of `f` (after one unmeasured), in ms.
fn time(runs: usize, f: &dyn Fn()) -> (f64, f64) {
    f();
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    (t[t.len() / 2], t[0])
}

/// `parquet` read every way against `twins` under `schema`, printed
/// (`record_api`: through parquet's record API too).
fn compare(what: &str, parquet: &[PathBuf], twins: &[PathBuf], schema: &Schema, runs: usize, record_api: bool) {
    let options = ParseOptions { hash_rows: true, missing_as_nan: true };
    let parse =
        |name: &Path, bytes: &[u8]| parse_with(&name.display().to_string(), bytes, schema, options).expect("log");
    let rows: usize = twins.iter().map(|t| parse(t, &std::fs::read(t).unwrap()).rows).sum();
    let bytes = |ps: &[PathBuf]| ps.iter().map(|p| std::fs::metadata(p).unwrap().len()).sum::<u64>() / 1024;
    let declared = match schema {
        Schema::Named { columns, .. } => columns.len(),
        Schema::Nanobench(keep) => keep.len(),
    };
    println!(
        "{what}: {} Parquet logs ({} KiB) and their CSV twins ({} KiB), {rows} rows, {declared} declared columns; {runs} passes each (median, min)",
        parquet.len(),
        bytes(parquet),
        bytes(twins)
    );
    let by_column = time(runs, &|| {
        for p in parquet {
            crossaudit::data::log::read_log(p, &p.display().to_string(), schema, options).expect("log");
        }
    });
    let reparsed = time(runs, &|| {
        for p in parquet {
            parse(p, &crossaudit::data::log::read_bytes(p).unwrap());
        }
    });
    let twin = time(runs, &|| {
        for p in twins {
            parse(p, &crossaudit::data::log::read_bytes(p).unwrap());
        }
    });
    // The twin's log is the Parquet log: the same values, content hash
    // and row hashes.
    for (p, t) in parquet.iter().zip(twins) {
        let log = crossaudit::data::log::read_log(p, &p.display().to_string(), schema, options).expect("log");
        let twin = parse(t, &std::fs::read(t).unwrap());
        let bits =
            |c: &[Vec<f64>]| c.iter().map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>()).collect::<Vec<_>>();
        assert!(bits(&log.columns) == bits(&twin.columns), "{}: values", p.display());
        assert!((&log.content_hash, &log.row_hashes) == (&twin.content_hash, &twin.row_hashes), "{}", p.display());
    }
    println!("  Parquet, read by column (this build):          {:7.1} ms, {:7.1} ms", by_column.0, by_column.1);
    println!("  Parquet, by column, text parsed back (before): {:7.1} ms, {:7.1} ms", reparsed.0, reparsed.1);
    let mut ratios = format!(
        "  ratio Parquet by column / CSV twin: {:.2}; text parsed / CSV twin: {:.2}",
        by_column.0 / twin.0,
        reparsed.0 / twin.0
    );
    if record_api {
        let by_record = time(runs, &|| {
            for p in parquet {
                let raw = bytes::Bytes::from(std::fs::read(p).unwrap());
                parse(p, &crossaudit::io::parquet::rows_to_csv_text(raw, u64::MAX, "a flight log").unwrap());
            }
        });
        println!("  Parquet, through the record API (earlier):     {:7.1} ms, {:7.1} ms", by_record.0, by_record.1);
        ratios += &format!("; record API / CSV twin: {:.2}", by_record.0 / twin.0);
    }
    println!("  CSV twin:                                      {:7.1} ms, {:7.1} ms", twin.0, twin.1);
    println!("{ratios}");
}
