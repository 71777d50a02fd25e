//! Golden cases of the split and repeat arithmetic (docs/shapes.md, "Split
//! and repeat arithmetic"), each computed by hand from the written rule.
//! A span is written `(part, tile, start, len)`.

use grm_shape::SizeError;
use grm_shape::split::{SplitSize, repeat, repeat_count, split};

use SplitSize::{Absolute as A, Floating as F, Relative as R};

const TOL: f32 = 1e-5;

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= TOL * b.abs().max(1.0)
}

#[track_caller]
fn check_spans(got: &[grm_shape::Span], want: &[(u32, u32, f32, f32)]) {
    let got_t: Vec<_> = got
        .iter()
        .map(|s| (s.part, s.tile, s.start, s.len))
        .collect();
    assert_eq!(got.len(), want.len(), "got {got_t:?}, want {want:?}");
    for (g, w) in got.iter().zip(want) {
        assert!(
            g.part == w.0 && g.tile == w.1 && close(g.start, w.2) && close(g.len, w.3),
            "got {got_t:?}, want {want:?}"
        );
    }
}

#[track_caller]
fn split_case(sizes: &[SplitSize], extent: f32, want: &[(u32, u32, f32, f32)]) {
    check_spans(&split(sizes, extent).unwrap(), want);
}

#[track_caller]
fn repeat_case(sizes: &[SplitSize], extent: f32, tiles: u32, want: &[(u32, u32, f32, f32)]) {
    let r = repeat(sizes, extent, 1_000_000).unwrap();
    assert_eq!(r.tiles, tiles, "tile count");
    check_spans(&r.spans, want);
}

// ---- splits ----

#[test]
fn s01_absolute_parts_leave_the_rest_uncovered() {
    split_case(
        &[A(2.0), A(3.0)],
        10.0,
        &[(0, 0, 0.0, 2.0), (1, 0, 2.0, 3.0)],
    );
}

#[test]
fn s02_one_floating_part_takes_the_rest() {
    split_case(
        &[A(2.0), F(1.0), A(3.0)],
        10.0,
        &[(0, 0, 0.0, 2.0), (1, 0, 2.0, 5.0), (2, 0, 7.0, 3.0)],
    );
}

#[test]
fn s03_equal_floating_parts_halve() {
    split_case(
        &[F(1.0), F(1.0)],
        10.0,
        &[(0, 0, 0.0, 5.0), (1, 0, 5.0, 5.0)],
    );
}

#[test]
fn s04_floating_parts_share_in_proportion() {
    split_case(
        &[F(1.0), F(3.0)],
        8.0,
        &[(0, 0, 0.0, 2.0), (1, 0, 2.0, 6.0)],
    );
}

#[test]
fn s05_relative_then_floating() {
    split_case(
        &[R(0.25), F(1.0)],
        8.0,
        &[(0, 0, 0.0, 2.0), (1, 0, 2.0, 6.0)],
    );
}

#[test]
fn s06_relative_halves() {
    split_case(
        &[R(0.5), R(0.5)],
        7.0,
        &[(0, 0, 0.0, 3.5), (1, 0, 3.5, 3.5)],
    );
}

#[test]
fn s07_part_crossing_the_end_is_cut() {
    split_case(
        &[A(4.0), A(4.0), A(4.0)],
        10.0,
        &[(0, 0, 0.0, 4.0), (1, 0, 4.0, 4.0), (2, 0, 8.0, 2.0)],
    );
}

#[test]
fn s08_part_starting_past_the_end_is_dropped() {
    split_case(&[A(6.0), A(6.0)], 5.0, &[(0, 0, 0.0, 5.0)]);
}

#[test]
fn s09_exact_fit() {
    split_case(
        &[A(5.0), A(5.0)],
        10.0,
        &[(0, 0, 0.0, 5.0), (1, 0, 5.0, 5.0)],
    );
}

#[test]
fn s10_floating_part_squeezed_to_nothing_is_dropped_and_numbers_keep() {
    // The wall between is 0 long: no span, but the window is still part 2.
    split_case(
        &[A(5.0), F(1.0), A(5.0)],
        10.0,
        &[(0, 0, 0.0, 5.0), (2, 0, 5.0, 5.0)],
    );
}

#[test]
fn s11_rigid_overflow_cuts_the_last_part_and_floats_get_nothing() {
    split_case(
        &[A(6.0), F(1.0), A(6.0)],
        10.0,
        &[(0, 0, 0.0, 6.0), (2, 0, 6.0, 4.0)],
    );
}

#[test]
fn s12_zero_scope_floating() {
    split_case(&[F(1.0)], 0.0, &[]);
}

#[test]
fn s13_zero_scope_absolute() {
    split_case(&[A(1.0), F(1.0)], 0.0, &[]);
}

#[test]
fn s14_zero_weight_float_is_dropped() {
    split_case(&[F(0.0), F(1.0)], 4.0, &[(1, 0, 0.0, 4.0)]);
}

