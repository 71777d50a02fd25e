// Turtle commands of a module string (included after the including
// kernel's bindings `syms`, `starts`, `params` and `tsyms`, as turtle.wgsl
// and expand_turtle.wgsl declare them): each module's system, settings,
// command and arguments, and the affine transform of its command
// (`module_elem`).
// ---- module commands

// The system of module i (its symbol's bits above SYS_SHIFT; derive.wgsl).
fn sys_of(i: u32) -> u32 {
    return syms[i] >> SYS_SHIFT;
}

fn config_of(sys: u32) -> TurtleConfig {
    let b = sys * TURTLE_CONFIG_WORDS;
    return TurtleConfig(
        tsyms[b], bitcast<f32>(tsyms[b + 1u]), bitcast<f32>(tsyms[b + 2u]), bitcast<f32>(tsyms[b + 3u]),
        bitcast<f32>(tsyms[b + 4u]), bitcast<f32>(tsyms[b + 5u]), bitcast<f32>(tsyms[b + 6u]),
        bitcast<f32>(tsyms[b + 7u]), tsyms[b + 8u], tsyms[b + 9u], tsyms[b + 10u], tsyms[b + 11u],
    );
}

// The configuration of the module being worked on.
var<private> CFG: TurtleConfig;

fn op_of(i: u32) -> TurtleSym {
    let raw = syms[i];
    let b = config_of(raw >> SYS_SHIFT).syms + (raw & SYM_MASK) * TURTLE_SYM_WORDS;
    return TurtleSym(tsyms[b], bitcast<f32>(tsyms[b + 1u]));
}

fn nparams(i: u32) -> u32 {
    return starts[i + 1u] - starts[i];
}

fn arg(i: u32, k: u32, dflt: f32) -> f32 {
    if (k < nparams(i)) {
        return params[starts[i] + k];
    }
    return dflt;
}

fn arg3(i: u32, dflt: vec3<f32>) -> vec3<f32> {
    if (nparams(i) >= 3u) {
        let s = starts[i];
        return vec3<f32>(params[s], params[s + 1u], params[s + 2u]);
    }
    return dflt;
}

fn rot_x(a: f32) -> mat3x3<f32> {
    let s = sin(a);
    let c = cos(a);
    return mat3x3<f32>(1.0, 0.0, 0.0, 0.0, c, s, 0.0, -s, c);
}

fn rot_y(a: f32) -> mat3x3<f32> {
    let s = sin(a);
    let c = cos(a);
    return mat3x3<f32>(c, 0.0, -s, 0.0, 1.0, 0.0, s, 0.0, c);
}

fn rot_z(a: f32) -> mat3x3<f32> {
    let s = sin(a);
    let c = cos(a);
    return mat3x3<f32>(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0);
}

// glam's Mat3A::from_axis_angle (axis normalised).
fn rot_axis(axis: vec3<f32>, a: f32) -> mat3x3<f32> {
    let s = sin(a);
    let c = cos(a);
    let xs = axis * s;
    let a2 = axis * axis;
    let omc = 1.0 - c;
    let xy = axis.x * axis.y * omc;
    let xz = axis.x * axis.z * omc;
    let yz = axis.y * axis.z * omc;
    return mat3x3<f32>(
        a2.x * omc + c, xy + xs.z, xz - xs.y,
        xy - xs.z, a2.y * omc + c, yz + xs.x,
        xz + xs.y, yz - xs.x, a2.z * omc + c,
    );
}

fn finite(x: f32) -> bool {
    return x == x && abs(x) <= 3.40282347e38;
}

fn finite3(v: vec3<f32>) -> bool {
    return finite(v.x) && finite(v.y) && finite(v.z);
}

fn normalize_or_zero(v: vec3<f32>) -> vec3<f32> {
    let r = 1.0 / sqrt(dot(v, v));
    if (finite(r) && r > 0.0) {
        return v * r;
    }
    return vec3<f32>(0.0);
}

// The affine part of module i's command (identity for brackets, cuts,
// `$`, geometry and user modules). Its bone field is i for `F`/`G`.
fn module_elem(i: u32) -> TurtleElem {
    CFG = config_of(sys_of(i));
    var e = scan_identity();
    let o = op_of(i);
    let angle = arg(i, 0u, CFG.angle) * DEG_TO_RAD * o.sign;
    var m = mat3x3<f32>(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
    var t = vec3<f32>(0.0);
    switch o.op {
        case TOP_FORWARD: {
            t = vec3<f32>(0.0, arg(i, 0u, CFG.step), 0.0);
            e.bone = i;
        }
        case TOP_MOVE: {
            t = vec3<f32>(0.0, arg(i, 0u, CFG.step), 0.0);
        }
        case TOP_ROT_X: {
            m = rot_x(angle);
        }
        case TOP_ROT_Y: {
            m = rot_y(angle);
        }
        case TOP_ROT_Z: {
            m = rot_z(angle);
        }
        case TOP_TURN_AROUND: {
            m = mat3x3<f32>(-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0);
        }
        case TOP_SET_WIDTH: {
            let w = arg(i, 0u, CFG.width);
            if (finite(w)) {
                e.wa = 0.0;
                e.wb = max(w, 0.0);
            }
        }
        case TOP_SHRINK_WIDTH: {
            e.wa = SHRINK;
        }
        case TOP_TRANSLATE: {
            t = arg3(i, vec3<f32>(0.0));
        }
        case TOP_ROTATE: {
            let axis = arg3(i, vec3<f32>(0.0, 1.0, 0.0));
            let a = arg(i, 3u, CFG.angle) * DEG_TO_RAD;
            let len = length(axis);
            if (len > 1e-12 && finite(len)) {
                m = rot_axis(axis / len, a);
            }
        }
        case TOP_SCALE_UNIFORM: {
            let s = arg(i, 0u, 1.0);
            m = mat3x3<f32>(s, 0.0, 0.0, 0.0, s, 0.0, 0.0, 0.0, s);
        }
        case TOP_SCALE: {
            let s = arg3(i, vec3<f32>(1.0));
            m = mat3x3<f32>(s.x, 0.0, 0.0, 0.0, s.y, 0.0, 0.0, 0.0, s.z);
        }
        default: {}
    }
    set_frame(&e, m, t);
    return e;
}

