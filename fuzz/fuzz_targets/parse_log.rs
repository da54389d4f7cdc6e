//! Any bytes, as a NanoBench flight log: the tokenizer, the header check
//! and every per-row check, keeping every column. Nothing may panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let keep: Vec<usize> = (0..crossaudit::data::log::NANOBENCH_COLUMNS.len()).collect();
    if let Err(e) = crossaudit::data::log::parse("fuzz.csv", data, &keep) {
        let _ = e.to_string();
    }
});