#[test]
fn s15_negative_size_counts_as_zero() {
    split_case(&[A(-2.0), F(1.0)], 4.0, &[(1, 0, 0.0, 4.0)]);
}

#[test]
fn s16_negative_weight_counts_as_zero() {
    split_case(
        &[F(-1.0), F(1.0), A(1.0)],
        4.0,
        &[(1, 0, 0.0, 3.0), (2, 0, 3.0, 1.0)],
    );
}

#[test]
fn s17_nan_size_is_an_error() {
    assert!(
        matches!(split(&[A(1.0), A(f32::NAN)], 4.0), Err(SizeError::BadSize { part: 1, value }) if value.is_nan())
    );
}

#[test]
fn s18_infinite_size_is_an_error() {
    assert!(matches!(
        split(&[F(f32::INFINITY)], 4.0),
        Err(SizeError::BadSize { part: 0, .. })
    ));
}

#[test]
fn s19_nan_or_infinite_extent_is_an_error() {
    assert!(matches!(
        split(&[F(1.0)], f32::NAN),
        Err(SizeError::BadExtent(_))
    ));
    assert!(matches!(
        split(&[F(1.0)], f32::INFINITY),
        Err(SizeError::BadExtent(_))
    ));
}

#[test]
fn s20_negative_extent_is_zero() {
    split_case(&[F(1.0), A(1.0)], -3.0, &[]);
}

#[test]
fn s21_no_parts_is_an_error() {
    assert_eq!(split(&[], 4.0), Err(SizeError::NoParts));
}

#[test]
fn s22_all_kinds_together() {
    // rigid = 1 + 0.5 * 12 = 7, free = 5 shared 2:1.
    split_case(
        &[A(1.0), R(0.5), F(2.0), F(1.0)],
        12.0,
        &[
            (0, 0, 0.0, 1.0),
            (1, 0, 1.0, 6.0),
            (2, 0, 7.0, 10.0 / 3.0),
            (3, 0, 7.0 + 10.0 / 3.0, 5.0 / 3.0),
        ],
    );
}

#[test]
fn s23_relative_over_one_is_cut_at_the_end() {
    split_case(&[R(1.5)], 4.0, &[(0, 0, 0.0, 4.0)]);
}

#[test]
fn s24_floats_around_a_fixed_window_centre_it() {
    split_case(
        &[F(1.0), A(1.2), F(1.0)],
        2.0,
        &[(0, 0, 0.0, 0.4), (1, 0, 0.4, 1.2), (2, 0, 1.6, 0.4)],
    );
}

// ---- repeats ----

#[test]
fn r01_absolute_tiles_exact_fit() {
    repeat_case(
        &[A(2.0)],
        10.0,
        5,
        &[
            (0, 0, 0.0, 2.0),
            (0, 1, 2.0, 2.0),
            (0, 2, 4.0, 2.0),
            (0, 3, 6.0, 2.0),
            (0, 4, 8.0, 2.0),
        ],
    );
}

#[test]
fn r02_absolute_tiles_leave_the_rest_at_the_end() {
    repeat_case(
        &[A(3.0)],
        10.0,
        3,
        &[(0, 0, 0.0, 3.0), (0, 1, 3.0, 3.0), (0, 2, 6.0, 3.0)],
    );
}

#[test]
fn r03_floating_tiles_stretch_to_fill() {
    let t = 10.0 / 3.0;
    repeat_case(
        &[F(3.0)],
        10.0,
        3,
        &[(0, 0, 0.0, t), (0, 1, t, t), (0, 2, 2.0 * t, t)],
    );
}

#[test]
fn r04_floating_tile_too_long_is_laid_once_shrunk() {
    repeat_case(&[F(3.0)], 2.0, 1, &[(0, 0, 0.0, 2.0)]);
}

#[test]
fn r05_absolute_tile_too_long_lays_nothing() {
    repeat_case(&[A(3.0)], 2.0, 0, &[]);
}

#[test]
fn r06_mixed_tile_floats_take_the_stretch() {
    // nominal 3, n = 3, each tile 10/3 long: 1 fixed + 7/3 floating.
    let t = 10.0 / 3.0;
    repeat_case(
        &[A(1.0), F(2.0)],
        10.0,
        3,
        &[
            (0, 0, 0.0, 1.0),
            (1, 0, 1.0, t - 1.0),
            (0, 1, t, 1.0),
            (1, 1, t + 1.0, t - 1.0),
            (0, 2, 2.0 * t, 1.0),
            (1, 2, 2.0 * t + 1.0, t - 1.0),
        ],
    );
}

#[test]
fn r07_nothing_fits_but_the_fixed_parts_do() {
    // nominal 3 > 2.5; fixed parts 2 <= 2.5: one tile, the float 0.5.
    repeat_case(
        &[A(1.0), F(1.0), A(1.0)],
        2.5,
        1,
        &[(0, 0, 0.0, 1.0), (1, 0, 1.0, 0.5), (2, 0, 1.5, 1.0)],
    );
}

