// The scan operator of the turtle interpretation: a segmented composition
// of turtle transforms (TurtleElem, see turtle.wgsl). Composing `a` then
// `b` (b applied after a, in turtle space: frame = frame * b):
//   M = Ma * Mb, width map w -> wa_b * (wa_a * w + wb_a) + wb_b,
//   bone = b's if it has one, else a's.
// An element with the SEG_START bit restarts the composition (it does not
// see anything before it), which makes one scan compute every branch's
// local transforms at once. Inclusive: each element ends up as the
// composition from its segment's start through itself.

const SCAN_INCLUSIVE: bool = true;

fn scan_identity() -> TurtleElem {
    var e: TurtleElem;
    e.m = array<f32, 12>(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0);
    e.wa = 1.0;
    e.wb = 0.0;
    e.bone = NONE;
    e.seg = 0u;
    return e;
}

fn elem_mat(e: TurtleElem) -> mat3x3<f32> {
    return mat3x3<f32>(e.m[0], e.m[1], e.m[2], e.m[3], e.m[4], e.m[5], e.m[6], e.m[7], e.m[8]);
}

fn elem_t(e: TurtleElem) -> vec3<f32> {
    return vec3<f32>(e.m[9], e.m[10], e.m[11]);
}

fn set_frame(e: ptr<function, TurtleElem>, m: mat3x3<f32>, t: vec3<f32>) {
    (*e).m = array<f32, 12>(m[0].x, m[0].y, m[0].z, m[1].x, m[1].y, m[1].z, m[2].x, m[2].y, m[2].z, t.x, t.y, t.z);
}

// `a` then `b`, ignoring segment starts.
fn compose(a: TurtleElem, b: TurtleElem) -> TurtleElem {
    var r: TurtleElem;
    let ma = elem_mat(a);
    set_frame(&r, ma * elem_mat(b), elem_t(a) + ma * elem_t(b));
    r.wa = b.wa * a.wa;
    r.wb = b.wa * a.wb + b.wb;
    r.bone = select(a.bone, b.bone, b.bone != NONE);
    r.seg = a.seg;
    return r;
}

fn scan_combine(a: TurtleElem, b: TurtleElem) -> TurtleElem {
    if ((b.seg & SEG_START) != 0u) {
        return b;
    }
    return compose(a, b);
}
