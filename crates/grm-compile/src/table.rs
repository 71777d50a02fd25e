//! The packed production tables: `#[repr(C)]` records of `u32`/`f32` words
//! that a GPU uploads unchanged (Lipp, dissertation ch. 5.2.1: a header per
//! production with the successor's module and parameter counts, the
//! probability, the contexts and the expression offsets).
//!
//! All offsets are indices (in records of the target table, or in words of
//! the code / constant arrays), never byte offsets. [`NONE`] marks an absent
//! offset. Every record is a multiple of 4 bytes with no padding, so an
//! array of them is also an array of `u32` words (WGSL: an
//! `array<SymbolEntry>` in a storage buffer has the same layout).
//!
//! How the engine uses them, for one module `m` at position `i`:
//!
//! 1. `sym = symbols[m.symbol]`; try groups `sym.first_group ..
//!    sym.first_group + sym.group_count` in order.
//! 2. For a group `g`: match `g`'s left context (context items
//!    `g.left_offset ..+ g.left_len`, nearest first is the *last* item) and
//!    right context, copying matched modules' parameter words into the
//!    binding array (`g.bind_words` words; the predecessor's at
//!    `g.pred_bind_offset`, each context pattern's at its `bind_offset`).
//! 3. If `g.cond_code != NONE`, run the condition; false (0.0): next group.
//! 4. Pick an alternative among `alts[g.first_alt ..+ g.alt_count]`: one
//!    alternative is taken; otherwise `u = u(seed, iteration, i, 0)`
//!    ([`crate::rng`]) and the first `k` with `u * total < cum_k` (constant
//!    weights: `alt.cum_weight` and `g.total_weight`; else the weights
//!    are evaluated from `alt.weight_code`). Weights whose sum passes the
//!    f32 range are all multiplied by [`WEIGHT_SCALE`] first (an exact
//!    power of two, so the draw is the one the real numbers give).
//! 5. Emit `succ[alt.succ_offset ..+ alt.succ_len]`: module `k` gets symbol
//!    `succ.symbol` and parameters `param_exprs[succ.first_param ..+
//!    succ.param_count]`, whose words land at `succ.word_offset` within the
//!    alternative's `alt.succ_words` output words.
//!
//! A module no group takes is copied unchanged.

use bytemuck::{Pod, Zeroable};

/// An absent offset.
pub const NONE: u32 = u32::MAX;

/// `SymbolEntry::flags`: the symbol is `[` (push).
pub const SYM_PUSH: u32 = 1;
/// `SymbolEntry::flags`: the symbol is `]` (pop).
pub const SYM_POP: u32 = 2;
/// `SymbolEntry::flags`: the symbol is in the system's `ignore` list
/// (skipped while matching contexts).
pub const SYM_IGNORED: u32 = 4;
/// `SymbolEntry::flags`: a built-in terminal (turtle, transform, geometry).
pub const SYM_TERMINAL: u32 = 8;

/// One module symbol of the system (indexed by `grm_sema::SymbolId`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct SymbolEntry {
    /// First normal group with this predecessor (index into the group table).
    pub first_group: u32,
    /// Number of normal groups, tried in order from `first_group`.
    pub group_count: u32,
    /// First wrap-up group (sample systems; the guided sampler's wrap-up phase).
    pub first_wrapup: u32,
    /// Number of wrap-up groups.
    pub wrapup_count: u32,
    /// Parameter words every module of this symbol carries (`vec3` = 3).
    pub param_words: u32,
    /// `SYM_*` bits.
    pub flags: u32,
}

/// `GroupHeader::flags`: the group has a left or right context.
pub const GROUP_CONTEXT: u32 = 1;
/// `GroupHeader::flags`: all weights are constants (`cum_weight` and
/// `total_weight` are valid).
pub const GROUP_CONST_WEIGHTS: u32 = 2;
/// `GroupHeader::flags`: a wrap-up group.
pub const GROUP_WRAPUP: u32 = 4;

/// One production group: productions with the same predecessor, contexts
/// and condition (stochastic alternatives of each other).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GroupHeader {
    /// The predecessor symbol.
    pub pred: u32,
    /// `GROUP_*` bits.
    pub flags: u32,
    /// Left context items: index into the context table.
    pub left_offset: u32,
    /// Number of left context items (0: no left context).
    pub left_len: u32,
    /// Right context items: index into the context table.
    pub right_offset: u32,
    /// Number of right context items (0: no right context).
    pub right_len: u32,
    /// Words of the binding array (all patterns' bound parameters).
    pub bind_words: u32,
    /// Where the predecessor's parameter words go in the binding array.
    pub pred_bind_offset: u32,
    /// Parameter words the predecessor binds: all of its words, or 0 for a
    /// terminal written without parameters.
    pub pred_bind_words: u32,
    /// Code offset of the condition (bool), or [`NONE`].
    pub cond_code: u32,
    /// First alternative (index into the alternative table).
    pub first_alt: u32,
    /// Number of alternatives (>= 1).
    pub alt_count: u32,
    /// Sum of the constant weights (valid with `GROUP_CONST_WEIGHTS`).
    pub total_weight: f32,
    /// The index of the group in `grm_sema::System::groups`.
    pub sema_group: u32,
}

