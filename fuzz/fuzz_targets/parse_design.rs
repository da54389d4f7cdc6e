//! Any bytes, as a design: parse, validate, compile and render diagnostics.
//! Nothing may panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        match crossaudit::design::from_str("fuzz.design", text) {
            Ok(design) => {
                let plan = crossaudit::compile(&design);
                let _ = plan.render_text();
            }
            Err(e) => {
                let _ = e.render(false);
                let _ = e.render(true);
            }
        }
    }
});
