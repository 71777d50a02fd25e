// The expression bytecode interpreter: the GPU twin of grm_compile::vm,
// running the same words (opcodes OP_* and STACK_SIZE come from the
// generated header, i.e. from grm_compile::op). Semantics per op: see
// grm_compile::op. Code and constants are read from the packed table
// buffer `tables` (declared by the including kernel) at TAB.code_offset and
// TAB.consts_offset (relative to the current system's TAB_BASE); the binding words of the production being applied are
// in `vm_bind`.
//
// Code is verified on the host (grm_compile::verify) before it is
// uploaded, so the interpreter does not re-check stack bounds; it still
// cannot run away: code is straight-line, pc only grows, and reading past
// the code ends the run with VM_FAULT.
//!include rng.wgsl

const VM_FAULT: u32 = 0xffffffffu;

var<private> vm_st: array<f32, STACK_SIZE>;
var<private> vm_bind: array<f32, MAX_BIND_WORDS>;

fn vm_code(pc: u32) -> u32 {
    return tables[TAB_BASE + TAB.code_offset + pc];
}

fn vm_const(i: u32) -> f32 {
    return bitcast<f32>(tables[TAB_BASE + TAB.consts_offset + i]);
}

fn truthy(x: f32) -> bool {
    return x != 0.0;
}

fn b2f(b: bool) -> f32 {
    return select(0.0, 1.0, b);
}

fn is_nan(x: f32) -> bool {
    return !(x == x);
}

// IEEE minNum / maxNum: a NaN operand yields the other one.
fn fmin(a: f32, b: f32) -> f32 {
    if (is_nan(a)) { return b; }
    if (is_nan(b)) { return a; }
    return select(b, a, a < b);
}

fn fmax(a: f32, b: f32) -> f32 {
    if (is_nan(a)) { return b; }
    if (is_nan(b)) { return a; }
    return select(b, a, a > b);
}

// Half away from zero (f32::round), not WGSL's half-to-even.
fn fround(x: f32) -> f32 {
    let t = trunc(x);
    if (abs(x - t) >= 0.5) {
        return t + select(-1.0, 1.0, x > 0.0);
    }
    return t;
}

fn fsign(x: f32) -> f32 {
    if (x > 0.0) { return 1.0; }
    if (x < 0.0) { return -1.0; }
    return 0.0;
}

fn ffloor_rem(x: f32, y: f32) -> f32 {
    return x - y * floor(x / y);
}

// ln(x) to a few ulps, relative, for every x (as Rust's f32::ln). WGSL
// bounds log()'s error on [0.5, 2] only by an absolute 2^-21, and there
// ln(x) is near 0: lavapipe's log(1 - 2^-24) is 73% off, and a GPU's may
// even have the wrong sign (a NaN normal draw, sqrt(-2 ln(1 - u1)) with a
// tiny u1). There it is the series ln(x) = 2 atanh(s) = 2 (s + s^3/3 +
// ... + s^15/15), s = (x - 1) / (x + 1): x - 1 is exact, |s| <= 1/3, and
// the first term left out is below 2^-29 of the sum. NaN, 0, negative
// and infinite x take log(), whose values there are Rust's.
fn fln(x: f32) -> f32 {
    if (x >= 0.5 && x <= 2.0) {
        let s = (x - 1.0) / (x + 1.0);
        let s2 = s * s;
        var p = 1.0 / 15.0;
        p = p * s2 + 1.0 / 13.0;
        p = p * s2 + 1.0 / 11.0;
        p = p * s2 + 1.0 / 9.0;
        p = p * s2 + 1.0 / 7.0;
        p = p * s2 + 1.0 / 5.0;
        p = p * s2 + 1.0 / 3.0;
        p = p * s2 + 1.0;
        return 2.0 * s * p;
    }
    return log(x);
}

// Inverse trigonometry to a few ulps (Cephes' single-precision asinf,
// acosf and atanf: polynomials in +, *, / and sqrt, which WGSL rounds to
// within 2.5 ulps). WGSL only bounds asin and acos by atan2's error, 4096
// ulps, and lavapipe's asin(0.8288) is 2e-4 radians off Rust's.
const F_PI: f32 = 3.14159265358979323846;
const F_PI_2: f32 = 1.57079632679489661923;
const F_PI_4: f32 = 0.78539816339744830962;

