//! Evaluation of typed expressions in the run-time arithmetic: 32-bit
//! floats ([`crate::scalar`], which the bytecode VM also calls), kept in
//! the f64 of [`Value`] but rounded to f32 at every step. The checker folds
//! constants with it, so a folded constant and the same expression
//! evaluated at run time give the same bits (`0.1 + 0.2 == 0.3` is true in
//! both; the literal `16777217` is 16777216 in both).
//!
//! Semantics: angles are in degrees; `%` is the floored remainder
//! (`x - y * floor(x / y)`, the sign of the divisor); arithmetic on `vec3`
//! is component-wise, with a float on either side of `*` and `/`.

use crate::builtins::Builtin;
use crate::program::{BinaryOp, TExpr, TExprKind, UnaryOp, Value};
use crate::scalar;

/// Values an expression may read.
#[derive(Clone, Copy, Debug)]
pub struct Env<'a> {
    /// Meta-parameter values, by [`crate::ParamId`].
    pub params: &'a [Value],
    /// Constant values, by [`crate::ConstId`] (see [`crate::Program::global_values`]).
    pub globals: &'a [Value],
    /// Binding slot values of the production being applied.
    pub bindings: &'a [Value],
}

/// Why an expression could not be evaluated without a run-time context.
#[derive(Clone, Debug, PartialEq)]
pub enum EvalError {
    /// The expression draws random numbers.
    Random,
    /// A reference outside the given environment.
    Unbound,
    /// The expression was already reported as broken.
    Broken,
}

impl std::fmt::Display for EvalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            EvalError::Random => "the expression draws random numbers",
            EvalError::Unbound => "the expression refers to a value that is not available",
            EvalError::Broken => "the expression has errors",
        })
    }
}

impl std::error::Error for EvalError {}

/// Evaluate an expression that draws no random numbers.
pub fn eval(e: &TExpr, env: &Env<'_>) -> Result<Value, EvalError> {
    Ok(match &e.kind {
        TExprKind::Lit(v) => rounded(*v),
        TExprKind::Param(p) => rounded(*env.params.get(p.index()).ok_or(EvalError::Unbound)?),
        TExprKind::Global(c) => rounded(*env.globals.get(c.index()).ok_or(EvalError::Unbound)?),
        TExprKind::ModuleParam(s) => {
            rounded(*env.bindings.get(*s as usize).ok_or(EvalError::Unbound)?)
        }
        TExprKind::Unary(op, a) => unary(*op, eval(a, env)?),
        TExprKind::Binary(op, a, b) => {
            // `&&` and `||` short-circuit.
            let x = eval(a, env)?;
            match (op, x) {
                (BinaryOp::And, Value::Bool(false)) => Value::Bool(false),
                (BinaryOp::Or, Value::Bool(true)) => Value::Bool(true),
                _ => binary(*op, x, eval(b, env)?),
            }
        }
        TExprKind::Field(a, i) => field(eval(a, env)?, *i),
        TExprKind::If(c, a, b) => {
            if eval(c, env)?.as_bool().unwrap_or(false) {
                eval(a, env)?
            } else {
                eval(b, env)?
            }
        }
        TExprKind::Call(f, args) => {
            let mut vs = Vec::with_capacity(args.len());
            for a in args {
                vs.push(eval(a, env)?);
            }
            call(*f, &vs)
        }
        TExprKind::Random(..) => return Err(EvalError::Random),
        TExprKind::Shape(_) => return Err(EvalError::Unbound),
        TExprKind::Error => return Err(EvalError::Broken),
    })
}

/// A setting's value: a number written as it is, exactly (settings are
/// read by the host, not computed at run time: `seed = 4294967295` is a
/// 32-bit seed no f32 holds), anything else as [`eval`] computes it.
pub fn eval_setting(e: &TExpr, env: &Env<'_>) -> Result<Value, EvalError> {
    match &e.kind {
        TExprKind::Lit(v) => Ok(*v),
        _ => eval(e, env),
    }
}

/// `x` rounded to the nearest 32-bit float (the run-time type), kept in
/// an f64 [`Value`].
#[inline]
pub fn round32(x: f64) -> f64 {
    x as f32 as f64
}

