//! [`Label`]: a shared, immutable name (a model, arm, recording, trajectory
//! or speed in a per-cell row). A million rows name a few thousand distinct
//! things; each row holds a pointer to one shared copy of its name instead
//! of five heap strings of its own.

use std::borrow::Borrow;
use std::collections::HashSet;
use std::fmt;
use std::hash::{BuildHasherDefault, Hasher};
use std::ops::Deref;
use std::sync::Arc;

/// A name shared between every row that carries it. It reads as a `str`:
/// it derefs to one, compares equal to one, and prints and serializes as
/// one.
#[derive(Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Label(Arc<Box<str>>);

// One pointer: a row holds five.
const _: () = assert!(std::mem::size_of::<Label>() == std::mem::size_of::<usize>());

impl Label {
    /// The name as a `str`.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl Deref for Label {
    type Target = str;
    fn deref(&self) -> &str {
        &self.0
    }
}

impl AsRef<str> for Label {
    fn as_ref(&self) -> &str {
        &self.0
    }
}

impl Borrow<str> for Label {
    fn borrow(&self) -> &str {
        &self.0
    }
}

impl From<&str> for Label {
    fn from(s: &str) -> Label {
        Label(Arc::new(Box::from(s)))
    }
}

impl From<String> for Label {
    fn from(s: String) -> Label {
        Label(Arc::new(Box::from(s)))
    }
}

impl From<&String> for Label {
    fn from(s: &String) -> Label {
        Label(Arc::new(Box::from(s.as_str())))
    }
}

impl From<Label> for String {
    fn from(l: Label) -> String {
        l.0.to_string()
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

/// Hands out one [`Label`] per distinct name. The last name asked for is
/// checked first: rows of a per-cell file come grouped, so most lookups
/// repeat the row before.
#[derive(Debug, Default)]
pub struct Interner {
    last: Option<Label>,
    seen: HashSet<Label, BuildHasherDefault<NameHasher>>,
}

/// A multiply-rotate hash of a name's bytes, 8 at a time (the Fx hash of
/// rustc): names come from the file being read and are looked up once per
/// row, so the default SipHash, built to resist chosen keys, cost more
/// than the lookup. A file that makes its names collide only slows its
/// own reading.
#[derive(Default)]
struct NameHasher(u64);

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
    /// The shared label for `name`.
    pub fn get(&mut self, name: &str) -> Label {
        if let Some(l) = &self.last {
            if l.as_str() == name {
                return l.clone();
            }
        }
        let l = match self.seen.get(name) {
            Some(l) => l.clone(),
            None => {
                let l = Label::from(name);
                self.seen.insert(l.clone());
                l
            }
        };
        self.last = Some(l.clone());
        l
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_read_as_strings_and_intern_to_one_copy() {
        let mut names = Interner::default();
        let (a, b, c) = (names.get("r01"), names.get("r02"), names.get("r01"));
        assert!(Arc::ptr_eq(&a.0, &c.0));
        assert!(!Arc::ptr_eq(&a.0, &b.0));
        assert_eq!(a, "r01");
        assert_eq!("r02", b);
        assert_eq!(a, "r01".to_string());
        assert!(a < b);
        assert_eq!(format!("{a} {a:?}"), "r01 \"r01\"");
        assert_eq!(serde_json::to_string(&b).unwrap(), "\"r02\"");
        let m: std::collections::BTreeMap<Label, u8> = [(a.clone(), 1)].into();
        assert_eq!(m.get("r01"), Some(&1));
    }
}
