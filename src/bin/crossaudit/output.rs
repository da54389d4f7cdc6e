//! Printing that cannot panic. `println!` panics when standard output is
//! a closed pipe (`crossaudit check X | head -1`) or a full disk
//! (`> /dev/full`); `out!` and `outln!` return the failure as
//! [`Error::Stdout`] instead, which `main` turns into a quiet end (closed
//! pipe) or a message and a non-zero exit (anything else). `note!` writes
//! a line to standard error and ignores a failure there: there is nowhere
//! left to report it.

use std::io::Write;

use crossaudit::Error;

/// `print!` to standard output; `?`-returns [`Error::Stdout`] on failure.
macro_rules! out {
    ($($arg:tt)*) => { $crate::output::print(format_args!($($arg)*))? };
}

/// `println!` to standard output; `?`-returns [`Error::Stdout`] on failure.
macro_rules! outln {
    ($($arg:tt)*) => { $crate::output::print(format_args!("{}\n", format_args!($($arg)*)))? };
}

/// `eprintln!` that ignores a failure to write standard error.
macro_rules! note {
    ($($arg:tt)*) => { $crate::output::note(format_args!($($arg)*)) };
}

/// `text` with every control character but a line break and a tab shown
/// as its escape: whatever user text a message quotes (a file name, a
/// label, a reason), it cannot drive the terminal. Colored diagnostics
/// are written by [`note_raw`], which keeps crossaudit's own escapes.
pub(crate) fn visible(text: String) -> String {
    match crossaudit::io::escape_controls(&text, &['\n', '\t']) {
        std::borrow::Cow::Borrowed(_) => text,
        std::borrow::Cow::Owned(escaped) => escaped,
    }
}

/// Writes to standard output.
pub fn print(args: std::fmt::Arguments<'_>) -> Result<(), Error> {
    std::io::stdout().lock().write_all(visible(args.to_string()).as_bytes()).map_err(Error::Stdout)
}

/// Flushes standard output: text written without a final newline is
/// still buffered, and a failure must be seen before the exit status is.
pub fn flush() -> Result<(), Error> {
    std::io::stdout().lock().flush().map_err(Error::Stdout)
}

/// Whether standard output was closed when the program started
/// (`crossaudit mixed ... >&-`). Rust's runtime then opens /dev/null
/// read-write as descriptor 1, so every write "succeeds" and a command
/// whose only output is standard output would end with status 0 and its
/// result lost. A shell's `> /dev/null` opens it write-only, so a deliberate
/// discard is not taken for a closed descriptor. Linux only (it reads
/// /proc); elsewhere `false`.
pub fn stdout_closed() -> bool {
    let Ok(target) = std::fs::read_link("/proc/self/fd/1") else { return false };
    if target != std::path::Path::new("/dev/null") {
        return false;
    }
    let Ok(info) = std::fs::read_to_string("/proc/self/fdinfo/1") else { return false };
    // `flags:` is octal; the access mode is its lowest two bits (2: O_RDWR).
    info.lines()
        .find_map(|l| l.strip_prefix("flags:"))
        .and_then(|f| u32::from_str_radix(f.trim(), 8).ok())
        .is_some_and(|flags| flags & 0o3 == 0o2)
}

/// Writes a line to standard error, ignoring a failure.
pub fn note(args: std::fmt::Arguments<'_>) {
    let _ = writeln!(std::io::stderr().lock(), "{}", visible(args.to_string()));
}

/// Writes to standard error, ignoring a failure.
pub fn note_raw(text: &str) {
    let _ = std::io::stderr().lock().write_all(text.as_bytes());
}

/// The report's warnings, one line each on standard error: what `run`,
/// `score`, `combine` and `analyze` all print, as report.md lists them.
pub fn warnings(a: &crossaudit::analysis::StudyAnalysis) {
    for w in a.warnings() {
        note!("warning: {}", crossaudit::io::one_line(w));
    }
}

/// The study's decision line, then each guard the report gives beside the
/// verdict (condition coverage, early stopping, a reference arm that is
/// not disjoint, a fragile decision), one indented line each: the console
/// says what the verdict's contrast measured, as the report does.
pub fn verdict(a: &crossaudit::analysis::StudyAnalysis) -> Result<(), Error> {
    print(format_args!("{}\n", crossaudit::report::study_decision_line(a)))?;
    for g in crossaudit::report::study_guards(a) {
        print(format_args!("  {}\n", visible(g)))?;
    }
    Ok(())
}
