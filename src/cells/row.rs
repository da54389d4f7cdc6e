//! One row of the per-cell CSV, field by field: each value checked and
//! read (trimmed, numbers as `str::parse` reads them, names interned), and
//! the row's own consistency (n_divergent within n_starts, the divergence
//! rate their ratio), each error naming the file, line and field.

use super::{Cell, CellsError, Origin};
use crate::label::{Interner, Label};

/// The cell of the record on line `line` whose fields are `fields`, those
/// of `header_for(has_split, has_dose)`.
pub(crate) fn cell_of(
    name: &str,
    line: u64,
    fields: &[&str],
    has_split: bool,
    has_dose: bool,
    names: &mut Names,
) -> Result<Cell, CellsError> {
    let raw = RawRow::of(fields, has_split, has_dose);
    let mut cell = parse_row(name, line, &raw, names)?;
    let r = Row { name, at: cell.origin };
    if has_split {
        cell.split = Some(r.uint("split", raw.split.unwrap_or(""))?);
    }
    if has_dose {
        let v = raw.dose.unwrap_or("");
        let dose = r.float("dose", v)?;
        if dose > 100.0 {
            return Err(r.fail("dose", v, "exceeds 100 (a percentage)"));
        }
        cell.dose = Some(dose);
    }
    Ok(cell)
}

/// A value as an error quotes it: at most 64 characters, then how long it is.
fn shortened(value: &str) -> String {
    match value.char_indices().nth(64) {
        None => value.to_string(),
        Some((at, _)) => format!("{}... ({} characters)", &value[..at], value.chars().count()),
    }
}

/// A row as text, by column name, borrowed from its record.
struct RawRow<'a> {
    split: Option<&'a str>,
    dose: Option<&'a str>,
    model: &'a str,
    arm: &'a str,
    seed: &'a str,
    recording: &'a str,
    trajectory: &'a str,
    speed: &'a str,
    horizon_s: &'a str,
    n_starts: &'a str,
    n_divergent: &'a str,
    fa_position_rmse_m: &'a str,
    conditional_position_rmse_m: &'a str,
    divergence_rate: &'a str,
    velocity_rmse_mps: &'a str,
    attitude_rmse_deg: &'a str,
}

impl<'a> RawRow<'a> {
    /// The fields of a record whose header was checked to be
    /// `header_for(has_split, has_dose)` (and whose length the reader
    /// checked against it).
    fn of(fields: &[&'a str], has_split: bool, has_dose: bool) -> RawRow<'a> {
        let mut f = fields.iter();
        let mut next = || f.next().copied().unwrap_or("");
        let split = has_split.then(&mut next);
        let (model, arm) = (next(), next());
        let dose = has_dose.then(&mut next);
        RawRow {
            split,
            dose,
            model,
            arm,
            seed: next(),
            recording: next(),
            trajectory: next(),
            speed: next(),
            horizon_s: next(),
            n_starts: next(),
            n_divergent: next(),
            fa_position_rmse_m: next(),
            conditional_position_rmse_m: next(),
            divergence_rate: next(),
            velocity_rmse_mps: next(),
            attitude_rmse_deg: next(),
        }
    }
}

/// One interner per label column: each distinct name is stored once. And
/// the kinds of emptiness the rows read with these names have shown
/// (`Emptiness::kinds`).
#[derive(Default)]
pub(crate) struct Names {
    model: Interner,
    arm: Interner,
    recording: Interner,
    trajectory: Interner,
    speed: Interner,
    pub(crate) kinds: u8,
}

/// Checks fields of one row, naming the file, line and field on error.
pub(crate) struct Row<'a> {
    pub(crate) name: &'a str,
    pub(crate) at: Origin,
}

impl Row<'_> {
    pub(crate) fn fail(&self, field: &'static str, value: &str, problem: impl Into<String>) -> CellsError {
        CellsError::Field {
            path: self.name.to_string(),
            at: self.at,
            field,
            value: shortened(value),
            problem: problem.into(),
        }
    }

