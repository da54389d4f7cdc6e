//! [`Label`]: an interned, immutable name (a model, arm, recording,
//! trajectory or speed in a per-cell row). A million rows name a few
//! thousand distinct things; each row holds the number of the one copy of
//! its name instead of five heap strings of its own.
//!
//! Every name is interned once per process, in a table every thread
//! shares (and each thread caches), and kept for the life of the
//! process: a label is a 4-byte number, copied without a reference count
//! and dropped without work, and two labels are equal when they number
//! the same name. The table holds each distinct name once, so what it
//! keeps is bounded by the distinct names read, not by the rows.

use std::borrow::Borrow;
use std::cell::RefCell;
use std::cmp::Ordering;
use std::collections::HashMap;
use std::fmt;
use std::hash::{BuildHasher, BuildHasherDefault, Hash, Hasher};
use std::ops::Deref;
use std::sync::atomic::{AtomicU32, Ordering as Atomic};
use std::sync::{Mutex, OnceLock};

/// A name shared between every row that carries it. It reads as a `str`:
/// it derefs to one, compares equal to one, and prints and serializes as
/// one.
#[derive(Clone, Copy)]
pub struct Label(u32);

// Four bytes: a row holds five (20 bytes, where five pointers took 40).
const _: () = assert!(std::mem::size_of::<Label>() == 4);

impl Label {
    /// The name as a `str`.
    pub fn as_str(&self) -> &'static str {
        let (segment, at) = place(self.0);
        // Set before the label was handed out (see `intern`): a label is
        // only made from a name already in its place.
        NAMES[segment].get().and_then(|s| s[at].get()).copied().unwrap_or_default()
    }

    /// A number that is this name's alone while the process lives (its
    /// place in the table of names): a key that hashes without reading
    /// the name.
    pub fn id(&self) -> usize {
        self.0 as usize
    }
}

/// The names by number, in segments that double: segment k holds
/// `FIRST << k` names, made when the first of them is, so a label's name
/// is found without a lock and no name ever moves. 23 segments number
/// every u32.
const FIRST: usize = 1024;
type Segment = Box<[OnceLock<&'static str>]>;
static NAMES: [OnceLock<Segment>; 23] = [const { OnceLock::new() }; 23];
/// The next name's number.
static NEXT: AtomicU32 = AtomicU32::new(0);

/// By label number, in the same segments as the names: 1 + the number of
/// the label an [`Interner`] was asked for after it last time (0: none
/// yet). Shared by every interner and thread, so a guess one learns serves
/// all, at 4 bytes a name; a guess is compared with the name before it is
/// used, so interners that disagree (a name in two columns) only cost each
/// other a lookup in the table of names.
static AFTER: [OnceLock<Box<[AtomicU32]>>; 23] = [const { OnceLock::new() }; 23];

/// Label `l`'s place in [`AFTER`] (made with its name's segment).
fn after(l: Label) -> Option<&'static AtomicU32> {
    let (segment, at) = place(l.0);
    AFTER[segment].get().and_then(|s| s.get(at))
}

/// Label `n`'s segment and place in it.
fn place(n: u32) -> (usize, usize) {
    let m = n as usize + FIRST;
    let segment = (usize::BITS - 1 - m.leading_zeros()) as usize - FIRST.trailing_zeros() as usize;
    (segment, m - (FIRST << segment))
}

/// Names and their labels, keyed by the name's one copy: a lookup
/// compares names without going through the table of names.
type Names = HashMap<&'static str, Label, BuildHasherDefault<NameHasher>>;

/// The labels of every thread, in shards chosen by the name's hash.
type Shard = Mutex<Names>;
const SHARDS: usize = 64;
static TABLE: OnceLock<Vec<Shard>> = OnceLock::new();

thread_local! {
    /// The labels this thread has used: most lookups take no lock.
    static CACHE: RefCell<Names> = RefCell::default();
}

