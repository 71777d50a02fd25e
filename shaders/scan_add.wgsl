// The scan operator for sizes and offsets: exclusive sums of ELEM (u32 or
// vec2<u32>), saturating at 0xffffffff so that an overflowing total shows
// as 0xffffffff (in each component that overflowed) instead of wrapping.

const SCAN_INCLUSIVE: bool = false;

fn scan_identity() -> ELEM {
    return ELEM(0u);
}

fn scan_combine(a: ELEM, b: ELEM) -> ELEM {
    let s = a + b;
    return select(s, ELEM(0xffffffffu), s < a);
}
