//! Numbers as text, fast: `f64` and `f32` exactly as Rust's `{:?}` writes
//! them, from the shortest round-trip digits of Żmij (the `zmij` crate,
//! about 2.7 times faster than ryu here; serde_json's own formatter).
//! Both give the shortest digit string that reads back to the same value,
//! the one nearest it; they may differ only in a tie (two shortest strings
//! equally near, as for the float 171404.625: ryu takes the even last
//! digit, Rust the one above), which needs a value whose exact decimal is
//! one digit longer than its shortest string, so there (and for integers
//! past 2^53) Rust writes it. The layout is Rust's: decimal, with at least one digit
//! after the point, for magnitudes in [1e-4, 1e16) and zero, exponential
//! otherwise (`1e-7`, `1.5e16`), `NaN`, `inf` and `-inf`. Tested equal to
//! `format!("{x:?}")` on millions of random values and every boundary.

/// Appends `x` as `format!("{x:?}")` writes it.
pub fn debug_f64(x: f64, out: &mut Vec<u8>) {
    if !x.is_finite() {
        return not_finite(x.is_nan(), x < 0.0, out);
    }
    let a = x.abs();
    let binary = binary(x.to_bits(), (11, 52), a < 9_007_199_254_740_992.0);
    // Żmij's layout is Rust's but in [1e-5, 1e-4), which it writes as a
    // decimal, and from 1e16, where its exponent has a sign (`1e+16`).
    let relayout = (1e-5..1e-4).contains(&a) || a >= 1e16;
    let exponential = x != 0.0 && !(1e-4..1e16).contains(&a);
    let spacing = f64::from_bits(a.to_bits().wrapping_add(1)) - a;
    write(x, binary, Layout { relayout, exponential, spacing }, out);
}

/// Appends `x` as `format!("{x:?}")` writes it.
pub fn debug_f32(x: f32, out: &mut Vec<u8>) {
    if !x.is_finite() {
        return not_finite(x.is_nan(), x < 0.0, out);
    }
    let a = x.abs();
    let binary = binary(u64::from(x.to_bits()), (8, 23), a < 16_777_216.0);
    // Żmij writes an f32 as a decimal in [1e-6, 1e13), Rust in [1e-4,
    // 1e16), and its positive exponents with a sign (`1e+13`).
    let relayout = (1e-6..1e-4).contains(&a) || a >= 1e13;
    let exponential = x != 0.0 && !(1e-4..1e16).contains(&a);
    let spacing = f64::from(f32::from_bits(a.to_bits().wrapping_add(1)) - a);
    write(x, binary, Layout { relayout, exponential, spacing }, out);
}

/// Writes what Rust's `{:?}` writes for a number that is not finite:
/// `NaN` (whatever its sign), `inf`, `-inf`. Each a copy of a constant
/// size, which compiles to a move or two, not a call to `memmove`.
fn not_finite(nan: bool, negative: bool, out: &mut Vec<u8>) {
    match (nan, negative) {
        (true, _) => out.extend_from_slice(b"NaN"),
        (false, false) => out.extend_from_slice(b"inf"),
        (false, true) => out.extend_from_slice(b"-inf"),
    }
}

/// The IEEE 754 number `bits` (an `exponent`-bit exponent and a
/// `fraction`-bit fraction) as (m, e, `exact`): its magnitude is
/// m x 2^e (for a finite number).
fn binary(bits: u64, (exponent, fraction): (u32, u32), exact: bool) -> (u64, i32, bool) {
    let biased = ((bits >> fraction) & ((1 << exponent) - 1)) as i32;
    let frac = bits & ((1 << fraction) - 1);
    // The bias, counted from a whole significand.
    let bias = (1 << (exponent - 1)) - 1 + fraction as i32;
    let (m, e) = if biased == 0 { (frac, 1 - bias) } else { (frac | 1 << fraction, biased - bias) };
    (m, e, exact)
}

/// How Rust lays out a value: `exponential` or not; `relayout`: where
/// Żmij's layout is not that one; `spacing`: the gap to the next value up.
struct Layout {
    relayout: bool,
    exponential: bool,
    spacing: f64,
}