/// The one label of `name`.
fn intern(name: &str) -> Label {
    // (No cache while the thread's own storage is torn down.)
    if let Ok(Some(l)) = CACHE.try_with(|c| c.borrow().get(name).copied()) {
        return l;
    }
    let table = TABLE.get_or_init(|| (0..SHARDS).map(|_| Shard::default()).collect());
    let hash = BuildHasherDefault::<NameHasher>::default().hash_one(name);
    let mut shard = table[hash as usize % SHARDS].lock().unwrap_or_else(|e| e.into_inner());
    let l = match shard.get(name) {
        Some(l) => *l,
        None => {
            // Four billion names would take more memory than any machine
            // has before the count ran out.
            let n = NEXT
                .fetch_update(Atomic::Relaxed, Atomic::Relaxed, |n| n.checked_add(1))
                .expect("fewer than 2^32 names");
            let (segment, at) = place(n);
            let names = NAMES[segment].get_or_init(|| (0..FIRST << segment).map(|_| OnceLock::new()).collect());
            AFTER[segment].get_or_init(|| (0..FIRST << segment).map(|_| AtomicU32::new(0)).collect());
            // Kept for the life of the process: see the module's notes.
            let copy: &'static str = Box::leak(Box::from(name));
            let _ = names[at].set(copy);
            let l = Label(n);
            shard.insert(copy, l);
            l
        }
    };
    drop(shard);
    let _ = CACHE.try_with(|c| c.borrow_mut().insert(l.as_str(), l));
    l
}

impl PartialEq for Label {
    fn eq(&self, other: &Label) -> bool {
        // One label per name: the same name is the same number.
        self.0 == other.0
    }
}

impl Eq for Label {}

impl Hash for Label {
    fn hash<H: Hasher>(&self, state: &mut H) {
        // As the `str` it borrows as.
        self.as_str().hash(state)
    }
}

impl PartialOrd for Label {
    fn partial_cmp(&self, other: &Label) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Label {
    fn cmp(&self, other: &Label) -> Ordering {
        if self == other {
            return Ordering::Equal;
        }
        self.as_str().cmp(other.as_str())
    }
}

impl Default for Label {
    fn default() -> Label {
        intern("")
    }
}

impl Deref for Label {
    type Target = str;
    fn deref(&self) -> &str {
        self.as_str()
    }
}

impl AsRef<str> for Label {
    fn as_ref(&self) -> &str {
        self.as_str()
    }
}

impl Borrow<str> for Label {
    fn borrow(&self) -> &str {
        self.as_str()
    }
}

impl From<&str> for Label {
    fn from(s: &str) -> Label {
        intern(s)
    }
}

impl From<String> for Label {
    fn from(s: String) -> Label {
        intern(&s)
    }
}

impl From<&String> for Label {
    fn from(s: &String) -> Label {
        intern(s)
    }
}

impl From<Label> for String {
    fn from(l: Label) -> String {
        l.as_str().to_string()
    }
}

impl PartialEq<str> for Label {
    fn eq(&self, other: &str) -> bool {
        self.as_str() == other
    }
}

impl PartialEq<&str> for Label {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

impl PartialEq<String> for Label {
    fn eq(&self, other: &String) -> bool {
        self.as_str() == other.as_str()
    }
}

impl PartialEq<Label> for str {
    fn eq(&self, other: &Label) -> bool {
        self == other.as_str()
    }
}

impl PartialEq<Label> for &str {
    fn eq(&self, other: &Label) -> bool {
        *self == other.as_str()
    }
}

impl PartialEq<Label> for String {
    fn eq(&self, other: &Label) -> bool {
        self.as_str() == other.as_str()
    }
}

impl fmt::Display for Label {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self.as_str(), f)
    }
}

impl fmt::Debug for Label {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self.as_str(), f)
    }
}

