//! The class of an edit after a derivation (Lipp, 3.2.2). The engines
//! compute it while they replay the edits; this is only its definition.

use std::fmt;

/// How an edit fared in the last derivation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum EditClass {
    /// Its target names the part(s) it named, and its operation applies.
    Valid,
    /// Its place does not exist now (floor 12 of a 10-floor facade): a
    /// prefix of its path matches but an edge number is past the children
    /// there. Kept dormant; it applies again when the place comes back.
    StructurallyInvalid,
    /// Its target no longer fits the model: the path leads nowhere (a label
    /// that is not there) or to a part of another symbol or other tags.
    SemanticallyInvalid,
    /// It matches more parts than it did, or an exact or key target
    /// matches more than one.
    Ambiguous,
    /// Its operation names a rule, alternative, parameter, material or
    /// mesh that is gone.
    Stale,
}

impl EditClass {
    pub const ALL: &'static [EditClass] = &[
        EditClass::Valid,
        EditClass::StructurallyInvalid,
        EditClass::SemanticallyInvalid,
        EditClass::Ambiguous,
        EditClass::Stale,
    ];

    /// The class's name in output (`grmc edits check --format json`, the
    /// editor): `valid`, `structurally_invalid`, `semantically_invalid`,
    /// `ambiguous`, `stale`.
    pub fn as_str(self) -> &'static str {
        match self {
            EditClass::Valid => "valid",
            EditClass::StructurallyInvalid => "structurally_invalid",
            EditClass::SemanticallyInvalid => "semantically_invalid",
            EditClass::Ambiguous => "ambiguous",
            EditClass::Stale => "stale",
        }
    }

    pub fn from_name(s: &str) -> Option<EditClass> {
        EditClass::ALL.iter().copied().find(|c| c.as_str() == s)
    }

    /// One line saying what the class means.
    pub fn explanation(self) -> &'static str {
        match self {
            EditClass::Valid => "the edit finds its part and applies",
            EditClass::StructurallyInvalid => {
                "the edit's place does not exist now; it is kept dormant and applies again if the place comes back"
            }
            EditClass::SemanticallyInvalid => {
                "the edit's target no longer fits the model (no such path, or a part of another kind there)"
            }
            EditClass::Ambiguous => {
                "the edit's target matches more parts than it did, or more than one for an exact or key target"
            }
            EditClass::Stale => {
                "the edit's operation names a rule, alternative, parameter, material or mesh that is gone"
            }
        }
    }

    /// Whether an edit of this class is valid (the others are reported).
    pub fn is_valid(self) -> bool {
        self == EditClass::Valid
    }
}

impl fmt::Display for EditClass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::EditClass;

    #[test]
    fn names_round_trip_and_explain() {
        for &c in EditClass::ALL {
            assert_eq!(EditClass::from_name(c.as_str()), Some(c));
            assert!(!c.explanation().is_empty());
            assert!(!c.explanation().contains('\n'));
        }
        assert_eq!(EditClass::from_name("bogus"), None);
        assert!(EditClass::Valid.is_valid() && !EditClass::Stale.is_valid());
    }
}
