//! A worker's memo of the covering tubes at open symbols' positions
//! (`CostModel::tubes_near`), so that the tournament's promise
//! (`Guide::order`) and the reach look-ahead, which ask for the tubes of
//! the same open symbols generation after generation (every copy of a
//! particle shares its open symbols), search the curves once per
//! position. A pure memo: an entry is the function's own answer for its
//! key, so results are the same, bit for bit, with or without it, and
//! whatever the thread a particle is advanced on.

use grm_guide::{CostModel, Tubes};

use crate::particle::Near;

/// Entries in the memo (direct-mapped: a new position replaces the one in
/// its slot).
const SLOTS: usize = 512;

/// The key of a position's tubes: the position's bits, eq. 1's curve
/// there and its closest point's parameter (the arguments of
/// `CostModel::tubes_near`, all functions of the position).
type Key = ([u32; 3], u32, u64);

/// A direct-mapped memo of `CostModel::tubes_near` per position.
pub(crate) struct TubesMemo {
    slots: Vec<Option<(Key, Tubes)>>,
}

impl TubesMemo {
    pub fn new() -> TubesMemo {
        TubesMemo {
            slots: vec![None; SLOTS],
        }
    }

    /// `cost.tubes_near` at `n`'s position, from the memo when it has it.
    pub fn tubes_near(&mut self, cost: &CostModel, n: &Near) -> Tubes {
        let p = n.position.to_array().map(f32::to_bits);
        let key: Key = (p, n.curve as u32, n.closest.t.to_bits());
        // FxHash-style mixing of the key's words.
        let mut h: u64 = 0;
        for x in [
            u64::from(p[0]),
            u64::from(p[1]),
            u64::from(p[2]),
            u64::from(key.1),
            key.2,
        ] {
            h = (h.rotate_left(5) ^ x).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
        }
        let slot = (h >> 32) as usize % SLOTS;
        if let Some((k, t)) = &self.slots[slot]
            && *k == key
        {
            return *t;
        }
        let t = cost.tubes_near(n.position.as_dvec3(), (n.curve, &n.closest));
        self.slots[slot] = Some((key, t));
        t
    }
}

impl std::fmt::Debug for TubesMemo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let held = self.slots.iter().filter(|s| s.is_some()).count();
        write!(f, "TubesMemo({held} of {SLOTS})")
    }
}

impl Default for TubesMemo {
    fn default() -> Self {
        TubesMemo::new()
    }
}
