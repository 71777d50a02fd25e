//! Split and repeat arithmetic: how the sizes of a split's parts, or of a
//! repeated tile, become intervals of a scope's extent.
//!
//! This is the written rule of docs/shapes.md ("Split and repeat
//! arithmetic"), implemented once here and checked against hand-computed
//! cases in `tests/split_golden.rs`. In short:
//!
//! - **Split**: absolute sizes first, then relative sizes (a fraction of
//!   the extent); the rest of the extent is shared by the floating parts in
//!   proportion to their weights. Parts are laid from 0 in order; a part of
//!   length 0 makes no interval, a part that starts at or past the end makes
//!   none, a part that crosses the end is cut there. Nothing stretches but
//!   floating parts: with no floating part the rest stays uncovered.
//! - **Repeat**: the tile's nominal length is the sum of its absolute and
//!   relative sizes and its floating weights (`~w` means "about `w`"). The
//!   count is `floor(extent / tile + 1e-5)`; when that is 0 a tile with a
//!   floating part whose fixed parts fit is laid once (its floating parts
//!   shrink), anything else lays no tile. With floating parts the tiles
//!   stretch to fill the extent exactly; without, they keep their length and
//!   the rest stays uncovered at the end.
//! - Negative sizes and weights count as 0; NaN or infinite sizes and
//!   extents are errors, never laid out.
//!
//! Arithmetic runs in `f64` and the intervals are returned in `f32`.

use crate::error::SizeError;

/// How one part of a split or repeat is sized.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SplitSize {
    /// A length in scope units.
    Absolute(f32),
    /// A fraction of the extent being divided (`25%` is `0.25`).
    Relative(f32),
    /// A weight: floating parts share what the others leave, in
    /// proportion to their weights (`~1`).
    Floating(f32),
}

impl SplitSize {
    fn value(self) -> f32 {
        match self {
            SplitSize::Absolute(v) | SplitSize::Relative(v) | SplitSize::Floating(v) => v,
        }
    }
}

/// One laid-out part: the interval `[start, start + len)` of the extent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    /// The part's index among the split's parts (or the tile's parts), from 0.
    pub part: u32,
    /// The tile's index, from 0 (always 0 for a split).
    pub tile: u32,
    /// Where the interval starts.
    pub start: f32,
    /// Its length (positive).
    pub len: f32,
}

/// A repeat's layout: how many tiles, and the intervals of their parts in
/// order (tile by tile).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RepeatLayout {
    /// The number of tiles laid (0 when not even one fits).
    pub tiles: u32,
    /// The parts' intervals; parts of length 0 are left out.
    pub spans: Vec<Span>,
}

/// The relative tolerance of "fits": a repeat count rounds up when the
/// extent holds within `1e-5` of a whole number of tiles, and a split part
/// ending within `1e-6` of the extent ends exactly at it.
pub const COUNT_TOLERANCE: f64 = 1e-5;
const END_TOLERANCE: f64 = 1e-6;

fn checked_extent(extent: f32) -> Result<f64, SizeError> {
    if !extent.is_finite() {
        return Err(SizeError::BadExtent(extent));
    }
    Ok(f64::from(extent.max(0.0)))
}

fn checked_sizes(sizes: &[SplitSize]) -> Result<(), SizeError> {
    if sizes.is_empty() {
        return Err(SizeError::NoParts);
    }
    for (part, s) in sizes.iter().enumerate() {
        let value = s.value();
        if !value.is_finite() {
            return Err(SizeError::BadSize { part, value });
        }
    }
    Ok(())
}

/// The fixed (absolute or relative) length of a part, or 0 for a floating one.
fn rigid(s: SplitSize, extent: f64) -> f64 {
    match s {
        SplitSize::Absolute(v) => f64::from(v.max(0.0)),
        SplitSize::Relative(v) => f64::from(v.max(0.0)) * extent,
        SplitSize::Floating(_) => 0.0,
    }
}

fn weight(s: SplitSize) -> f64 {
    match s {
        SplitSize::Floating(v) => f64::from(v.max(0.0)),
        _ => 0.0,
    }
}