    fn label(&self, field: &'static str, v: &str, names: &mut Interner) -> Result<Label, CellsError> {
        let t = trim(v);
        if t.is_empty() {
            return Err(self.fail(field, v, "is empty"));
        }
        // A line break or a terminal escape in a name would be written
        // into every report table and console line that names it. (Text of
        // printable ASCII holds none.)
        let printable = t.bytes().all(|b| (0x20..0x7f).contains(&b));
        if !printable && t.chars().any(char::is_control) {
            return Err(self.fail(field, v, "holds a control character, which no name may"));
        }
        Ok(names.get(t))
    }

    fn uint(&self, field: &'static str, v: &str) -> Result<u64, CellsError> {
        let t = trim(v);
        // At most 19 digits: below 10^19 < 2^64, read at once.
        if (1..=19).contains(&t.len()) && t.bytes().all(|b| b.is_ascii_digit()) {
            return Ok(t.bytes().fold(0u64, |n, b| n * 10 + u64::from(b - b'0')));
        }
        t.parse::<u64>().map_err(|_| {
            let digits = !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit());
            // `25.0`: a whole number written as a float, as pandas writes
            // an integer column once it held a missing value.
            let whole = t.split_once('.').is_some_and(|(n, z)| {
                !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()) && z.bytes().all(|b| b == b'0')
            });
            self.fail(
                field,
                v,
                match (digits, whole) {
                    (true, _) => "is larger than 18446744073709551615, the largest integer a cell holds",
                    (false, true) => "is not a non-negative integer: a whole number written as a float, as pandas writes an integer column that held a missing value (write the column as integers: `df[column].astype(int)`)",
                    (false, false) => "is not a non-negative integer",
                },
            )
        })
    }

    /// A count of rollout starts: at most 4294967295, which a cell holds
    /// in 4 bytes (a design allows 100,000 starts per recording).
    fn count(&self, field: &'static str, v: &str) -> Result<u32, CellsError> {
        let n = self.uint(field, v)?;
        u32::try_from(n).map_err(|_| self.fail(field, v, "is larger than 4294967295, the largest count a cell holds"))
    }

    fn float(&self, field: &'static str, v: &str) -> Result<f64, CellsError> {
        let t = trim(v);
        if let Some(x) = plain_decimal(t) {
            // Finite, not negative, and 0 or at least 1e-15: every check
            // below passes (so none waits on the division).
            return Ok(x);
        }
        if t.is_empty() {
            return Err(self.fail(field, v, "is empty"));
        }
        let x = number(t).ok_or_else(|| self.fail(field, v, "is not a number"))?;
        if !x.is_finite() {
            return Err(self.fail(field, v, "is not finite"));
        }
        if x < 0.0 {
            return Err(self.fail(field, v, "is negative"));
        }
        if x != 0.0 && x < crate::io::MIN_MAGNITUDE {
            return Err(self.fail(
                field,
                v,
                "is below 1e-60 but not 0: the variances of values this small underflow double precision and the interval would collapse to a point; write the metric in a smaller unit",
            ));
        }
        Ok(x)
    }

    /// A metric that may be empty (the velocity and attitude RMSE: empty
    /// when every start diverged, and in every row of a layout without a
    /// velocity or attitude; [`Emptiness`] checks which).
    fn optional(&self, field: &'static str, v: &str) -> Result<Option<f64>, CellsError> {
        if trim(v).is_empty() {
            Ok(None)
        } else {
            self.float(field, v).map(Some)
        }
    }

    /// A metric that is empty exactly when every start diverged.
    fn finite_only(&self, field: &'static str, v: &str, all_diverged: bool) -> Result<Option<f64>, CellsError> {
        if trim(v).is_empty() {
            if all_diverged {
                Ok(None)
            } else {
                Err(self.fail(field, v, "is empty, but not every start diverged"))
            }
        } else {
            self.float(field, v).map(Some)
        }
    }
}

/// `v.trim()`, at once where `v` begins and ends with a printable ASCII
/// character (as nearly every field does).
pub(super) fn trim(v: &str) -> &str {
    let solid = |b: Option<&u8>| b.is_some_and(|&b| (0x21..0x7f).contains(&b));
    if solid(v.as_bytes().first()) && solid(v.as_bytes().last()) {
        v
    } else {
        v.trim()
    }
}

