//! Any bytes, as a per-cell CSV: the reader's row checks and then the
//! whole analysis under a small design (value checks against the design,
//! completeness, the crossed estimator). Nothing may panic.
#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;

fn plan() -> &'static crossaudit::Plan {
    static PLAN: OnceLock<crossaudit::Plan> = OnceLock::new();
    PLAN.get_or_init(|| {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/designs/minimal.design");
        let file = crossaudit::design::load(std::path::Path::new(path)).expect("the minimal design is valid");
        crossaudit::compile(&file.design)
    })
}

fuzz_target!(|data: &[u8]| {
    match crossaudit::cells::read_cells_from("fuzz.csv", data) {
        Ok(cells) => {
            if let Err(e) = crossaudit::analysis::analyze(plan(), &cells, Default::default()) {
                let _ = e.to_string();
            }
        }
        Err(e) => {
            let _ = e.to_string();
        }
    }
});
