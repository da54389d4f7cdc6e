//! `--threads`: the analysis and the readers run on every core, and the
//! same inputs give the same bytes at any thread count.

use std::path::Path;

use crate::common::{crossaudit, said};

/// Every file under `dir`, by its path below it, with its bytes.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let read = |f: std::path::PathBuf| (f.display().to_string(), std::fs::read(dir.join(&f)).unwrap());
    crate::logs::files(dir).into_iter().map(read).collect()
}

/// The reports of `analyze DESIGN --cells CELLS` at 1, 2 and 8 threads.
fn reports(design: &str, cells: &str) -> Vec<Vec<(String, Vec<u8>)>> {
    let tmp = tempfile::tempdir().unwrap();
    [1, 2, 8]
        .iter()
        .map(|n| {
            let out = tmp.path().join(format!("threads-{n}"));
            let threads = n.to_string();
            let o = crossaudit(&[
                "--threads",
                &threads,
                "analyze",
                design,
                "--cells",
                cells,
                "--out",
                out.to_str().unwrap(),
            ]);
            assert!(o.status.success(), "{}", said(&o));
            files(&out)
        })
        .collect()
}

/// The confirmatory analysis (B = 9,999 pigeonhole replicates, grouped,
/// leave-one-out both ways, the optimism's Fieller interval), the same of
/// its cells as Parquet (read a batch of columns on every core), and the
/// 32-specification multiverse (each specification analysed in parallel)
/// give the same report files, byte for byte, at 1, 2 and 8 threads.
#[test]
fn the_reports_are_the_same_at_1_2_and_8_threads() {
    let tmp = tempfile::tempdir().unwrap();
    let parquet = tmp.path().join("nanobench_synthetic.parquet");
    let csv = std::fs::read("examples/cells/nanobench_synthetic.csv").unwrap();
    std::fs::write(&parquet, crossaudit::io::parquet::csv_to_parquet(&csv).unwrap()).unwrap();
    for (design, cells) in [
        ("designs/nanobench_confirmatory.design", "examples/cells/nanobench_synthetic.csv"),
        ("designs/nanobench_confirmatory.design", parquet.to_str().unwrap()),
        ("designs/multiverse/paper_multiverse.design", "results/multiverse/paper"),
    ] {
        let r = reports(design, cells);
        assert!(r[0].len() >= 5, "{design}: {:?}", r[0].iter().map(|f| &f.0).collect::<Vec<_>>());
        assert!(r[0].iter().any(|(name, _)| name.ends_with(".csv")), "{design}: a table is written");
        for (k, n) in [(1, 2), (2, 8)] {
            for (a, b) in r[0].iter().zip(&r[k]) {
                assert_eq!(a.0, b.0, "{design}: the same files at 1 and {n} threads");
                assert!(a.1 == b.1, "{design}: {} differs between 1 and {n} threads", a.0);
            }
            assert_eq!(r[0].len(), r[k].len());
        }
    }
}

/// Zero threads is refused by the argument parser, naming the option.
#[test]
fn zero_threads_are_refused() {
    let o = crossaudit(&["--threads", "0", "check", "designs/nanobench_confirmatory.design"]);
    assert_eq!(o.status.code(), Some(2), "{}", said(&o));
    assert!(said(&o).contains("--threads"), "{}", said(&o));
}
