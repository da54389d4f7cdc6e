//! numpy's legacy `RandomState`, bit for bit: the MT19937 generator seeded by
//! `init_genrand`, and the bounded integers of `random_interval` (a bit mask
//! just covering the bound, 32-bit draws rejected until one falls inside).
//! `permutation(n)` is a Fisher-Yates shuffle of `0..n` from the last
//! position down; `choice(n, k, replace=False)` is the first `k` of
//! `permutation(n)`, as numpy's legacy `choice` does it.
//!
//! This is the generator the paper's split used: over the 106 usable names
//! sorted bytewise, `RandomState(42).permutation(106)[:26]` is its evaluation
//! set. Test vectors come from numpy itself
//! (`scripts/reference/numpy_legacy_vectors.py`).
//!
//! ```
//! use crossaudit::split::RandomState;
//! // numpy: np.random.RandomState(0).permutation(10)
//! assert_eq!(RandomState::new(0).permutation(10), vec![2, 8, 4, 9, 1, 6, 7, 3, 0, 5]);
//! ```

const N: usize = 624;
const M: usize = 397;
const MATRIX_A: u32 = 0x9908_b0df;
const UPPER: u32 = 0x8000_0000;
const LOWER: u32 = 0x7fff_ffff;

/// numpy's legacy `RandomState` (MT19937), restricted to what a split needs.
#[derive(Clone)]
pub struct RandomState {
    key: [u32; N],
    pos: usize,
}

impl std::fmt::Debug for RandomState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RandomState").field("pos", &self.pos).finish_non_exhaustive()
    }
}

impl RandomState {
    /// `RandomState(seed)`: numpy accepts integer seeds 0..=2^32-1 and
    /// seeds MT19937 with `init_genrand`.
    pub fn new(seed: u32) -> RandomState {
        let mut key = [0u32; N];
        let mut s = seed;
        for (pos, k) in key.iter_mut().enumerate() {
            *k = s;
            s = 1_812_433_253u32.wrapping_mul(s ^ (s >> 30)).wrapping_add(pos as u32 + 1);
        }
        RandomState { key, pos: N }
    }

    fn twist(&mut self) {
        for i in 0..N {
            let y = (self.key[i] & UPPER) | (self.key[(i + 1) % N] & LOWER);
            let mag = if y & 1 == 1 { MATRIX_A } else { 0 };
            self.key[i] = self.key[(i + M) % N] ^ (y >> 1) ^ mag;
        }
        self.pos = 0;
    }

    /// The next tempered 32-bit output.
    pub fn next_u32(&mut self) -> u32 {
        if self.pos == N {
            self.twist();
        }
        let mut y = self.key[self.pos];
        self.pos += 1;
        y ^= y >> 11;
        y ^= (y << 7) & 0x9d2c_5680;
        y ^= (y << 15) & 0xefc6_0000;
        y ^ (y >> 18)
    }

    /// A uniform integer in `0..=max` (numpy's `random_interval`).
    pub fn interval(&mut self, max: u64) -> u64 {
        if max == 0 {
            return 0;
        }
        let mut mask = max;
        for shift in [1, 2, 4, 8, 16, 32] {
            mask |= mask >> shift;
        }
        loop {
            let value = if max <= u64::from(u32::MAX) {
                u64::from(self.next_u32()) & mask
            } else {
                let hi = u64::from(self.next_u32());
                ((hi << 32) | u64::from(self.next_u32())) & mask
            };
            if value <= max {
                return value;
            }
        }
    }

    /// `shuffle(x)` in place: for i from len-1 down to 1, swap `x[i]` with
    /// x[interval(i)].
    pub fn shuffle<T>(&mut self, x: &mut [T]) {
        for i in (1..x.len()).rev() {
            let j = self.interval(i as u64) as usize;
            x.swap(i, j);
        }
    }

    /// `permutation(n)`: a shuffled `0..n`.
    pub fn permutation(&mut self, n: usize) -> Vec<usize> {
        let mut v: Vec<usize> = (0..n).collect();
        self.shuffle(&mut v);
        v
    }

    /// `choice(n, k, replace=False)`: the first `k` of `permutation(n)`, in
    /// draw order. `k > n` is the caller's error (numpy raises).
    pub fn choice(&mut self, n: usize, k: usize) -> Vec<usize> {
        let mut v = self.permutation(n);
        v.truncate(k);
        v
    }
}
