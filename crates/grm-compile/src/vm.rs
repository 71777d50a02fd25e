//! The CPU interpreter of the expression bytecode ([`crate::op`]).
//!
//! A [`Vm`] owns a fixed stack of [`STACK_SIZE`] f32 slots and is reused for
//! every evaluation: evaluating allocates nothing. It trusts nothing either:
//! every stack access, constant and binding read is bounds-checked and a
//! broken program yields a [`VmError`] (with the code offset, which the span
//! table maps to source), never a panic. Code produced by the compiler is
//! verified ([`crate::verify`]) so these faults do not happen in practice.
//!
//! Semantics of each op: see [`crate::op`].

use crate::op::{Op, STACK_SIZE, decode};
use crate::rng::DrawCtx;

/// What went wrong while running code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VmFault {
    /// A word whose low byte is no opcode.
    BadOpcode(u32),
    /// An operand that the op does not accept.
    BadOperand,
    /// More than [`STACK_SIZE`] slots.
    StackOverflow,
    /// An op needed more slots than the stack had.
    StackUnderflow,
    /// The code ended without `ret`.
    CodeEnd,
    /// A constant index past the constant pool.
    ConstOutOfRange,
    /// A binding word past the binding array.
    BindOutOfRange,
}

impl std::fmt::Display for VmFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            VmFault::BadOpcode(c) => write!(f, "invalid opcode {c}"),
            VmFault::BadOperand => f.write_str("invalid operand"),
            VmFault::StackOverflow => write!(f, "stack overflow (more than {STACK_SIZE} slots)"),
            VmFault::StackUnderflow => f.write_str("stack underflow"),
            VmFault::CodeEnd => f.write_str("code ended without `ret`"),
            VmFault::ConstOutOfRange => f.write_str("constant index out of range"),
            VmFault::BindOutOfRange => f.write_str("binding word out of range"),
        }
    }
}

/// A fault at a code offset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VmError {
    /// Offset of the faulting instruction in the code array.
    pub pc: u32,
    pub fault: VmFault,
}

impl std::fmt::Display for VmError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "bytecode fault at {}: {}", self.pc, self.fault)
    }
}

impl std::error::Error for VmError {}

const CONST: u32 = Op::Const as u32;
const LOAD: u32 = Op::Load as u32;
const ADD1: u32 = Op::Add.encode(1);
const SUB1: u32 = Op::Sub.encode(1);
const MUL1: u32 = Op::Mul.encode(1);
const DIV1: u32 = Op::Div.encode(1);

/// The stack machine. Create one per thread and reuse it.
#[derive(Clone, Debug)]
pub struct Vm {
    stack: [f32; STACK_SIZE],
}

impl Default for Vm {
    fn default() -> Self {
        Vm::new()
    }
}

#[inline]
fn truthy(x: f32) -> bool {
    x != 0.0
}

#[inline]
fn b2f(b: bool) -> f32 {
    if b { 1.0 } else { 0.0 }
}

pub use grm_sema::scalar::floored_rem;
use grm_sema::scalar::{self, clamp};

/// `randint` on a uniform draw `u`; see [`Op::RandInt`]. Bounds whose
/// span passes the f32 range (`randint(-2e38, 2e38)`) draw between them
/// as [`rand_uniform`] does, rounded (every f32 that large is a whole
/// number).
#[inline]
pub fn rand_int(a: f32, b: f32, u: f32) -> f32 {
    if a.is_nan() || b.is_nan() {
        return f32::NAN;
    }
    let lo = a.min(b).round();
    let hi = a.max(b).round();
    let span = hi - lo;
    if !span.is_finite() && lo.is_finite() && hi.is_finite() {
        return clamp((lo * (1.0 - u) + hi * u).round(), lo, hi);
    }
    lo + (u * (span + 1.0)).floor().min(span)
}

/// `uniform(lo, hi)` on a uniform draw `u`; see [`Op::RandUniform`]. Finite
/// bounds whose difference passes the f32 range (`uniform(-3e38, 3e38)`)
/// are interpolated without forming it, so the value stays between them.
#[inline]
pub fn rand_uniform(lo: f32, hi: f32, u: f32) -> f32 {
    let span = hi - lo;
    if !span.is_finite() && lo.is_finite() && hi.is_finite() {
        return lo * (1.0 - u) + hi * u;
    }
    lo + span * u
}

impl Vm {
    pub fn new() -> Vm {
        Vm {
            stack: [0.0; STACK_SIZE],
        }
    }