#[test]
fn r08_fixed_parts_do_not_fit_lays_nothing() {
    repeat_case(&[A(2.0), F(1.0)], 1.5, 0, &[]);
}

#[test]
fn r09_count_forgives_rounding_at_an_exact_fit() {
    // 1 / 0.1f32 is 9.99999985: still ten tiles.
    let r = repeat(&[A(0.1)], 1.0, 100).unwrap();
    assert_eq!(r.tiles, 10);
    assert_eq!(r.spans.len(), 10);
    assert!(close(r.spans[9].start, 0.9) && r.spans[9].start + r.spans[9].len <= 1.0 + 1e-6);
}

#[test]
fn r10_count_tolerance_is_tiny() {
    // 8.99995 / 3 = 2.99998: two tiles. 8.99999 / 3 = 2.999997: three,
    // the last cut at the extent.
    repeat_case(&[A(3.0)], 8.99995, 2, &[(0, 0, 0.0, 3.0), (0, 1, 3.0, 3.0)]);
    repeat_case(
        &[A(3.0)],
        8.99999,
        3,
        &[(0, 0, 0.0, 3.0), (0, 1, 3.0, 3.0), (0, 2, 6.0, 2.99999)],
    );
}

#[test]
fn r11_too_many_tiles_is_an_error_before_anything_is_laid() {
    assert_eq!(
        repeat(&[F(1.0)], 1e9, 1000),
        Err(SizeError::TooManyTiles {
            count: 1_000_000_000,
            max: 1000
        })
    );
}

#[test]
fn r12_huge_count_at_the_limit() {
    let r = repeat(&[A(1.0)], 100_000.0, 100_000).unwrap();
    assert_eq!(r.tiles, 100_000);
    let last = r.spans.last().unwrap();
    assert_eq!((last.tile, last.start, last.len), (99_999, 99_999.0, 1.0));
    assert_eq!(
        repeat(&[A(1.0)], 100_000.0, 99_999),
        Err(SizeError::TooManyTiles {
            count: 100_000,
            max: 99_999
        })
    );
}

#[test]
fn r13_empty_tile_is_an_error() {
    assert_eq!(repeat(&[A(0.0)], 10.0, 10), Err(SizeError::EmptyTile));
    assert_eq!(
        repeat(&[F(0.0), A(-1.0)], 10.0, 10),
        Err(SizeError::EmptyTile)
    );
}

#[test]
fn r14_relative_tile() {
    repeat_case(
        &[R(0.25)],
        8.0,
        4,
        &[
            (0, 0, 0.0, 2.0),
            (0, 1, 2.0, 2.0),
            (0, 2, 4.0, 2.0),
            (0, 3, 6.0, 2.0),
        ],
    );
}

#[test]
fn r15_zero_scope_lays_nothing() {
    repeat_case(&[A(2.0)], 0.0, 0, &[]);
    repeat_case(&[F(1.0)], 0.0, 0, &[]);
}

#[test]
fn r16_floating_first_tile_stretches_one() {
    // nominal 3 in 3.2: one tile, 3.2 long, the float 2.2.
    repeat_case(
        &[F(2.0), A(1.0)],
        3.2,
        1,
        &[(0, 0, 0.0, 2.2), (1, 0, 2.2, 1.0)],
    );
}

#[test]
fn r17_two_absolutes_one_tile_and_a_remainder() {
    repeat_case(
        &[A(2.0), A(2.0)],
        5.9999,
        1,
        &[(0, 0, 0.0, 2.0), (1, 0, 2.0, 2.0)],
    );
}

#[test]
fn r18_nan_in_a_tile_is_an_error() {
    assert!(matches!(
        repeat_count(&[A(1.0), F(f32::NAN)], 4.0),
        Err(SizeError::BadSize { part: 1, .. })
    ));
    assert!(matches!(
        repeat(&[A(1.0)], f32::NAN, 10),
        Err(SizeError::BadExtent(_))
    ));
}

#[test]
fn r19_window_tiles_of_a_facade() {
    // Tile ~0.4 | 1.2 | ~0.4 is nominally 2: 50 tiles in 100, the window
    // centred in each. (With ~1 walls the tile is nominally 3.2: 31 tiles.)
    assert_eq!(
        repeat_count(&[F(1.0), A(1.2), F(1.0)], 100.0).unwrap().0,
        31
    );
    let r = repeat(&[F(0.4), A(1.2), F(0.4)], 100.0, 1000).unwrap();
    assert_eq!(r.tiles, 50);
    assert_eq!(r.spans.len(), 150);
    let w = r.spans[3 * 17 + 1];
    assert_eq!((w.part, w.tile), (1, 17));
    assert!(close(w.start, 34.4) && close(w.len, 1.2));
}
