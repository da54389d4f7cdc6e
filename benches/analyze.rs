//! `analyze` on a paper-size per-cell file: 26 recordings x 20 seeds x 2
//! models x 2 arms x 3 horizons = 6,240 rows, B = 9,999 pigeonhole
//! replicates for each of the 6 endpoint units and 3 interactions.
//!
//!     cargo bench --bench analyze
//!
//! The whole-process figure (start-up, CSV read, analysis, three report
//! files) is measured by benches/analyze_process.py.

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let design = root.join("designs/nanobench_confirmatory.design");
    let cells_path = root.join("examples/cells/nanobench_synthetic.csv");
    let file = crossaudit::design::load(&design).expect("design");
    let plan = crossaudit::compile(&file.design);
    let cells = crossaudit::cells::read_cells(&cells_path).expect("cells");
    assert_eq!(cells.len(), 6240);
    let mut g = c.benchmark_group("analyze");
    g.sample_size(20);
    g.bench_function("read_cells_6240_rows", |b| b.iter(|| crossaudit::cells::read_cells(&cells_path).unwrap()));
    g.bench_function("analyze_6240_rows_b9999", |b| {
        b.iter(|| crossaudit::analyze(&plan, &cells, Default::default()).unwrap())
    });
    g.bench_function("analyze_files_plus_reports", |b| {
        let dir = std::env::temp_dir().join("crossaudit-bench-report");
        b.iter(|| {
            let a = crossaudit::analyze_files(&design, &cells_path, Default::default()).unwrap();
            crossaudit::report::write_all(&a, &dir).unwrap();
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