    /// Run the expression at `entry` and return its value (1 or 3 words).
    ///
    /// `consts` is the constant pool, `bind` the binding words of the
    /// production being applied, `draws` the random context of the module
    /// being rewritten.
    pub fn run(
        &mut self,
        code: &[u32],
        consts: &[f32],
        entry: u32,
        bind: &[f32],
        draws: &DrawCtx,
    ) -> Result<&[f32], VmError> {
        let st = &mut self.stack;
        let mut sp: usize = 0;
        let mut pc = entry as usize;
        loop {
            let at = pc as u32;
            let err = |fault| VmError { pc: at, fault };
            let Some(&word) = code.get(pc) else {
                return Err(err(VmFault::CodeEnd));
            };
            pc += 1;
            // Fast path for the commonest instructions (loads and scalar
            // arithmetic), with the same checks and results as the general
            // path below.
            match word & 0xFF {
                CONST if sp < STACK_SIZE => {
                    st[sp] = *consts
                        .get((word >> 8) as usize)
                        .ok_or(err(VmFault::ConstOutOfRange))?;
                    sp += 1;
                    continue;
                }
                LOAD if sp < STACK_SIZE => {
                    st[sp] = *bind
                        .get((word >> 8) as usize)
                        .ok_or(err(VmFault::BindOutOfRange))?;
                    sp += 1;
                    continue;
                }
                _ if sp >= 2 && matches!(word, ADD1 | SUB1 | MUL1 | DIV1) => {
                    let (x, y) = (st[sp - 2], st[sp - 1]);
                    st[sp - 2] = match word {
                        ADD1 => x + y,
                        SUB1 => x - y,
                        MUL1 => x * y,
                        _ => x / y,
                    };
                    sp -= 1;
                    continue;
                }
                _ => {}
            }
            let (opcode, a) = decode(word);
            let Some(op) = Op::from_code(opcode) else {
                return Err(err(VmFault::BadOpcode(opcode)));
            };
            // Check the stack effect once, up front: afterwards every index
            // below is in bounds.
            let Some((pops, pushes)) = op.stack_effect(a) else {
                return Err(err(VmFault::BadOperand));
            };
            let (pops, pushes) = (pops as usize, pushes as usize);
            if sp < pops {
                return Err(err(VmFault::StackUnderflow));
            }
            let base = sp - pops;
            if base + pushes.max(pops) > STACK_SIZE {
                return Err(err(VmFault::StackOverflow));
            }
            let a = a as usize;
            match op {
                Op::Ret => return Ok(&st[..sp]),
                Op::Const => {
                    st[base] = *consts.get(a).ok_or(err(VmFault::ConstOutOfRange))?;
                }
                Op::Const3 => {
                    let c = consts.get(a..a + 3).ok_or(err(VmFault::ConstOutOfRange))?;
                    st[base..base + 3].copy_from_slice(c);
                }
                Op::Load => {
                    st[base] = *bind.get(a).ok_or(err(VmFault::BindOutOfRange))?;
                }
                Op::Load3 => {
                    let c = bind.get(a..a + 3).ok_or(err(VmFault::BindOutOfRange))?;
                    st[base..base + 3].copy_from_slice(c);
                }
                Op::Splat => {
                    let x = st[base];
                    st[base + 1] = x;
                    st[base + 2] = x;
                }
                Op::Pick => st[base] = st[base + a],
                Op::Neg => unary(&mut st[base..base + a], |x| -x),
                Op::Abs => unary(&mut st[base..base + a], f32::abs),
                Op::Floor => unary(&mut st[base..base + a], f32::floor),
                Op::Ceil => unary(&mut st[base..base + a], f32::ceil),
                Op::Round => unary(&mut st[base..base + a], f32::round),
                Op::Fract => unary(&mut st[base..base + a], scalar::fract),
                Op::Sign => unary(&mut st[base..base + a], scalar::sign),
                Op::Add => binary(st, base, a, |x, y| x + y),
                Op::Sub => binary(st, base, a, |x, y| x - y),
                Op::Mul => binary(st, base, a, |x, y| x * y),
                Op::Div => binary(st, base, a, |x, y| x / y),
                Op::Rem => binary(st, base, a, floored_rem),
                Op::Min => binary(st, base, a, f32::min),
                Op::Max => binary(st, base, a, f32::max),
                Op::Step => binary(st, base, a, scalar::step),
                Op::Eq | Op::Ne => {
                    let eq = (0..a).all(|k| st[base + k] == st[base + a + k]);
                    st[base] = b2f(eq == (op == Op::Eq));
                }
                Op::Lt => st[base] = b2f(st[base] < st[base + 1]),
                Op::Le => st[base] = b2f(st[base] <= st[base + 1]),
                Op::Gt => st[base] = b2f(st[base] > st[base + 1]),
                Op::Ge => st[base] = b2f(st[base] >= st[base + 1]),
                Op::Not => st[base] = b2f(!truthy(st[base])),
                Op::And => st[base] = b2f(truthy(st[base]) && truthy(st[base + 1])),
                Op::Or => st[base] = b2f(truthy(st[base]) || truthy(st[base + 1])),
                Op::Select => {
                    let from = if truthy(st[base]) {
                        base + 1
                    } else {
                        base + 1 + a
                    };
                    st.copy_within(from..from + a, base);
                }
                Op::Sin => st[base] = scalar::sin_deg(st[base]),
                Op::Cos => st[base] = scalar::cos_deg(st[base]),
                Op::Tan => st[base] = scalar::tan_deg(st[base]),
                Op::Asin => st[base] = scalar::asin_deg(st[base]),
                Op::Acos => st[base] = scalar::acos_deg(st[base]),
                Op::Atan => st[base] = scalar::atan_deg(st[base]),
                Op::Atan2 => st[base] = scalar::atan2_deg(st[base], st[base + 1]),
                Op::Sqrt => st[base] = st[base].sqrt(),
                Op::Exp => st[base] = st[base].exp(),
                Op::Ln => st[base] = st[base].ln(),
                Op::Log10 => st[base] = st[base].log10(),
                Op::Pow => st[base] = st[base].powf(st[base + 1]),
                Op::Clamp => ternary(st, base, a, clamp),
                Op::Mix => ternary(st, base, a, scalar::mix),
                Op::Smoothstep => ternary(st, base, a, scalar::smoothstep),
                Op::Dot => {
                    let (u, v) = vec2(st, base);
                    st[base] = scalar::dot(u, v);
                }
                Op::Cross => {
                    let (u, v) = vec2(st, base);
                    st[base..base + 3].copy_from_slice(&scalar::cross(u, v));
                }
                Op::Length => st[base] = scalar::length(vec1(st, base)),
                Op::Normalize => {
                    let u = scalar::normalize(vec1(st, base));
                    st[base..base + 3].copy_from_slice(&u);
                }
                Op::Distance => {
                    let (u, v) = vec2(st, base);
                    st[base] = scalar::distance(u, v);
                }
                Op::Spline => spline(st, base, a & 0xFFFF, a >> 16),
                Op::RandUniform => {
                    st[base] = rand_uniform(st[base], st[base + 1], draws.uniform(a as u32));
                }
                Op::RandNormal => {
                    let (mean, sd) = (st[base], st[base + 1]);
                    st[base] = mean + sd * draws.standard_normal(a as u32);
                }
                Op::RandInt => {
                    st[base] = rand_int(st[base], st[base + 1], draws.uniform(a as u32));
                }
                Op::RandChance => st[base] = b2f(draws.uniform(a as u32) < st[base]),
                Op::RandChoose => {
                    let Some(&draw) = code.get(pc) else {
                        return Err(err(VmFault::CodeEnd));
                    };
                    pc += 1;
                    choose(st, base, a & 0xFFFF, a >> 16, draws.uniform(draw));
                }
            }
            sp = base + pushes;
        }
    }

