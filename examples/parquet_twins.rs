//! Writes the Parquet twin of each CSV table named: `X.parquet` beside
//! `X.csv`, with the typed columns `crossaudit::io::parquet::csv_to_parquet`
//! gives (what a run writes as `cells.parquet` and a report as
//! `estimates.parquet`, from the same tables). Used once, to give the
//! result folders committed before those files existed their twins
//! (results/INDEX.md).
//!
//!     cargo run --release --example parquet_twins -- results/quickstart/cells.csv ...

fn main() -> std::process::ExitCode {
    let mut failed = false;
    for arg in std::env::args().skip(1) {
        let csv = std::path::PathBuf::from(&arg);
        let written = std::fs::read(&csv)
            .map_err(|e| e.to_string())
            .and_then(|text| crossaudit::io::parquet::csv_to_parquet(&text))
            .and_then(|bytes| {
                crossaudit::io::write_atomic(&csv.with_extension("parquet"), &bytes).map_err(|e| e.to_string())
            });
        if let Err(e) = written {
            eprintln!("error: {arg}: {e}");
            failed = true;
        }
    }
    if failed {
        std::process::ExitCode::FAILURE
    } else {
        std::process::ExitCode::SUCCESS
    }
}
