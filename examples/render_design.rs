//! Prints the diagnostics (or the plan) of a design file, plain text.
fn main() {
    let path = std::env::args().nth(1).expect("usage: render_design FILE");
    let src = std::fs::read_to_string(&path).expect("readable");
    match crossaudit::design::from_str(&path, &src) {
        Ok(d) => print!("{}", crossaudit::compile(&d).render_text()),
        Err(e) => print!("{}", e.render(false)),
    }
}