/// The number `t` writes, as Rust's `str::parse::<f64>` reads it (the
/// reference): a plain decimal of at most 15 digits at once
/// ([`plain_decimal`]), then fast-float2, which reads every decimal number
/// to the same correctly rounded value, then the reference for anything
/// it refuses (a test checks all three agree on every string they accept).
pub(super) fn number(t: &str) -> Option<f64> {
    plain_decimal(t).or_else(|| fast_float2::parse::<f64, _>(t).ok()).or_else(|| t.parse().ok())
}

/// Powers of ten that a double holds exactly.
const TENS: [f64; 16] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15];

/// Digits with at most one decimal point and at most 15 digits in all
/// ("0.980943", "250", "1."), as the correctly rounded double; `None` for
/// anything else. Its digits make an integer m below 10^15, exact in a
/// double, and its k decimals a power 10^k, exact too, so m / 10^k, one
/// correctly rounded division, is the correctly rounded value of the
/// decimal: what `str::parse` reads (Clinger's fast path).
fn plain_decimal(t: &str) -> Option<f64> {
    let b = t.as_bytes();
    if b.len() > 16 {
        return None;
    }
    let (mut m, mut digits, mut point) = (0u64, 0usize, None);
    for (i, &c) in b.iter().enumerate() {
        if c.is_ascii_digit() {
            m = m * 10 + u64::from(c - b'0');
            digits += 1;
        } else if c == b'.' && point.is_none() {
            point = Some(i);
        } else {
            return None;
        }
    }
    if digits == 0 || digits > 15 {
        return None;
    }
    let decimals = point.map_or(0, |p| b.len() - p - 1);
    // m < 10^15 < 2^63: converted as a signed integer, one instruction.
    Some(m as i64 as f64 / TENS[decimals])
}

fn parse_row(name: &str, line: u64, raw: &RawRow, names: &mut Names) -> Result<Cell, CellsError> {
    // A cell records its line in 4 bytes (see `Cell`'s size).
    if line > Origin::MAX {
        let message = format!("more than {} lines: the most a per-cell file may hold", Origin::MAX);
        return Err(CellsError::Csv { path: name.to_string(), at: Origin::line(line), message });
    }
    let r = Row { name, at: Origin::line(line) };
    let n_starts = r.count("n_starts", raw.n_starts)?;
    if n_starts == 0 {
        return Err(r.fail("n_starts", raw.n_starts, "must be at least 1"));
    }
    let n_divergent = r.count("n_divergent", raw.n_divergent)?;
    if n_divergent > n_starts {
        return Err(r.fail("n_divergent", raw.n_divergent, format!("exceeds n_starts ({n_starts})")));
    }
    let all_diverged = n_divergent == n_starts;
    let horizon_s = r.float("horizon_s", raw.horizon_s)?;
    if horizon_s <= 0.0 {
        return Err(r.fail("horizon_s", raw.horizon_s, "must be > 0"));
    }
    let divergence_rate = r.float("divergence_rate", raw.divergence_rate)?;
    let expected = f64::from(n_divergent) / f64::from(n_starts);
    if (divergence_rate - expected).abs() > 1e-6 {
        let problem = format!("disagrees with n_divergent / n_starts = {expected}");
        return Err(r.fail("divergence_rate", raw.divergence_rate, problem));
    }
    Ok(Cell {
        split: None,
        dose: None,
        model: r.label("model", raw.model, &mut names.model)?,
        arm: r.label("arm", raw.arm, &mut names.arm)?,
        seed: r.uint("seed", raw.seed)?,
        recording: r.label("recording", raw.recording, &mut names.recording)?,
        trajectory: r.label("trajectory", raw.trajectory, &mut names.trajectory)?,
        speed: r.label("speed", raw.speed, &mut names.speed)?,
        horizon_s,
        n_starts,
        n_divergent,
        fa_position_rmse_m: r.float("fa_position_rmse_m", raw.fa_position_rmse_m)?,
        conditional_position_rmse_m: r.finite_only(
            "conditional_position_rmse_m",
            raw.conditional_position_rmse_m,
            all_diverged,
        )?,
        divergence_rate,
        velocity_rmse_mps: r.optional("velocity_rmse_mps", raw.velocity_rmse_mps)?,
        attitude_rmse_deg: r.optional("attitude_rmse_deg", raw.attitude_rmse_deg)?,
        origin: r.at,
    })
}