impl serde::Serialize for Label {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

/// Hands out the [`Label`] of each name. Rows of a per-cell file come
/// grouped and in repeating orders, so two guesses are tried before the
/// table of names: the name asked for last, then the name that followed
/// it the last time any interner was asked for it (`AFTER`: a
/// recording's successor in a seed's list of recordings). A guess costs
/// one comparison of names.
#[derive(Debug, Default)]
pub struct Interner {
    /// The label asked for last, and its name.
    last: Option<(Label, &'static str)>,
}

/// A multiply-rotate hash of a name's bytes, 8 at a time (the Fx hash of
/// rustc): names come from the file being read and are looked up once per
/// row, so the default SipHash, built to resist chosen keys, cost more
/// than the lookup. A file that makes its names collide only slows its
/// own reading.
#[derive(Default)]
pub(crate) struct NameHasher(u64);

/// Hash maps keyed by names or numbers read from a file, with
/// [`NameHasher`].
pub(crate) type NameHash = BuildHasherDefault<NameHasher>;

impl NameHasher {
    fn add(&mut self, word: u64) {
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
}

impl Hasher for NameHasher {
    fn write(&mut self, bytes: &[u8]) {
        let mut words = bytes.chunks_exact(8);
        for w in &mut words {
            self.add(u64::from_le_bytes([w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]]));
        }
        let mut tail = [0u8; 8];
        tail[..words.remainder().len()].copy_from_slice(words.remainder());
        self.add(u64::from_le_bytes(tail) ^ words.remainder().len() as u64);
    }