/// Lay `sizes` along `[0, extent)` from `origin` (one split, or one tile
/// of a repeat whose floating parts share `free`), appending to `out`.
/// Parts of length 0 and parts at or past `limit` are left out; a part
/// crossing `limit` is cut there.
#[allow(clippy::too_many_arguments)]
fn lay(
    sizes: &[SplitSize],
    extent: f64,
    free: f64,
    total_weight: f64,
    origin: f64,
    limit: f64,
    tile: u32,
    out: &mut Vec<Span>,
) {
    let tol = END_TOLERANCE * limit.max(f64::MIN_POSITIVE);
    let mut pos = origin;
    for (part, &s) in sizes.iter().enumerate() {
        let len = match s {
            SplitSize::Floating(_) if free > 0.0 && total_weight > 0.0 => {
                free * weight(s) / total_weight
            }
            SplitSize::Floating(_) => 0.0,
            _ => rigid(s, extent),
        };
        let start = pos;
        pos += len;
        if len <= 0.0 || start >= limit - tol {
            continue;
        }
        let mut end = start + len;
        if end > limit || limit - end <= tol {
            end = limit;
        }
        out.push(Span {
            part: part as u32,
            tile,
            start: start as f32,
            len: (end - start) as f32,
        });
    }
}

/// Lay out a split of `extent` into `sizes`, appending the intervals to
/// `out` (cleared first). See the module documentation for the rule.
pub fn split_into(sizes: &[SplitSize], extent: f32, out: &mut Vec<Span>) -> Result<(), SizeError> {
    out.clear();
    checked_sizes(sizes)?;
    let extent = checked_extent(extent)?;
    let fixed: f64 = sizes.iter().map(|&s| rigid(s, extent)).sum();
    let total_weight: f64 = sizes.iter().map(|&s| weight(s)).sum();
    let free = (extent - fixed).max(0.0);
    lay(sizes, extent, free, total_weight, 0.0, extent, 0, out);
    Ok(())
}

/// [`split_into`] into a new vector.
pub fn split(sizes: &[SplitSize], extent: f32) -> Result<Vec<Span>, SizeError> {
    let mut out = Vec::with_capacity(sizes.len());
    split_into(sizes, extent, &mut out)?;
    Ok(out)
}

/// The number of tiles a repeat of `sizes` lays along `extent` (before the
/// `max_tiles` check), and the length of each tile.
pub fn repeat_count(sizes: &[SplitSize], extent: f32) -> Result<(u64, f64), SizeError> {
    checked_sizes(sizes)?;
    let extent = checked_extent(extent)?;
    let fixed: f64 = sizes.iter().map(|&s| rigid(s, extent)).sum();
    let total_weight: f64 = sizes.iter().map(|&s| weight(s)).sum();
    let nominal = fixed + total_weight;
    if nominal <= 0.0 {
        return Err(SizeError::EmptyTile);
    }
    let fit = (extent / nominal + COUNT_TOLERANCE).floor();
    let count = if fit >= u64::MAX as f64 {
        u64::MAX
    } else {
        fit as u64
    };
    let count = if count == 0
        && total_weight > 0.0
        && extent > 0.0
        && fixed <= extent * (1.0 + END_TOLERANCE)
    {
        1
    } else {
        count
    };
    let tile_len = if count == 0 {
        0.0
    } else if total_weight > 0.0 {
        extent / count as f64
    } else {
        nominal
    };
    Ok((count, tile_len))
}

/// Lay out a repeat of the tile `sizes` along `extent`, at most
/// `max_tiles` tiles (more is [`SizeError::TooManyTiles`], checked before
/// anything is laid). `out.spans` is cleared first.
pub fn repeat_into(
    sizes: &[SplitSize],
    extent: f32,
    max_tiles: u64,
    out: &mut RepeatLayout,
) -> Result<(), SizeError> {
    out.spans.clear();
    out.tiles = 0;
    let (count, tile_len) = repeat_count(sizes, extent)?;
    let max = max_tiles.min(u64::from(u32::MAX));
    if count > max {
        return Err(SizeError::TooManyTiles { count, max });
    }
    let extent = checked_extent(extent)?;
    let fixed: f64 = sizes.iter().map(|&s| rigid(s, extent)).sum();
    let total_weight: f64 = sizes.iter().map(|&s| weight(s)).sum();
    let free = (tile_len - fixed).max(0.0);
    out.spans.reserve(count as usize * sizes.len());
    for t in 0..count {
        let origin = t as f64 * tile_len;
        // Each tile is cut at its own end (and the last at the extent), so
        // rounding never lets one tile overlap the next.
        let limit = if t + 1 == count && total_weight > 0.0 {
            extent
        } else {
            (origin + tile_len).min(extent)
        };
        lay(
            sizes,
            extent,
            free,
            total_weight,
            origin,
            limit,
            t as u32,
            &mut out.spans,
        );
    }
    out.tiles = count as u32;
    Ok(())
}

/// [`repeat_into`] into a new layout.
pub fn repeat(sizes: &[SplitSize], extent: f32, max_tiles: u64) -> Result<RepeatLayout, SizeError> {
    let mut out = RepeatLayout::default();
    repeat_into(sizes, extent, max_tiles, &mut out)?;
    Ok(out)
}
