//! Reading a Parquet flight log against its CSV twin: the simulated lab's
//! 21 Parquet logs (`crossaudit simulate-lab`, the fixture of
//! designs/logs/lab.design) and the CSV text crossaudit renders for each
//! (the twin: the same columns, values, content hash and row hashes),
//! read and parsed under the lab design's columns, in one run, one thread:
//!   - Parquet read by column (`data::log::read_log` as `run` reads a log:
//!     the declared columns taken from the decoded values, the text
//!     written for the hashes);
//!   - Parquet read by column, then its text parsed (`io::parquet::to_csv_text`
//!     and the CSV reader, as builds before this one read a log);
//!   - Parquet through parquet's record API (`io::parquet::rows_to_csv_text`,
//!     how every earlier build read it);
//!   - the CSV twin.
//!
//! Median and min of RUNS passes over all 21 files (default 15).
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
    let twins: Vec<PathBuf> = parquet
        .iter()
        .map(|p| {
            let text = crossaudit::data::log::read_bytes(p).expect("parquet log");
            let twin = p.with_extension("csv");
            std::fs::write(&twin, text).expect("write twin");
            twin
        })
        .collect();
    let columns: Vec<String> = [
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
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let schema = Schema::Named { columns, time: Some("timestamp".into()) };
    let options = ParseOptions { hash_rows: true, missing_as_nan: true };
    let parse =
        |name: &Path, bytes: &[u8]| parse_with(&name.display().to_string(), bytes, &schema, options).expect("log");
    let rows: usize = twins.iter().map(|t| parse(t, &std::fs::read(t).unwrap()).rows).sum();
    let bytes = |ps: &[PathBuf]| ps.iter().map(|p| std::fs::metadata(p).unwrap().len()).sum::<u64>() / 1024;
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
    println!(
        "files: {} Parquet logs ({} KiB) and their CSV twins ({} KiB), {rows} rows, 18 declared columns; {runs} passes each (median, min)",
        parquet.len(),
        bytes(&parquet),
        bytes(&twins)
    );
    let time = |f: &dyn Fn()| {
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
    };
    let by_column = time(&|| {
        for p in &parquet {
            crossaudit::data::log::read_log(p, &p.display().to_string(), &schema, options).expect("log");
        }
    });
    let reparsed = time(&|| {
        for p in &parquet {
            parse(p, &crossaudit::data::log::read_bytes(p).unwrap());
        }
    });
    let by_record = time(&|| {
        for p in &parquet {
            let raw = bytes::Bytes::from(std::fs::read(p).unwrap());
            parse(p, &crossaudit::io::parquet::rows_to_csv_text(raw, u64::MAX, "a flight log").unwrap());
        }
    });
    let twin = time(&|| {
        for p in &twins {
            parse(p, &crossaudit::data::log::read_bytes(p).unwrap());
        }
    });
    println!("  Parquet, read by column (this build):          {:7.1} ms, {:7.1} ms", by_column.0, by_column.1);
    println!("  Parquet, by column, text parsed back (before): {:7.1} ms, {:7.1} ms", reparsed.0, reparsed.1);
    println!("  Parquet, through the record API (earlier):     {:7.1} ms, {:7.1} ms", by_record.0, by_record.1);
    println!("  CSV twin:                                      {:7.1} ms, {:7.1} ms", twin.0, twin.1);
    println!(
        "  ratio Parquet by column / CSV twin: {:.2}; text parsed / CSV twin: {:.2}; record API / CSV twin: {:.2}",
        by_column.0 / twin.0,
        reparsed.0 / twin.0,
        by_record.0 / twin.0
    );
    let _ = std::fs::remove_dir_all(&tmp);
}