    /// Run an expression that leaves one word.
    pub fn run1(
        &mut self,
        code: &[u32],
        consts: &[f32],
        entry: u32,
        bind: &[f32],
        draws: &DrawCtx,
    ) -> Result<f32, VmError> {
        let v = self.run(code, consts, entry, bind, draws)?;
        Ok(v.first().copied().unwrap_or(f32::NAN))
    }
}

#[inline]
fn unary(xs: &mut [f32], f: impl Fn(f32) -> f32) {
    for x in xs {
        *x = f(*x);
    }
}

#[inline]
fn binary(st: &mut [f32; STACK_SIZE], base: usize, w: usize, f: impl Fn(f32, f32) -> f32) {
    for k in 0..w {
        st[base + k] = f(st[base + k], st[base + w + k]);
    }
}

#[inline]
fn ternary(st: &mut [f32; STACK_SIZE], base: usize, w: usize, f: impl Fn(f32, f32, f32) -> f32) {
    for k in 0..w {
        st[base + k] = f(st[base + k], st[base + w + k], st[base + 2 * w + k]);
    }
}

#[inline]
fn vec2(st: &[f32; STACK_SIZE], base: usize) -> ([f32; 3], [f32; 3]) {
    (
        [st[base], st[base + 1], st[base + 2]],
        [st[base + 3], st[base + 4], st[base + 5]],
    )
}