/// Writes the finite number `x`, m x 2^e (`exact`: an integer its type
/// holds exactly), as Rust's `{:?}` does: Żmij's digits laid out as Rust
/// lays them out, or Rust's own text where the two could differ, a
/// possible tie (checked from the digits where the binary form cannot
/// rule one out: a unit of the last digit more than twice the value's
/// spacing does).
fn write<F: zmij::Float + std::fmt::Debug>(x: F, (m, e, exact): (u64, i32, bool), layout: Layout, out: &mut Vec<u8>) {
    let mut buffer = zmij::Buffer::new();
    let shortest = buffer.format_finite(x);
    let tie = tie_possible(m, e, exact);
    if !tie && !layout.relayout {
        return out.extend_from_slice(shortest.as_bytes());
    }
    let d = Digits::of(shortest);
    if tie && d.unit() <= 2.0 * layout.spacing {
        return out.extend_from_slice(format!("{x:?}").as_bytes());
    }
    d.write(layout.exponential, out);
}

/// Whether m x 2^e might be a tie: a value exactly midway between two
/// shortest strings of n digits, so that its exact decimal has n + 1 <=
/// 18 significant digits. An integer held exactly is its own shortest
/// string (no tie). Otherwise, with m odd and e < 0, the exact decimal
/// has floor(log10 |x|) + 1 - e significant digits, and |x| >= 2^top.
fn tie_possible(m: u64, e: i32, exact: bool) -> bool {
    if m == 0 {
        return false;
    }
    let top = e + 63 - m.leading_zeros() as i32;
    let e = e + m.trailing_zeros() as i32;
    if e >= 0 {
        return !exact;
    }
    // floor(top log10 2), one less than the digits of 2^top, in integers
    // (exact for |top| <= 2620; here -1074 <= top < 1024).
    let digits = ((top * 315_653) >> 20) - e;
    digits <= 18
}

/// A finite number as its sign and significant digits D: the value is
/// 0.D x 10^k (no digits: zero).
struct Digits {
    negative: bool,
    digits: [u8; 40],
    n: usize,
    k: i32,
}

impl Digits {
    /// The digits of the text of a finite number (`-1.5e-7`, `1e+16`,
    /// `123.0`, `0.001`).
    fn of(text: &str) -> Digits {
        let (negative, text) = match text.strip_prefix('-') {
            Some(rest) => (true, rest),
            None => (false, text),
        };
        let (mantissa, e) = match text.split_once(['e', 'E']) {
            Some((m, e)) => (m, e.parse::<i32>().unwrap_or(0)),
            None => (text, 0),
        };
        let (int, frac) = mantissa.split_once('.').unwrap_or((mantissa, ""));
        let mut d = Digits { negative, digits: [0u8; 40], n: 0, k: int.len() as i32 + e };
        for &b in int.as_bytes().iter().chain(frac.as_bytes()) {
            if d.n == 0 && b == b'0' {
                d.k -= 1;
            } else if d.n < d.digits.len() {
                d.digits[d.n] = b;
                d.n += 1;
            }
        }
        while d.n > 0 && d.digits[d.n - 1] == b'0' {
            d.n -= 1;
        }
        d
    }

    /// The value of one unit in the last digit: a tie is half a unit from
    /// each string, within half the value's spacing, so a unit of more
    /// than twice the spacing (the margin for `powi`) rules one out.
    fn unit(&self) -> f64 {
        10f64.powi(self.k - self.n as i32)
    }

