//! Building edits on parcels (issue 29 with the persistent edits of issue
//! 27; docs/layout.md, "Building edits"): an edit of the edits file
//! (`grm_edits`, docs/edits.md) that carries a `parcel` (the parcel's
//! identity) belongs to the building grown on that one parcel. The city
//! ([`crate::city::city_edited`]) replays a parcel's edits inside its
//! building's derivation (`grm_grow::shape::grow_on_lot_with_edits`, the
//! engine's replay), so they survive any layout change that keeps the
//! parcel: a kept parcel has the same identity, and so the same edits.
//! An edit whose parcel is gone (moved streets regrew or removed it),
//! whose parcel grows no building (`building: false`), or that names a
//! system other than the one the parcels grow is reported
//! ([`EditIssue`], R1032) and applied to no building: never to another
//! parcel.

use std::collections::BTreeMap;

use grm_edits::{Edit, EditsFile};

use crate::id::Id;

/// The building edits of an edits file, by parcel (edits without a
/// `parcel` are the system's own and are left out; each parcel's in the
/// file's order).
pub fn by_parcel(file: &EditsFile) -> BTreeMap<Id, Vec<&Edit>> {
    let mut m: BTreeMap<Id, Vec<&Edit>> = BTreeMap::new();
    for e in &file.edits {
        if let Some(p) = e.parcel {
            m.entry(Id(p)).or_default().push(e);
        }
    }
    m
}

/// Why a building edit applies nowhere.
#[derive(Debug, Clone, PartialEq)]
pub enum Unplaced {
    /// The layout has no parcel of this identity (any more).
    ParcelGone,
    /// The parcel is tagged `building: false`: nothing grows on it.
    NoBuilding,
    /// The edit names `system`, the parcels grow `grown`.
    OtherSystem { system: String, grown: String },
}

/// A building edit that was not applied (R1032).
#[derive(Debug, Clone, PartialEq)]
pub struct EditIssue {
    /// The edit's id in the edits file.
    pub edit: u32,
    pub parcel: Id,
    pub why: Unplaced,
}

impl EditIssue {
    pub fn diag_code(&self) -> grm_diag::Code {
        grm_diag::Code::BuildingEditUnplaced
    }

    /// The stable code as written.
    pub fn code(&self) -> String {
        self.diag_code().as_str().to_string()
    }

    pub fn describe(&self) -> String {
        let (e, p) = (self.edit, self.parcel);
        match &self.why {
            Unplaced::ParcelGone => format!(
                "edit {e}: parcel {p} is not in the layout (the change regrew or removed it); the edit is applied to no building"
            ),
            Unplaced::NoBuilding => format!(
                "edit {e}: parcel {p} grows no building (tagged `building: false`); the edit is applied to no building"
            ),
            Unplaced::OtherSystem { system, grown } => format!(
                "edit {e}: it edits system `{system}` but parcel {p} grows `{grown}`; the edit is applied to no building"
            ),
        }
    }
}

/// The edits of `edits` (by parcel, [`by_parcel`]) that apply to no
/// building of `layout` when the parcels grow `system`: every edit of a
/// parcel that is gone or grows nothing, and every edit naming another
/// system; in edit-id order.
pub fn unplaced(
    layout: &crate::model::Layout,
    edits: &BTreeMap<Id, Vec<&Edit>>,
    system: &str,
) -> Vec<EditIssue> {
    let mut out = Vec::new();
    for (parcel, list) in edits {
        let why_all = match layout.parcels.get(parcel) {
            None => Some(Unplaced::ParcelGone),
            Some(p)
                if p.tags.get(crate::city::NO_BUILDING)
                    == Some(&crate::model::TagValue::Bool(false)) =>
            {
                Some(Unplaced::NoBuilding)
            }
            Some(_) => None,
        };
        for e in list {
            let why = match &why_all {
                Some(w) => w.clone(),
                None if e.system != system => Unplaced::OtherSystem {
                    system: e.system.clone(),
                    grown: system.to_string(),
                },
                None => continue,
            };
            out.push(EditIssue {
                edit: e.id,
                parcel: *parcel,
                why,
            });
        }
    }
    out.sort_by_key(|i| (i.edit, i.parcel));
    out
}