    fn write_u8(&mut self, b: u8) {
        self.add(u64::from(b));
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

impl Interner {
    /// The label for `name`.
    pub fn get(&mut self, name: &str) -> Label {
        let Some((last, last_name)) = self.last else {
            return self.remember(intern(name));
        };
        if same(last_name.as_bytes(), name.as_bytes()) {
            return last;
        }
        let after = after(last);
        if let Some(g) = after.and_then(|a| a.load(Atomic::Relaxed).checked_sub(1)).map(Label) {
            let g_name = g.as_str();
            if same(g_name.as_bytes(), name.as_bytes()) {
                self.last = Some((g, g_name));
                return g;
            }
        }
        let l = intern(name);
        // Fits: a label number is below u32::MAX (see `intern`).
        after.inspect(|a| a.store(l.0 + 1, Atomic::Relaxed));
        self.remember(l)
    }

    fn remember(&mut self, l: Label) -> Label {
        self.last = Some((l, l.as_str()));
        l
    }
}

/// Whether `a` and `b` hold the same bytes: a name of at most 16 bytes is
/// compared in two overlapping words (most names here are short: a
/// recording, an arm, a speed), a longer one as slices are.
#[inline(always)]
fn same(a: &[u8], b: &[u8]) -> bool {
    let n = a.len();
    if n != b.len() {
        return false;
    }
    match n {
        0 => true,
        // The first, middle and last bytes are every byte.
        1..=3 => a[0] == b[0] && a[n / 2] == b[n / 2] && a[n - 1] == b[n - 1],
        4..=7 => word::<4>(a, 0) == word::<4>(b, 0) && word::<4>(a, n - 4) == word::<4>(b, n - 4),
        8..=16 => word::<8>(a, 0) == word::<8>(b, 0) && word::<8>(a, n - 8) == word::<8>(b, n - 8),
        _ => a == b,
    }
}

/// The `N` bytes of `s` from `at` (which [`same`] keeps within `s`).
#[inline(always)]
fn word<const N: usize>(s: &[u8], at: usize) -> [u8; N] {
    s.get(at..at + N).and_then(|w| w.try_into().ok()).unwrap_or([0; N])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_read_as_strings_and_intern_to_one_copy() -> Result<(), Box<dyn std::error::Error>> {
        let mut names = Interner::default();
        let (a, b, c) = (names.get("r01"), names.get("r02"), names.get("r01"));
        assert!(a.0 == c.0 && a.0 == Label::from("r01").0);
        assert!(a.0 != b.0 && a != b);
        assert_eq!(a, "r01");
        assert_eq!("r02", b);
        assert_eq!(a, "r01".to_string());
        assert!(a < b);
        assert_eq!(format!("{a} {a:?}"), "r01 \"r01\"");
        assert_eq!(serde_json::to_string(&b)?, "\"r02\"");
        let m: std::collections::BTreeMap<Label, u8> = [(a, 1)].into();
        assert_eq!(m.get("r01"), Some(&1));
        Ok(())
    }

    /// Every number has one place: the segments follow each other with
    /// no gap or overlap, up to the last u32.
    #[test]
    fn the_segments_number_every_u32_once() {
        assert_eq!(place(0), (0, 0));
        assert_eq!(place(1023), (0, 1023));
        assert_eq!(place(1024), (1, 0));
        assert_eq!(place(3071), (1, 2047));
        assert_eq!(place(3072), (2, 0));
        for k in 1..NAMES.len() {
            // The first of segment k follows the last of segment k - 1.
            let first = (FIRST << k) - FIRST;
            assert_eq!(place(first as u32), (k, 0));
            assert_eq!(place(first as u32 - 1), (k - 1, (FIRST << (k - 1)) - 1));
        }
        let (segment, at) = place(u32::MAX);
        assert!(segment < NAMES.len() && at < FIRST << segment);
    }

    /// Names compared in words are equal exactly when their bytes are:
    /// every length from 0 to 20, each byte changed in turn.
    #[test]
    fn names_compare_equal_exactly_when_their_bytes_are() {
        for n in 0..=20usize {
            let a: Vec<u8> = (0..n).map(|k| b'a' + k as u8).collect();
            assert!(same(&a, &a.clone()));
            for k in 0..n {
                let mut b = a.clone();
                b[k] ^= 0x20;
                assert!(!same(&a, &b), "length {n}, byte {k}");
            }
            assert!(!same(&a, &a[..n.saturating_sub(1)]) || n == 0);
        }
    }

    /// The interners' guesses never hand out a wrong label: names in
    /// repeating orders, broken orders and runs, asked of two interners
    /// that teach the shared guesses different successors.
    #[test]
    fn an_interner_gives_each_name_its_label_whatever_the_order() {
        let names: Vec<String> = (0..50).map(|k| format!("guess-test-{}", k % 17)).collect();
        let mut interners = [Interner::default(), Interner::default()];
        for round in 0..12usize {
            let interner = &mut interners[round % 2];
            for k in 0..names.len() {
                // In order, reversed, strided and repeated.
                let at = match round % 3 {
                    0 => k,
                    1 => names.len() - 1 - k,
                    _ => (k * 7 + round) % names.len(),
                };
                for _ in 0..1 + (k + round) % 2 {
                    let l = interner.get(&names[at]);
                    assert_eq!(l.as_str(), names[at]);
                    assert_eq!(l.0, Label::from(names[at].as_str()).0);
                }
            }
        }
    }

    /// Threads interning the same names at once get the same labels: one
    /// copy per name, whichever thread made it.
    #[test]
    fn threads_share_one_label_per_name() {
        let names: Vec<String> = (0..2000).map(|k| format!("thread-test-{k}")).collect();
        let per_thread: Vec<Vec<Label>> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..8)
                .map(|t| {
                    let names = &names;
                    // Each thread in its own order, half through an
                    // interner (whose guesses the threads share).
                    s.spawn(move || {
                        let mut interner = Interner::default();
                        // Twice: the second time, with guesses learnt.
                        (0..2 * names.len())
                            .map(|k| {
                                let name = names[(k * 7 + t * 13) % names.len()].as_str();
                                if t % 2 == 0 {
                                    Label::from(name)
                                } else {
                                    interner.get(name)
                                }
                            })
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            // A thread that panicked fails the test with its message.
            handles.into_iter().map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))).collect()
        });
        for (t, labels) in per_thread.iter().enumerate() {
            for (k, l) in labels.iter().enumerate() {
                let name = &names[(k * 7 + t * 13) % names.len()];
                assert_eq!(l.as_str(), name);
                assert_eq!(l.0, Label::from(name.as_str()).0, "{name} in thread {t}");
            }
        }
    }
}
