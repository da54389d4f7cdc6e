//! Coupled draws (`draws coupled`): priority sampling.
//!
//! Every candidate (a recording, or a row of one) gets a key that depends
//! only on the draw's seed, the draw's purpose, the recording's name and
//! the row; a draw of k takes the k smallest keys. Two designs whose data
//! differ (other columns, a dropped or truncated recording) then draw the
//! same candidates wherever those survive: removing one recording of n
//! leaves about (n - 1) / n of a window draw in place, where an independent
//! draw would keep only the share two random subsets have in common.
//!
//! The key, for reimplementation elsewhere:
//! `key = mix(mix(mix(seed ^ mix(tag)) ^ fnv1a64(name)) ^ row)` with
//! `mix` SplitMix64's finalizer (after adding 0x9E3779B97F4A7C15) and
//! `fnv1a64` the 64-bit FNV-1a hash of the name's UTF-8 bytes; ties (never
//! seen) fall back to (name, row).

use super::Window;

/// What a draw is for: each purpose keys its candidates independently.
#[derive(Debug, Clone, Copy)]
pub(super) enum Purpose {
    /// The evaluation recordings (chacha8 only; numpy_legacy keeps numpy's).
    Evaluation = 1,
    /// Rollout starts.
    Starts = 2,
    /// Validation recordings.
    ValidationRecordings = 3,
    /// Validation windows.
    ValidationWindows = 4,
    /// A fit arm's windows.
    Fit = 5,
    /// A derived arm's replaced positions.
    Replaced = 6,
    /// A derived arm's incoming evaluation windows.
    Incoming = 7,
}

/// SplitMix64's output function.
fn mix(z: u64) -> u64 {
    let mut z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// 64-bit FNV-1a.
fn fnv1a(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// The priority key of `row` of recording `name` in a draw.
pub fn key(seed: u64, purpose: u64, name: &str, row: u64) -> u64 {
    mix(mix(mix(seed ^ mix(purpose)) ^ fnv1a(name)) ^ row)
}

/// The candidates `0..n`, named by `name(i)` (and row `row(i)`), ordered by
/// their keys: a draw of k takes the first k.
pub(super) fn order(
    n: usize,
    seed: u64,
    purpose: Purpose,
    name: &dyn Fn(usize) -> String,
    row: &dyn Fn(usize) -> u64,
) -> Vec<usize> {
    let mut keyed: Vec<(u64, String, u64, usize)> = (0..n)
        .map(|i| {
            let (nm, r) = (name(i), row(i));
            (key(seed, purpose as u64, &nm, r), nm, r, i)
        })
        .collect();
    keyed.sort();
    keyed.into_iter().map(|k| k.3).collect()
}

/// `k` windows of `pool` with the smallest keys, returned sorted.
pub(super) fn draw(
    pool: &[Window],
    k: usize,
    seed: u64,
    purpose: Purpose,
    name: &dyn Fn(usize) -> String,
) -> Vec<Window> {
    let by_key = order(pool.len(), seed, purpose, &|i| name(pool[i].recording), &|i| pool[i].t as u64);
    let mut picked: Vec<Window> = by_key.into_iter().take(k).map(|i| pool[i]).collect();
    picked.sort();
    picked
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_depend_on_every_input_and_nothing_else() {
        let k = key(7, 5, "B9_trefoil_slow_rep6", 120);
        assert_eq!(k, key(7, 5, "B9_trefoil_slow_rep6", 120));
        assert_ne!(k, key(8, 5, "B9_trefoil_slow_rep6", 120));
        assert_ne!(k, key(7, 4, "B9_trefoil_slow_rep6", 120));
        assert_ne!(k, key(7, 5, "B9_trefoil_slow_rep7", 120));
        assert_ne!(k, key(7, 5, "B9_trefoil_slow_rep6", 121));
    }

    #[test]
    fn fnv1a_matches_the_published_test_vectors() {
        // FNV-1a 64-bit test vectors (Fowler, Noll, Vo: "a" and "foobar").
        assert_eq!(fnv1a(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a("a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a("foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn removing_a_candidate_keeps_the_rest_of_the_draw() {
        let name = |r: usize| format!("rec{r}");
        let pool: Vec<Window> = (0..50).flat_map(|r| (0..400).map(move |t| Window { recording: r, t })).collect();
        let full = draw(&pool, 2000, 42, Purpose::Fit, &name);
        let fewer: Vec<Window> = pool.iter().copied().filter(|w| w.recording != 17).collect();
        let drawn = draw(&fewer, 2000, 42, Purpose::Fit, &name);
        let kept = full.iter().filter(|w| drawn.binary_search(w).is_ok()).count();
        // One recording of 50 removed: about 1/50 of the draw goes with it.
        assert!(kept as f64 >= 0.96 * full.len() as f64, "kept {kept} of {}", full.len());
        assert!(drawn.iter().all(|w| w.recording != 17));
    }
}