fn copysign(m: f32, s: f32) -> f32 {
    return bitcast<f32>((bitcast<u32>(m) & 0x7fffffffu) | (bitcast<u32>(s) & 0x80000000u));
}

// atan(x) for x >= 0 (or NaN), infinity included.
fn fatan_pos(x: f32) -> f32 {
    var y = 0.0;
    var t = x;
    if (x > 2.414213562373095) {
        y = F_PI_2;
        t = -1.0 / x;
    } else if (x > 0.4142135623730950) {
        y = F_PI_4;
        t = (x - 1.0) / (x + 1.0);
    }
    let z = t * t;
    return y + ((((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z
        - 3.33329491539e-1) * z * t + t);
}

fn fatan(x: f32) -> f32 {
    return copysign(fatan_pos(abs(x)), x);
}

fn fasin(x: f32) -> f32 {
    let a = abs(x);
    if (!(a <= 1.0)) {
        return bitcast<f32>(0x7fc00000u);
    }
    let big = a > 0.5;
    var z = a * a;
    var t = a;
    if (big) {
        z = 0.5 * (1.0 - a);
        t = sqrt(z);
    }
    var r = ((((4.2163199048e-2 * z + 2.4181311049e-2) * z + 4.5470025998e-2) * z
        + 7.4953002686e-2) * z + 1.6666752422e-1) * z * t + t;
    if (big) {
        r = F_PI_2 - (r + r);
    }
    return copysign(r, x);
}

fn facos(x: f32) -> f32 {
    if (!(abs(x) <= 1.0)) {
        return bitcast<f32>(0x7fc00000u);
    }
    if (x < -0.5) {
        return F_PI - 2.0 * fasin(sqrt(0.5 * (1.0 + x)));
    }
    if (x > 0.5) {
        return 2.0 * fasin(sqrt(0.5 * (1.0 - x)));
    }
    return F_PI_2 - fasin(x);
}

fn is_inf(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) == 0x7f800000u;
}

// f32::atan2(y, x), special values included: signed zeros pick the
// half-plane (x = -0 counts as negative), infinities give the multiples
// of pi/4.
fn fatan2(y: f32, x: f32) -> f32 {
    if (is_nan(x) || is_nan(y)) {
        return x + y;
    }
    let neg_x = (bitcast<u32>(x) & 0x80000000u) != 0u;
    let ax = abs(x);
    let ay = abs(y);
    var r: f32;
    if (is_inf(ax)) {
        if (is_inf(ay)) {
            r = select(F_PI_4, 3.0 * F_PI_4, neg_x);
        } else {
            r = select(0.0, F_PI, neg_x);
        }
    } else if (is_inf(ay) || ax == 0.0) {
        if (ay == 0.0) {
            r = select(0.0, F_PI, neg_x);
        } else {
            r = F_PI_2;
        }
    } else if (ay == 0.0) {
        r = select(0.0, F_PI, neg_x);
    } else {
        if (ay <= ax) {
            r = fatan_pos(ay / ax);
        } else {
            r = F_PI_2 - fatan_pos(ax / ay);
        }
        if (neg_x) {
            r = F_PI - r;
        }
    }
    return copysign(r, y);
}

// pow for x > 0. WGSL's pow is exp2(y * log2(x)), whose log2 has fln's
// problem near 1 (pow(1.0001, 1000) would be off by 1e-4 relative): there
// it is exp2 of y times fln's logarithm. Powers of two and every x
// outside (0.5, 2) keep the builtin, exact for pow(2, 3).
fn fpow_pos(x: f32, y: f32) -> f32 {
    if (x > 0.5 && x < 2.0) {
        return exp2(y * (fln(x) * LOG2_E));
    }
    return pow(x, y);
}

// powf with Rust's cases that WGSL's pow leaves undefined (x <= 0).
fn fpow(x: f32, y: f32) -> f32 {
    if (y == 0.0) { return 1.0; }
    if (x == 1.0) { return 1.0; }
    if (is_nan(x) || is_nan(y)) { return x + y; }
    if (x == 0.0) {
        if (y > 0.0) {
            let odd = (trunc(y) == y) && (ffloor_rem(y, 2.0) == 1.0);
            return select(0.0, x, odd);
        }
        return bitcast<f32>(0x7f800000u);
    }
    if (x < 0.0) {
        if (trunc(y) != y) { return bitcast<f32>(0x7fc00000u); }
        let m = fpow_pos(-x, y);
        return select(m, -m, ffloor_rem(y, 2.0) == 1.0);
    }
    return fpow_pos(x, y);
}

fn fclamp(x: f32, lo: f32, hi: f32) -> f32 {
    return fmin(fmax(x, lo), hi);
}

// f32::clamp: NaN stays NaN.
fn fclamp_nan(x: f32, lo: f32, hi: f32) -> f32 {
    if (is_nan(x)) { return x; }
    return min(max(x, lo), hi);
}

fn fsmoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = fclamp_nan((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

fn unary(op: u32, x: f32) -> f32 {
    switch op {
        case OP_NEG: { return -x; }
        case OP_ABS: { return abs(x); }
        case OP_FLOOR: { return floor(x); }
        case OP_CEIL: { return ceil(x); }
        case OP_ROUND: { return fround(x); }
        case OP_FRACT: { return x - floor(x); }
        case OP_SIGN: { return fsign(x); }
        case OP_NOT: { return b2f(!truthy(x)); }
        case OP_SIN: { return sin(x * DEG_TO_RAD); }
        case OP_COS: { return cos(x * DEG_TO_RAD); }
        case OP_TAN: { return tan(x * DEG_TO_RAD); }
        case OP_ASIN: { return fasin(x) * RAD_TO_DEG; }
        case OP_ACOS: { return facos(x) * RAD_TO_DEG; }
        case OP_ATAN: { return fatan(x) * RAD_TO_DEG; }
        case OP_SQRT: { return sqrt(x); }
        case OP_EXP: { return exp(x); }
        case OP_LN: { return fln(x); }
        case OP_LOG10: {
            if (x >= 0.5 && x <= 2.0) { return fln(x) * LOG10_E; }
            return log2(x) * LOG10_2;
        }
        default: { return x; }
    }
}

fn binary(op: u32, x: f32, y: f32) -> f32 {
    switch op {
        case OP_ADD: { return x + y; }
        case OP_SUB: { return x - y; }
        case OP_MUL: { return x * y; }
        case OP_DIV: { return x / y; }
        case OP_REM: { return ffloor_rem(x, y); }
        case OP_MIN: { return fmin(x, y); }
        case OP_MAX: { return fmax(x, y); }
        case OP_STEP: { return select(1.0, 0.0, y < x); }
        case OP_LT: { return b2f(x < y); }
        case OP_LE: { return b2f(x <= y); }
        case OP_GT: { return b2f(x > y); }
        case OP_GE: { return b2f(x >= y); }
        case OP_AND: { return b2f(truthy(x) && truthy(y)); }
        case OP_OR: { return b2f(truthy(x) || truthy(y)); }
        case OP_ATAN2: { return fatan2(x, y) * RAD_TO_DEG; }
        case OP_POW: { return fpow(x, y); }
        default: { return x; }
    }
}

fn ternary(op: u32, x: f32, y: f32, z: f32) -> f32 {
    switch op {
        case OP_CLAMP: { return fclamp(x, y, z); }
        case OP_MIX: { return x * (1.0 - z) + y * z; }
        default: { return fsmoothstep(x, y, z); }
    }
}

fn vm_rand_int(a: f32, b: f32, u: f32) -> f32 {
    if (is_nan(a) || is_nan(b)) {
        return a + b;
    }
    let lo = fround(fmin(a, b));
    let hi = fround(fmax(a, b));
    let span = hi - lo;
    // A span past the f32 range: between the bounds as vm_rand_uniform,
    // rounded (as the CPU's `rand_int`).
    if (!is_finite(span) && is_finite(lo) && is_finite(hi)) {
        return fclamp(fround(lo * (1.0 - u) + hi * u), lo, hi);
    }
    return lo + fmin(floor(u * (span + 1.0)), span);
}

fn vm_rand_uniform(lo: f32, hi: f32, u: f32) -> f32 {
    let span = hi - lo;
    if (!is_finite(span) && is_finite(lo) && is_finite(hi)) {
        return lo * (1.0 - u) + hi * u;
    }
    return lo + span * u;
}

fn vm_spline(base: u32, n: u32, w: u32) {
    let t = vm_st[base];
    let segments = f32(n - 3u);
    var tc = 0.0;
    if (!is_nan(t)) {
        tc = fclamp(t, 0.0, 1.0);
    }
    let u = tc * segments;
    let i = min(u32(floor(u)), n - 4u);
    let s = u - f32(i);
    let s2 = s * s;
    let s3 = s2 * s;
    var b: array<f32, 4>;
    b[0] = (1.0 - 3.0 * s + 3.0 * s2 - s3) / 6.0;
    b[1] = (4.0 - 6.0 * s2 + 3.0 * s3) / 6.0;
    b[2] = (1.0 + 3.0 * s + 3.0 * s2 - 3.0 * s3) / 6.0;
    b[3] = s3 / 6.0;
    var acc = vec3<f32>(0.0);
    for (var k = 0u; k < 4u; k = k + 1u) {
        let c = base + 1u + (i + k) * w;
        for (var j = 0u; j < w; j = j + 1u) {
            acc[j] = acc[j] + vm_st[c + j] * b[k];
        }
    }
    for (var j = 0u; j < w; j = j + 1u) {
        vm_st[base + j] = acc[j];
    }
}

fn vm_choose_weight(base: u32, j: u32, w: u32) -> f32 {
    let x = vm_st[base + j * (w + 1u) + w];
    return select(0.0, x, x > 0.0);
}

fn vm_choose(base: u32, n: u32, w: u32, u: f32) {
    var total = 0.0;
    for (var j = 0u; j < n; j = j + 1u) {
        total = total + vm_choose_weight(base, j, w);
    }
    if (is_nan(total) || total <= 0.0) {
        let nan = bitcast<f32>(0x7fc00000u);
        for (var k = 0u; k < w; k = k + 1u) {
            vm_st[base + k] = nan;
        }
        return;
    }
    // Finite weights past the f32 range together: scaled by WEIGHT_SCALE,
    // as the CPU's `choose`.
    var scale = 1.0;
    if (!is_finite(total)) {
        var all_finite = true;
        for (var j = 0u; j < n; j = j + 1u) {
            all_finite = all_finite && is_finite(vm_choose_weight(base, j, w));
        }
        if (all_finite) {
            scale = WEIGHT_SCALE;
            total = 0.0;
            for (var j = 0u; j < n; j = j + 1u) {
                total = total + vm_choose_weight(base, j, w) * scale;
            }
        }
    }
    let goal = u * total;
    var acc = 0.0;
    var pick = n;
    var last = 0u;
    for (var j = 0u; j < n; j = j + 1u) {
        let wj = vm_choose_weight(base, j, w);
        if (wj > 0.0) {
            last = j;
            acc = acc + wj * scale;
            if (goal < acc) {
                pick = j;
                break;
            }
        }
    }
    if (pick == n) {
        pick = last;
    }
    let src = base + pick * (w + 1u);
    for (var k = 0u; k < w; k = k + 1u) {
        vm_st[base + k] = vm_st[src + k];
    }
}

fn is_finite(x: f32) -> bool {
    return x == x && abs(x) <= 3.40282347e38;
}

// vm_param's findings (bits).
const VM_PARAM_FAULT: u32 = 1u;
const VM_PARAM_NON_FINITE: u32 = 2u;

// The words of one successor parameter (`pe`, grm_compile's ParamExpr)
// into vm_st[0 .. pe.words]: its constants, a copy of binding words, or
// its code run with draws `d`. Returns VM_PARAM_FAULT when the code
// faulted and VM_PARAM_NON_FINITE when a word it computed is not finite
// (constants and copies are not checked: they were when they were made).
fn vm_param(pe: ParamExpr, d: Draws) -> u32 {
    if (pe.kind == PARAM_CONST) {
        for (var c = 0u; c < pe.words; c = c + 1u) {
            vm_st[c] = vm_const(pe.a + c);
        }
        return 0u;
    }
    if (pe.kind == PARAM_COPY) {
        for (var c = 0u; c < pe.words; c = c + 1u) {
            vm_st[c] = vm_bind[pe.a + c];
        }
        return 0u;
    }
    var bad = 0u;
    if (vm_run(pe.a, d) == VM_FAULT) {
        bad = VM_PARAM_FAULT;
    }
    for (var c = 0u; c < pe.words; c = c + 1u) {
        if (!is_finite(vm_st[c])) {
            bad = bad | VM_PARAM_NON_FINITE;
        }
    }
    return bad;
}

// vm_run(entry, draws): run the expression at `entry`; returns the number
// of result words left in vm_st[0..], or VM_FAULT. The kernel's
// substitution names the file: vm_run.wgsl (the interpreter) or
// vm_run_none.wgsl (kernels for programs without code; grm-gpu's
// kernels.rs).
//!include VM_RUN