/// What every weight of a group is multiplied by when their sum passes the
/// f32 range (2^-64: exact, and no sum of finite f32 weights then
/// overflows): a group of weights `3e38` and `3e38` is a fair coin, not
/// always its last alternative. The compiler applies it to constant
/// groups' `cum_weight` and `total_weight`; `select::choose_alternative`
/// and the GPU's `decide` to computed weights whose sum is not finite.
pub const WEIGHT_SCALE: f32 = 5.421_011e-20;

/// `AltHeader::flags`: every successor parameter is a constant or a copy of
/// a binding word (no code runs for this alternative's successor).
pub const ALT_NO_CODE: u32 = 1;

/// One production (alternative) of a group.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct AltHeader {
    /// The group it belongs to.
    pub group: u32,
    /// Code offset of the weight expression, or [`NONE`] when constant.
    pub weight_code: u32,
    /// The constant weight (0 when computed).
    pub weight: f32,
    /// Sum of the constant weights of the group's alternatives up to and
    /// including this one (valid with `GROUP_CONST_WEIGHTS`).
    pub cum_weight: f32,
    /// First successor module (index into the successor table).
    pub succ_offset: u32,
    /// Successor length in modules.
    pub succ_len: u32,
    /// Successor length in parameter words.
    pub succ_words: u32,
    /// `ALT_*` bits.
    pub flags: u32,
}

/// `ContextItem::kind`: a pattern (matches one module of `symbol`).
pub const CTX_SYMBOL: u32 = 0;
/// `ContextItem::kind`: `[` in a right context: enter a lateral branch.
pub const CTX_PUSH: u32 = 1;
/// `ContextItem::kind`: `]` in a right context: the branch ends here.
pub const CTX_POP: u32 = 2;

/// One item of a left or right context.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct ContextItem {
    /// `CTX_*`.
    pub kind: u32,
    /// The symbol a `CTX_SYMBOL` item matches (0 otherwise).
    pub symbol: u32,
    /// Parameter words it binds: all of the module's, or 0.
    pub bind_words: u32,
    /// Where they go in the binding array.
    pub bind_offset: u32,
}

/// One module of a successor (or of the axiom).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct SuccModule {
    /// The module's symbol.
    pub symbol: u32,
    /// Its first parameter expression (index into the parameter table).
    pub first_param: u32,
    /// Number of parameters (expressions), not words.
    pub param_count: u32,
    /// Offset of its first parameter word within the successor's words.
    pub word_offset: u32,
    /// Its identity salt ([`crate::rng::salt`]): the key of the module it
    /// writes is `child_key(parent key, salt)`.
    pub salt: u32,
}

/// `ParamExpr::kind`: a constant: `consts[a .. a + words]`.
pub const PARAM_CONST: u32 = 0;
/// `ParamExpr::kind`: a copy of binding words `a .. a + words`.
pub const PARAM_COPY: u32 = 1;
/// `ParamExpr::kind`: run the code at offset `a`; it leaves `words` values.
pub const PARAM_CODE: u32 = 2;

/// One successor parameter: how its words are computed.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct ParamExpr {
    /// `PARAM_*`.
    pub kind: u32,
    /// Constant index, binding word or code offset (see `kind`).
    pub a: u32,
    /// Words it produces: 1, or 3 for a `vec3`.
    pub words: u32,
    /// Index into [`crate::CompiledSystem::param_spans`] (its source span).
    pub span: u32,
}

/// One entry of the span table: code from `code_offset` (up to the next
/// entry's offset) was compiled from `span` (`start .. end` bytes in the
/// system's file).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct SpanEntry {
    pub code_offset: u32,
    pub start: u32,
    pub end: u32,
}

/// The section directory of [`crate::CompiledSystem::pack`]: where each table
/// starts in the packed word buffer and how many records it has.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct PackedHeader {
    /// `b"GRM2"` little-endian: layout version.
    pub magic: u32,
    pub symbols_offset: u32,
    pub symbols_count: u32,
    pub groups_offset: u32,
    pub groups_count: u32,
    pub alts_offset: u32,
    pub alts_count: u32,
    pub context_offset: u32,
    pub context_count: u32,
    pub succ_offset: u32,
    pub succ_count: u32,
    pub params_offset: u32,
    pub params_count: u32,
    pub code_offset: u32,
    pub code_count: u32,
    pub consts_offset: u32,
    pub consts_count: u32,
    /// The axiom: an alternative index (its successor is the axiom).
    pub axiom_alt: u32,
    /// The system's seed setting.
    pub seed: u32,
    /// The system's iterations setting.
    pub iterations: u32,
    /// [`crate::rng::LOG2_TABLE`] (257 words), which the kernels' race
    /// among weighted alternatives reads.
    pub log2_offset: u32,
    pub log2_count: u32,
}

/// The layout version in [`PackedHeader::magic`].
pub const PACKED_MAGIC: u32 = u32::from_le_bytes(*b"GRM2");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn record_sizes_in_words() {
        assert_eq!(size_of::<SymbolEntry>(), 6 * 4);
        assert_eq!(size_of::<GroupHeader>(), 14 * 4);
        assert_eq!(size_of::<AltHeader>(), 8 * 4);
        assert_eq!(size_of::<ContextItem>(), 4 * 4);
        assert_eq!(size_of::<SuccModule>(), 5 * 4);
        assert_eq!(size_of::<ParamExpr>(), 4 * 4);
        assert_eq!(size_of::<SpanEntry>(), 3 * 4);
        assert_eq!(size_of::<PackedHeader>(), 22 * 4);
    }
}