/// A value with every float component rounded to 32 bits.
pub fn rounded(v: Value) -> Value {
    match v {
        Value::Float(x) => Value::Float(round32(x)),
        Value::Vec3(u) => Value::Vec3(u.map(round32)),
        other => other,
    }
}

fn map1(v: Value, f: impl Fn(f32) -> f32) -> Value {
    let g = |x: f64| f(x as f32) as f64;
    match v {
        Value::Float(x) => Value::Float(g(x)),
        Value::Vec3([x, y, z]) => Value::Vec3([g(x), g(y), g(z)]),
        other => other,
    }
}

fn map2(a: Value, b: Value, f: impl Fn(f32, f32) -> f32) -> Value {
    let g = |x: f64, y: f64| f(x as f32, y as f32) as f64;
    match (a, b) {
        (Value::Float(x), Value::Float(y)) => Value::Float(g(x, y)),
        (Value::Vec3(u), Value::Vec3(v)) => {
            Value::Vec3([g(u[0], v[0]), g(u[1], v[1]), g(u[2], v[2])])
        }
        (Value::Vec3(u), Value::Float(y)) => Value::Vec3([g(u[0], y), g(u[1], y), g(u[2], y)]),
        (Value::Float(x), Value::Vec3(v)) => Value::Vec3([g(x, v[0]), g(x, v[1]), g(x, v[2])]),
        _ => Value::Float(f64::NAN),
    }
}

fn map3(a: Value, b: Value, c: Value, f: impl Fn(f32, f32, f32) -> f32) -> Value {
    let comp = |v: Value, i: usize| match v {
        Value::Float(x) => x as f32,
        Value::Vec3(u) => u[i] as f32,
        _ => f32::NAN,
    };
    let g = |i: usize| f(comp(a, i), comp(b, i), comp(c, i)) as f64;
    if matches!(a, Value::Vec3(_)) || matches!(b, Value::Vec3(_)) || matches!(c, Value::Vec3(_)) {
        Value::Vec3([0, 1, 2].map(g))
    } else {
        Value::Float(g(0))
    }
}

pub fn unary(op: UnaryOp, v: Value) -> Value {
    match (op, v) {
        (UnaryOp::Not, Value::Bool(b)) => Value::Bool(!b),
        (UnaryOp::Neg, v) => map1(v, |x| -x),
        (_, v) => v,
    }
}

pub fn binary(op: BinaryOp, a: Value, b: Value) -> Value {
    use BinaryOp::*;
    let cmp = |f: fn(f32, f32) -> bool| match (a, b) {
        (Value::Float(x), Value::Float(y)) => Value::Bool(f(x as f32, y as f32)),
        _ => Value::Bool(false),
    };
    match op {
        Add => map2(a, b, |x, y| x + y),
        Sub => map2(a, b, |x, y| x - y),
        Mul => map2(a, b, |x, y| x * y),
        Div => map2(a, b, |x, y| x / y),
        Rem => map2(a, b, scalar::floored_rem),
        Lt => cmp(|x, y| x < y),
        Le => cmp(|x, y| x <= y),
        Gt => cmp(|x, y| x > y),
        Ge => cmp(|x, y| x >= y),
        Eq => Value::Bool(rounded(a) == rounded(b)),
        Ne => Value::Bool(rounded(a) != rounded(b)),
        And => Value::Bool(a.as_bool().unwrap_or(false) && b.as_bool().unwrap_or(false)),
        Or => Value::Bool(a.as_bool().unwrap_or(false) || b.as_bool().unwrap_or(false)),
    }
}

pub fn field(v: Value, i: u8) -> Value {
    match v {
        Value::Vec3(u) => Value::Float(u.get(i as usize).copied().map_or(f64::NAN, round32)),
        _ => Value::Float(f64::NAN),
    }
}

fn vec(v: Value) -> [f32; 3] {
    v.as_vec3().unwrap_or([f64::NAN; 3]).map(|x| x as f32)
}

fn flt(v: Value) -> f32 {
    v.as_float().unwrap_or(f64::NAN) as f32
}

fn float(x: f32) -> Value {
    Value::Float(x as f64)
}