#[inline]
fn vec1(st: &[f32; STACK_SIZE], base: usize) -> [f32; 3] {
    [st[base], st[base + 1], st[base + 2]]
}

/// Uniform cubic B-spline over `n >= 4` control values of width `w`
/// following `t` at `base` ([`scalar::spline_weights`], as
/// `grm_sema::eval::spline`). The result overwrites `base .. base + w`.
fn spline(st: &mut [f32; STACK_SIZE], base: usize, n: usize, w: usize) {
    let (i, b) = scalar::spline_weights(st[base], n);
    let mut acc = [0.0f32; 3];
    for (k, bk) in b.iter().enumerate() {
        let c = base + 1 + (i + k) * w;
        for (j, a) in acc.iter_mut().enumerate().take(w) {
            *a += st[c + j] * bk;
        }
    }
    st[base..base + w].copy_from_slice(&acc[..w]);
}

/// `choose` over `n` pairs `(value of width w, weight)` at `base` with the
/// uniform draw `u`; see [`Op::RandChoose`]. The result overwrites
/// `base .. base + w`.
fn choose(st: &mut [f32; STACK_SIZE], base: usize, n: usize, w: usize, u: f32) {
    let weight = |j: usize| {
        let x = st[base + j * (w + 1) + w];
        if x > 0.0 { x } else { 0.0 }
    };
    let mut total = 0.0f32;
    for j in 0..n {
        total += weight(j);
    }
    if total.is_nan() || total <= 0.0 {
        st[base..base + w].fill(f32::NAN);
        return;
    }
    // Finite weights whose sum passes the f32 range: all scaled by an
    // exact power of two (`table::WEIGHT_SCALE`), as for productions.
    let mut scale = 1.0f32;
    if total.is_infinite() && (0..n).all(|j| weight(j).is_finite()) {
        scale = crate::table::WEIGHT_SCALE;
        total = 0.0;
        for j in 0..n {
            total += weight(j) * scale;
        }
    }
    let target = u * total;
    let mut acc = 0.0f32;
    let mut pick = None;
    let mut last = 0;
    for j in 0..n {
        let wj = weight(j);
        if wj > 0.0 {
            last = j;
            acc += wj * scale;
            if target < acc {
                pick = Some(j);
                break;
            }
        }
    }
    let j = pick.unwrap_or(last);
    let from = base + j * (w + 1);
    st.copy_within(from..from + w, base);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(code: &[u32], consts: &[f32], bind: &[f32]) -> Result<Vec<f32>, VmError> {
        let mut vm = Vm::new();
        let ctx = DrawCtx {
            seed: 1,
            iteration: 2,
            position: 3,
        };
        vm.run(code, consts, 0, bind, &ctx).map(|v| v.to_vec())
    }

    #[test]
    fn arithmetic_and_loads() {
        // bind[0] * consts[0] + consts[1]
        let code = [
            Op::Load.encode(0),
            Op::Const.encode(0),
            Op::Mul.encode(1),
            Op::Const.encode(1),
            Op::Add.encode(1),
            Op::Ret.encode(0),
        ];
        assert_eq!(run(&code, &[2.0, 0.5], &[3.0]).unwrap(), vec![6.5]);
    }

    #[test]
    fn vec_ops() {
        // vec3(1, 2, 3) * 2 then .y
        let code = [
            Op::Const3.encode(0),
            Op::Const.encode(3),
            Op::Splat.encode(0),
            Op::Mul.encode(3),
            Op::Pick.encode(1),
            Op::Ret.encode(0),
        ];
        assert_eq!(run(&code, &[1.0, 2.0, 3.0, 2.0], &[]).unwrap(), vec![4.0]);
        let code = [
            Op::Const3.encode(0),
            Op::Const3.encode(3),
            Op::Cross.encode(0),
            Op::Ret.encode(0),
        ];
        assert_eq!(
            run(&code, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0], &[]).unwrap(),
            vec![0.0, 0.0, 1.0]
        );
    }

    #[test]
    fn ieee_semantics() {
        let div = [
            Op::Const.encode(0),
            Op::Const.encode(1),
            Op::Div.encode(1),
            Op::Ret.encode(0),
        ];
        assert_eq!(run(&div, &[1.0, 0.0], &[]).unwrap(), vec![f32::INFINITY]);
        assert!(run(&div, &[0.0, 0.0], &[]).unwrap()[0].is_nan());
        let rem = [
            Op::Const.encode(0),
            Op::Const.encode(1),
            Op::Rem.encode(1),
            Op::Ret.encode(0),
        ];
        assert_eq!(run(&rem, &[-1.0, 360.0], &[]).unwrap(), vec![359.0]);
        let lt = [
            Op::Const.encode(0),
            Op::Const.encode(1),
            Op::Lt.encode(0),
            Op::Ret.encode(0),
        ];
        assert_eq!(run(&lt, &[f32::NAN, 1.0], &[]).unwrap(), vec![0.0]);
        let round = [Op::Const.encode(0), Op::Round.encode(1), Op::Ret.encode(0)];
        assert_eq!(run(&round, &[2.5], &[]).unwrap(), vec![3.0]);
        assert_eq!(run(&round, &[-2.5], &[]).unwrap(), vec![-3.0]);
    }

    #[test]
    fn degrees() {
        let sin = [Op::Const.encode(0), Op::Sin.encode(0), Op::Ret.encode(0)];
        assert!((run(&sin, &[90.0], &[]).unwrap()[0] - 1.0).abs() < 1e-6);
        let atan2 = [
            Op::Const.encode(0),
            Op::Const.encode(0),
            Op::Atan2.encode(0),
            Op::Ret.encode(0),
        ];
        assert!((run(&atan2, &[1.0], &[]).unwrap()[0] - 45.0).abs() < 1e-4);
    }

    #[test]
    fn select_picks_a_branch() {
        let code = [
            Op::Const.encode(0),
            Op::Const3.encode(1),
            Op::Const3.encode(4),
            Op::Select.encode(3),
            Op::Ret.encode(0),
        ];
        let consts = [1.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        assert_eq!(run(&code, &consts, &[]).unwrap(), vec![1.0, 2.0, 3.0]);
        let mut consts = consts;
        consts[0] = 0.0;
        assert_eq!(run(&code, &consts, &[]).unwrap(), vec![4.0, 5.0, 6.0]);
    }

    #[test]
    fn spline_of_equal_controls_is_constant() {
        let mut code = vec![Op::Const.encode(0)];
        for _ in 0..5 {
            code.push(Op::Const.encode(1));
        }
        code.push(Op::Spline.encode(5 | 1 << 16));
        code.push(Op::Ret.encode(0));
        for t in [0.0, 0.3, 1.0] {
            let v = run(&code, &[t, 2.0], &[]).unwrap()[0];
            assert!((v - 2.0).abs() < 1e-6);
        }
    }

    #[test]
    fn choose_respects_zero_weights() {
        // choose(10, 0, 20, 1): always 20.
        let code = [
            Op::Const.encode(0),
            Op::Const.encode(1),
            Op::Const.encode(2),
            Op::Const.encode(3),
            Op::RandChoose.encode(2 | 1 << 16),
            7,
            Op::Ret.encode(0),
        ];
        assert_eq!(
            run(&code, &[10.0, 0.0, 20.0, 1.0], &[]).unwrap(),
            vec![20.0]
        );
        assert!(run(&code, &[10.0, 0.0, 20.0, -1.0], &[]).unwrap()[0].is_nan());
    }

    #[test]
    fn randint_stays_in_range() {
        for k in 0..1000u32 {
            let u = crate::rng::uniform(3, 1, k, 1);
            let v = rand_int(4.0, 8.0, u);
            assert!((4.0..=8.0).contains(&v) && v.fract() == 0.0, "{v}");
        }
        assert_eq!(rand_int(3.0, 3.0, 0.999), 3.0);
        assert!(rand_int(f32::NAN, 3.0, 0.5).is_nan());
    }

    #[test]
    fn faults_not_panics() {
        assert_eq!(
            run(&[Op::Add.encode(1), Op::Ret.encode(0)], &[], &[])
                .unwrap_err()
                .fault,
            VmFault::StackUnderflow
        );
        assert_eq!(
            run(&[Op::Const.encode(5)], &[], &[]).unwrap_err().fault,
            VmFault::ConstOutOfRange
        );
        assert_eq!(
            run(&[Op::Load.encode(0), Op::Ret.encode(0)], &[], &[])
                .unwrap_err()
                .fault,
            VmFault::BindOutOfRange
        );
        assert_eq!(
            run(&[0xFF], &[], &[]).unwrap_err().fault,
            VmFault::BadOpcode(0xFF)
        );
        assert_eq!(run(&[], &[], &[]).unwrap_err().fault, VmFault::CodeEnd);
        assert_eq!(
            run(&[Op::Add.encode(2)], &[], &[]).unwrap_err().fault,
            VmFault::BadOperand
        );
        let deep: Vec<u32> = std::iter::repeat_n(Op::Const.encode(0), STACK_SIZE + 1).collect();
        assert_eq!(
            run(&deep, &[1.0], &[]).unwrap_err().fault,
            VmFault::StackOverflow
        );
    }
}