    /// Writes the number laid out as Rust's `{:?}`.
    fn write(&self, exponential: bool, out: &mut Vec<u8>) {
        let (d, k) = (&self.digits[..self.n], self.k);
        if self.negative {
            out.push(b'-');
        }
        if d.is_empty() {
            out.extend_from_slice(b"0.0");
        } else if exponential {
            out.push(d[0]);
            if d.len() > 1 {
                out.push(b'.');
                out.extend_from_slice(&d[1..]);
            }
            out.push(b'e');
            out.extend_from_slice(itoa::Buffer::new().format(k - 1).as_bytes());
        } else if k <= 0 {
            out.extend_from_slice(b"0.");
            out.resize(out.len() + k.unsigned_abs() as usize, b'0');
            out.extend_from_slice(d);
        } else if (k as usize) < d.len() {
            out.extend_from_slice(&d[..k as usize]);
            out.push(b'.');
            out.extend_from_slice(&d[k as usize..]);
        } else {
            out.extend_from_slice(d);
            out.resize(out.len() + (k as usize - d.len()), b'0');
            out.extend_from_slice(b".0");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tie_possible_f64(x: f64) -> bool {
        let (m, e, exact) = binary(x.to_bits(), (11, 52), x.abs() < 9_007_199_254_740_992.0);
        tie_possible(m, e, exact)
    }

    fn ours64(x: f64) -> String {
        let mut out = Vec::new();
        debug_f64(x, &mut out);
        String::from_utf8_lossy(&out).into_owned()
    }

    fn ours32(x: f32) -> String {
        let mut out = Vec::new();
        debug_f32(x, &mut out);
        String::from_utf8_lossy(&out).into_owned()
    }

    /// The integer floor(top log10 2) is the floating-point one over
    /// every binary exponent of an f64.
    #[test]
    fn the_integer_log10_of_a_power_of_two_is_the_floating_points() {
        for top in -1074..1024 {
            assert_eq!((top * 315_653) >> 20, (f64::from(top) * std::f64::consts::LOG10_2).floor() as i32, "{top}");
        }
    }

    /// Equal to Rust's `{:?}` (the reference) on random bit patterns of
    /// every exponent, on values with few digits (as logs hold), and at
    /// every boundary of the layout.
    #[test]
    fn numbers_are_written_as_rusts_debug_writes_them() {
        // A 64-bit LCG (Knuth's MMIX constants).
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            state
        };
        let mut edges = vec![0.0, -0.0, 1.0, -1.0, 0.1, 1e-4, -1e-4, 1e16, -1e16, 1e15, 1e21, 1e-7, 5e-324];
        edges.extend([f64::MAX, f64::MIN, f64::MIN_POSITIVE, f64::EPSILON, f64::NAN, f64::INFINITY, f64::NEG_INFINITY]);
        edges.extend([-f64::NAN, f64::from_bits(0x7ff0_0000_0000_0001), f64::from_bits(0xfff8_0000_0000_0001)]);
        for e in [1e-4f64, 1e16] {
            edges.extend([e, f64::from_bits(e.to_bits() - 1), f64::from_bits(e.to_bits() + 1)]);
        }
        for k in -30..30 {
            edges.push(10f64.powi(k));
            edges.push(1.5 * 10f64.powi(k));
        }
        // A tie: ryu writes -171404.62, Rust -171404.63.
        edges.push(f64::from(f32::from_bits(0xc8276328)));
        for x in edges {
            assert_eq!(ours64(x), format!("{x:?}"), "{x:e}");
            assert_eq!(ours32(x as f32), format!("{:?}", x as f32), "{x:e} as f32");
        }
        let mut fast = 0;
        for _ in 0..1_000_000 {
            let bits = next();
            let x = f64::from_bits(bits);
            assert_eq!(ours64(x), format!("{x:?}"), "bits {bits:#x}");
            let y = f32::from_bits((bits >> 32) as u32);
            assert_eq!(ours32(y), format!("{y:?}"), "bits {:#x}", bits >> 32);
            // A log's values: few digits, at a scale of 1e-6 to 1e6.
            let z = (next() % 2_000_000) as f64 / 10f64.powi((next() % 13) as i32) - 1e3;
            assert_eq!(ours64(z), format!("{z:?}"), "{z:e}");
            // Short exact decimals, where ties are: an integer over a
            // small power of two.
            let t = (next() >> (next() % 64)) as f64 / f64::from(1u32 << (next() % 24));
            assert_eq!(ours64(t), format!("{t:?}"), "{t:e}");
            assert_eq!(ours32(t as f32), format!("{:?}", t as f32), "{t:e} as f32");
            fast += usize::from(z == 0.0 || !tie_possible_f64(z));
        }
        // Nearly every value a log holds is ruled out as a tie from its
        // binary form alone (the rest, short exact decimals such as
        // 999.5, from their digits).
        assert!(fast > 970_000, "{fast} of 1,000,000 ruled out from the binary form");
    }
}
