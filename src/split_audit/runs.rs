//! Long runs of identical rows shared by two recordings.
//!
//! Every window of `k` consecutive row hashes of every recording gets a
//! rolling hash; windows with equal hashes in two recordings put their
//! offset (a diagonal) on a candidate list, and each candidate diagonal is
//! then walked row by row, comparing the row hashes themselves, to find its
//! maximal runs. A run of `k` or more identical rows always contains a
//! matching window, so none is missed; a window-hash collision only costs a
//! walk that finds nothing long.

use std::collections::{BTreeMap, BTreeSet};

/// The longest run shared by recordings `a` and `b` (the caller's indices).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Run {
    /// One recording.
    pub a: usize,
    /// The other.
    pub b: usize,
    /// First row of the run in `a` (0-based).
    pub start_a: usize,
    /// First row of the run in `b`.
    pub start_b: usize,
    /// Its length, rows.
    pub rows: usize,
}

/// Odd multiplier of the rolling polynomial hash (the 64-bit FNV prime).
const BASE: u64 = 0x0000_0100_0000_01b3;

/// At most this many positions of one recording per window hash take part
/// (a recording repeating one window many times adds nothing new).
const PER_RECORDING: usize = 8;

/// `base^exp` modulo 2^64, by squaring: what `exp` wrapping
/// multiplications give, in 64 steps at most.
fn wrapping_pow(mut base: u64, mut exp: u64) -> u64 {
    let mut out = 1u64;
    while exp > 0 {
        if exp & 1 == 1 {
            out = out.wrapping_mul(base);
        }
        base = base.wrapping_mul(base);
        exp >>= 1;
    }
    out
}

/// For every pair of recordings (`id`, row hashes) that `eligible(id_a,
/// id_b)` admits, their longest shared run of at least `k` identical rows;
/// pairs without one are left out. Sorted by the pair.
pub fn longest_shared(recs: &[(usize, &[u64])], k: usize, eligible: &dyn Fn(usize, usize) -> bool) -> Vec<Run> {
    let k = k.max(1);
    if recs.iter().all(|(_, h)| h.len() < k) {
        // No recording holds a window: nothing to find (and `--min-run`
        // may be any number up to 2^64 - 1).
        return Vec::new();
    }
    let top = wrapping_pow(BASE, k as u64 - 1);
    let mut windows: Vec<(u64, u32, u32)> = Vec::new();
    for (r, (_, h)) in recs.iter().enumerate() {
        if h.len() < k {
            continue;
        }
        let mut w = h[..k].iter().fold(0u64, |acc, &x| acc.wrapping_mul(BASE).wrapping_add(x));
        windows.push((w, r as u32, 0));
        for p in 1..=h.len() - k {
            w = w.wrapping_sub(h[p - 1].wrapping_mul(top)).wrapping_mul(BASE).wrapping_add(h[p + k - 1]);
            windows.push((w, r as u32, p as u32));
        }
    }
    windows.sort_unstable();
    let mut diagonals: BTreeSet<(usize, usize, isize)> = BTreeSet::new();
    let mut i = 0;
    while i < windows.len() {
        let j = i + windows[i..].iter().take_while(|w| w.0 == windows[i].0).count();
        let bucket = &windows[i..j];
        if bucket.first().map(|w| w.1) != bucket.last().map(|w| w.1) {
            let mut kept: Vec<(usize, usize)> = Vec::new();
            let mut per = 0;
            for (n, w) in bucket.iter().enumerate() {
                per = if n > 0 && bucket[n - 1].1 == w.1 { per + 1 } else { 0 };
                if per < PER_RECORDING {
                    kept.push((w.1 as usize, w.2 as usize));
                }
            }
            for (x, &(ra, pa)) in kept.iter().enumerate() {
                for &(rb, pb) in kept[x + 1..].iter().filter(|(rb, _)| *rb != ra) {
                    if eligible(recs[ra].0, recs[rb].0) {
                        diagonals.insert((ra, rb, pa as isize - pb as isize));
                    }
                }
            }
        }
        i = j;
    }
    let mut best: BTreeMap<(usize, usize), Run> = BTreeMap::new();
    for (ra, rb, d) in diagonals {
        let (ha, hb) = (recs[ra].1, recs[rb].1);
        // Rows pa in a and pb = pa - d in b.
        let mut pa = d.max(0) as usize;
        let mut run = 0;
        while pa < ha.len() && ((pa as isize - d) as usize) < hb.len() {
            let pb = (pa as isize - d) as usize;
            run = if ha[pa] == hb[pb] { run + 1 } else { 0 };
            if run >= k {
                let entry = best.entry((ra, rb)).or_insert(Run { a: 0, b: 0, start_a: 0, start_b: 0, rows: 0 });
                if run > entry.rows {
                    *entry =
                        Run { a: recs[ra].0, b: recs[rb].0, start_a: pa + 1 - run, start_b: pb + 1 - run, rows: run };
                }
            }
            pa += 1;
        }
    }
    best.into_values().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_longest_shared_run_and_nothing_shorter() {
        // b copies rows 10..60 of a at its rows 5..55, and 3 more rows elsewhere.
        let a: Vec<u64> = (0..100).collect();
        let mut b: Vec<u64> = (1000..1100).collect();
        b[5..55].copy_from_slice(&a[10..60]);
        b[80..83].copy_from_slice(&a[0..3]);
        let c: Vec<u64> = (2000..2100).collect();
        let recs = [(7, a.as_slice()), (8, b.as_slice()), (9, c.as_slice())];
        let runs = longest_shared(&recs, 20, &|_, _| true);
        assert_eq!(runs, vec![Run { a: 7, b: 8, start_a: 10, start_b: 5, rows: 50 }]);
        assert!(longest_shared(&recs, 51, &|_, _| true).is_empty());
        assert!(longest_shared(&recs, 20, &|_, _| false).is_empty());
        // Issue 30: `--min-run 18446744073709551615` looped 2^64 times.
        assert!(longest_shared(&recs, usize::MAX, &|_, _| true).is_empty());
    }

    #[test]
    fn wrapping_pow_is_repeated_wrapping_multiplication() {
        for e in [0u64, 1, 2, 3, 19, 64, 99] {
            let slow = (0..e).fold(1u64, |p, _| p.wrapping_mul(BASE));
            assert_eq!(wrapping_pow(BASE, e), slow, "exponent {e}");
        }
    }
}
