//! Identities minted from structure: a 64-bit FNV-1a hash of the parts that
//! say how an element was made (a generator's seed and the element's
//! construction path, or the identities of a street's end nodes), finished
//! with a splitmix64 mix. Never an array index or a creation order, so the
//! same construction gives the same identity on every run and machine.

use std::fmt;

/// An element's identity (node, street, block, parcel, assignment).
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Id(pub u64);

impl fmt::Debug for Id {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:016x}", self.0)
    }
}

impl fmt::Display for Id {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:016x}", self.0)
    }
}

impl Id {
    /// Starts minting an identity of the given kind ("node", "street", ...).
    pub fn mint(kind: &str) -> Minter {
        Minter::new().str(kind)
    }

    /// Parses the 16-hex-digit form that `Display` writes.
    pub fn parse(s: &str) -> Option<Id> {
        if s.is_empty() || s.len() > 16 {
            return None;
        }
        u64::from_str_radix(s, 16).ok().map(Id)
    }
}

/// A hasher for maps keyed by identities (or other words: a point's
/// bits): the words folded, finished by splitmix64's mix, a few
/// instructions a key. Only for maps that are looked up, never walked in
/// their order (a walk's order would follow the table, not the keys).
#[derive(Debug, Default, Clone, Copy)]
pub struct IdHasher(u64);

impl std::hash::Hasher for IdHasher {
    fn finish(&self) -> u64 {
        mix(self.0)
    }

    fn write(&mut self, bytes: &[u8]) {
        // Not an identity's word (a key of another type): FNV-1a.
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(FNV_PRIME);
        }
    }

    fn write_u64(&mut self, v: u64) {
        self.0 = self.0.wrapping_mul(FNV_PRIME).rotate_left(29) ^ v;
    }
}

/// A hash map keyed by identities ([`IdHasher`]).
pub type IdMap<K, V> = std::collections::HashMap<K, V, std::hash::BuildHasherDefault<IdHasher>>;

/// Builds an identity from parts (each part is length-prefixed, so
/// ("ab","c") and ("a","bc") differ).
#[derive(Debug, Clone)]
pub struct Minter(u64);

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

impl Minter {
    fn new() -> Minter {
        Minter(FNV_OFFSET)
    }

    fn bytes(mut self, b: &[u8]) -> Minter {
        for &x in b {
            self.0 ^= u64::from(x);
            self.0 = self.0.wrapping_mul(FNV_PRIME);
        }
        self
    }

    /// A string part.
    pub fn str(self, s: &str) -> Minter {
        self.u64(s.len() as u64).bytes(s.as_bytes())
    }

    /// An integer part.
    pub fn u64(self, v: u64) -> Minter {
        self.bytes(&v.to_le_bytes())
    }

    /// A signed integer part.
    pub fn i64(self, v: i64) -> Minter {
        self.bytes(&v.to_le_bytes())
    }

    /// Another identity as a part.
    pub fn id(self, id: Id) -> Minter {
        self.u64(id.0)
    }

    /// A coordinate as a part (its exact bits; -0 and 0 alike).
    pub fn f64(self, v: f64) -> Minter {
        let v = if v == 0.0 { 0.0 } else { v };
        self.u64(v.to_bits())
    }

    /// The identity.
    pub fn finish(self) -> Id {
        Id(mix(self.0))
    }
}

/// splitmix64's finaliser.
pub fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A small counter-based stream for the generators (splitmix64 keyed by an
/// identity), so a block's parcels depend only on the block's seed.
#[derive(Debug, Clone)]
pub struct Stream(u64);

impl Stream {
    pub fn new(seed: Id) -> Stream {
        Stream(seed.0)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        mix(self.0)
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_are_length_prefixed_and_ids_round_trip() {
        let a = Id::mint("x").str("ab").str("c").finish();
        let b = Id::mint("x").str("a").str("bc").finish();
        assert_ne!(a, b);
        assert_eq!(Id::parse(&a.to_string()), Some(a));
        assert_eq!(Id::parse("zz"), None);
        assert_eq!(
            Id::mint("n").f64(0.0).finish(),
            Id::mint("n").f64(-0.0).finish()
        );
    }
}