fn vec3(u: [f32; 3]) -> Value {
    Value::Vec3(u.map(|x| x as f64))
}

/// Evaluate a built-in function on argument values of the checked types.
pub fn call(f: Builtin, args: &[Value]) -> Value {
    use Builtin::*;
    let a = |i: usize| args.get(i).copied().unwrap_or(Value::Float(f64::NAN));
    match f {
        Sin => float(scalar::sin_deg(flt(a(0)))),
        Cos => float(scalar::cos_deg(flt(a(0)))),
        Tan => float(scalar::tan_deg(flt(a(0)))),
        Asin => float(scalar::asin_deg(flt(a(0)))),
        Acos => float(scalar::acos_deg(flt(a(0)))),
        Atan => float(scalar::atan_deg(flt(a(0)))),
        Atan2 => float(scalar::atan2_deg(flt(a(0)), flt(a(1)))),
        Sqrt => float(flt(a(0)).sqrt()),
        Exp => float(flt(a(0)).exp()),
        Ln => float(flt(a(0)).ln()),
        Log10 => float(flt(a(0)).log10()),
        Pow => float(flt(a(0)).powf(flt(a(1)))),
        Abs => map1(a(0), f32::abs),
        Floor => map1(a(0), f32::floor),
        Ceil => map1(a(0), f32::ceil),
        Round => map1(a(0), f32::round),
        Fract => map1(a(0), scalar::fract),
        Sign => map1(a(0), scalar::sign),
        Min => map2(a(0), a(1), f32::min),
        Max => map2(a(0), a(1), f32::max),
        Clamp => map3(a(0), a(1), a(2), scalar::clamp),
        Mix => map3(a(0), a(1), a(2), scalar::mix),
        Step => map2(a(0), a(1), scalar::step),
        Smoothstep => map3(a(0), a(1), a(2), scalar::smoothstep),
        Vec3 | Rgb => Value::Vec3([a(0), a(1), a(2)].map(|v| flt(v) as f64)),
        Dot => float(scalar::dot(vec(a(0)), vec(a(1)))),
        Cross => vec3(scalar::cross(vec(a(0)), vec(a(1)))),
        Length => float(scalar::length(vec(a(0)))),
        Normalize => vec3(scalar::normalize(vec(a(0)))),
        Distance => float(scalar::distance(vec(a(0)), vec(a(1)))),
        Spline => spline(flt(a(0)), args.get(1..).unwrap_or(&[])),
    }
}

/// Uniform cubic B-spline over control values `c` (at least 4), `t` clamped
/// to [0, 1] and spread evenly over the `c.len() - 3` segments
/// ([`scalar::spline_weights`]).
pub fn spline(t: f32, c: &[Value]) -> Value {
    if c.len() < 4 {
        return c.first().copied().map_or(Value::Float(f64::NAN), rounded);
    }
    let (i, w) = scalar::spline_weights(t, c.len());
    let mut acc = match c[i] {
        Value::Vec3(_) => Value::Vec3([0.0; 3]),
        _ => Value::Float(0.0),
    };
    for (k, wk) in w.iter().enumerate() {
        let term = map2(c[i + k], float(*wk), |x, y| x * y);
        acc = map2(acc, term, |x, y| x + y);
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trig_is_in_degrees() {
        let v = call(Builtin::Sin, &[Value::Float(90.0)])
            .as_float()
            .unwrap();
        assert!((v - 1.0).abs() < 1e-6);
        let v = call(Builtin::Atan2, &[Value::Float(1.0), Value::Float(1.0)])
            .as_float()
            .unwrap();
        assert!((v - 45.0).abs() < 1e-5);
    }

    #[test]
    fn spline_of_equal_controls_is_constant() {
        let c = [Value::Float(2.0); 5];
        for t in [0.0, 0.3, 0.5, 1.0] {
            let v = spline(t, &c).as_float().unwrap();
            assert!((v - 2.0).abs() < 1e-6);
        }
    }

    #[test]
    fn vec_times_float() {
        let v = binary(
            BinaryOp::Mul,
            Value::Vec3([1.0, 2.0, 3.0]),
            Value::Float(2.0),
        );
        assert_eq!(v, Value::Vec3([2.0, 4.0, 6.0]));
    }
}
