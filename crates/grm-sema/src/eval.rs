//! Evaluation of typed expressions: the one definition of what each operator
//! and built-in function computes. The checker folds constants with it, and
//! the CPU engine may call it too, so folded and run-time values agree.
//!
//! Semantics: angles are in degrees; `%` is the floored remainder
//! (`x - y * floor(x / y)`, the sign of the divisor); arithmetic on `vec3`
//! is component-wise, with a float on either side of `*` and `/`.

use crate::builtins::Builtin;
use crate::program::{BinaryOp, TExpr, TExprKind, UnaryOp, Value};

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
        TExprKind::Lit(v) => *v,
        TExprKind::Param(p) => *env.params.get(p.index()).ok_or(EvalError::Unbound)?,
        TExprKind::Global(c) => *env.globals.get(c.index()).ok_or(EvalError::Unbound)?,
        TExprKind::ModuleParam(s) => *env.bindings.get(*s as usize).ok_or(EvalError::Unbound)?,
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
        TExprKind::Error => return Err(EvalError::Broken),
    })
}

fn map1(v: Value, f: impl Fn(f64) -> f64) -> Value {
    match v {
        Value::Float(x) => Value::Float(f(x)),
        Value::Vec3([x, y, z]) => Value::Vec3([f(x), f(y), f(z)]),
        other => other,
    }
}

fn map2(a: Value, b: Value, f: impl Fn(f64, f64) -> f64) -> Value {
    match (a, b) {
        (Value::Float(x), Value::Float(y)) => Value::Float(f(x, y)),
        (Value::Vec3(u), Value::Vec3(v)) => {
            Value::Vec3([f(u[0], v[0]), f(u[1], v[1]), f(u[2], v[2])])
        }
        (Value::Vec3(u), Value::Float(y)) => Value::Vec3([f(u[0], y), f(u[1], y), f(u[2], y)]),
        (Value::Float(x), Value::Vec3(v)) => Value::Vec3([f(x, v[0]), f(x, v[1]), f(x, v[2])]),
        _ => Value::Float(f64::NAN),
    }
}

fn map3(a: Value, b: Value, c: Value, f: impl Fn(f64, f64, f64) -> f64) -> Value {
    let comp = |v: Value, i: usize| match v {
        Value::Float(x) => x,
        Value::Vec3(u) => u[i],
        _ => f64::NAN,
    };
    if matches!(a, Value::Vec3(_)) || matches!(b, Value::Vec3(_)) || matches!(c, Value::Vec3(_)) {
        Value::Vec3([0, 1, 2].map(|i| f(comp(a, i), comp(b, i), comp(c, i))))
    } else {
        Value::Float(f(comp(a, 0), comp(b, 0), comp(c, 0)))
    }
}

/// The floored remainder: the result has the sign of `y`.
pub fn floored_rem(x: f64, y: f64) -> f64 {
    x - y * (x / y).floor()
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
    let cmp = |f: fn(f64, f64) -> bool| match (a, b) {
        (Value::Float(x), Value::Float(y)) => Value::Bool(f(x, y)),
        _ => Value::Bool(false),
    };
    match op {
        Add => map2(a, b, |x, y| x + y),
        Sub => map2(a, b, |x, y| x - y),
        Mul => map2(a, b, |x, y| x * y),
        Div => map2(a, b, |x, y| x / y),
        Rem => map2(a, b, floored_rem),
        Lt => cmp(|x, y| x < y),
        Le => cmp(|x, y| x <= y),
        Gt => cmp(|x, y| x > y),
        Ge => cmp(|x, y| x >= y),
        Eq => Value::Bool(a == b),
        Ne => Value::Bool(a != b),
        And => Value::Bool(a.as_bool().unwrap_or(false) && b.as_bool().unwrap_or(false)),
        Or => Value::Bool(a.as_bool().unwrap_or(false) || b.as_bool().unwrap_or(false)),
    }
}

pub fn field(v: Value, i: u8) -> Value {
    match v {
        Value::Vec3(u) => Value::Float(u.get(i as usize).copied().unwrap_or(f64::NAN)),
        _ => Value::Float(f64::NAN),
    }
}

fn vec(v: Value) -> [f64; 3] {
    v.as_vec3().unwrap_or([f64::NAN; 3])
}

fn flt(v: Value) -> f64 {
    v.as_float().unwrap_or(f64::NAN)
}

/// Evaluate a built-in function on argument values of the checked types.
pub fn call(f: Builtin, args: &[Value]) -> Value {
    use Builtin::*;
    let a = |i: usize| args.get(i).copied().unwrap_or(Value::Float(f64::NAN));
    let deg = |x: f64| x.to_radians();
    match f {
        Sin => Value::Float(deg(flt(a(0))).sin()),
        Cos => Value::Float(deg(flt(a(0))).cos()),
        Tan => Value::Float(deg(flt(a(0))).tan()),
        Asin => Value::Float(flt(a(0)).asin().to_degrees()),
        Acos => Value::Float(flt(a(0)).acos().to_degrees()),
        Atan => Value::Float(flt(a(0)).atan().to_degrees()),
        Atan2 => Value::Float(flt(a(0)).atan2(flt(a(1))).to_degrees()),
        Sqrt => Value::Float(flt(a(0)).sqrt()),
        Exp => Value::Float(flt(a(0)).exp()),
        Ln => Value::Float(flt(a(0)).ln()),
        Log10 => Value::Float(flt(a(0)).log10()),
        Pow => Value::Float(flt(a(0)).powf(flt(a(1)))),
        Abs => map1(a(0), f64::abs),
        Floor => map1(a(0), f64::floor),
        Ceil => map1(a(0), f64::ceil),
        Round => map1(a(0), f64::round),
        Fract => map1(a(0), |x| x - x.floor()),
        Sign => map1(a(0), |x| {
            if x > 0.0 {
                1.0
            } else if x < 0.0 {
                -1.0
            } else {
                0.0
            }
        }),
        Min => map2(a(0), a(1), f64::min),
        Max => map2(a(0), a(1), f64::max),
        Clamp => map3(a(0), a(1), a(2), |x, lo, hi| x.max(lo).min(hi)),
        Mix => map3(a(0), a(1), a(2), |x, y, t| x * (1.0 - t) + y * t),
        Step => map2(a(0), a(1), |edge, x| if x < edge { 0.0 } else { 1.0 }),
        Smoothstep => map3(a(0), a(1), a(2), |e0, e1, x| {
            let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        }),
        Vec3 | Rgb => Value::Vec3([flt(a(0)), flt(a(1)), flt(a(2))]),
        Dot => {
            let (u, v) = (vec(a(0)), vec(a(1)));
            Value::Float(u[0] * v[0] + u[1] * v[1] + u[2] * v[2])
        }
        Cross => {
            let (u, v) = (vec(a(0)), vec(a(1)));
            Value::Vec3([
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ])
        }
        Length => {
            let u = vec(a(0));
            Value::Float((u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt())
        }
        Normalize => {
            let u = vec(a(0));
            let l = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
            // The zero vector normalizes to itself rather than to NaN.
            if l > 0.0 {
                Value::Vec3([u[0] / l, u[1] / l, u[2] / l])
            } else {
                Value::Vec3([0.0; 3])
            }
        }
        Distance => {
            let (u, v) = (vec(a(0)), vec(a(1)));
            let d = [u[0] - v[0], u[1] - v[1], u[2] - v[2]];
            Value::Float((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
        }
        Spline => spline(flt(a(0)), args.get(1..).unwrap_or(&[])),
    }
}

/// Uniform cubic B-spline over control values `c` (at least 4), `t` clamped
/// to [0, 1] and spread evenly over the `c.len() - 3` segments.
pub fn spline(t: f64, c: &[Value]) -> Value {
    if c.len() < 4 {
        return c.first().copied().unwrap_or(Value::Float(f64::NAN));
    }
    let segments = (c.len() - 3) as f64;
    let u = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) } * segments;
    let i = (u.floor() as usize).min(c.len() - 4);
    let s = u - i as f64;
    let s2 = s * s;
    let s3 = s2 * s;
    let b = [
        (1.0 - 3.0 * s + 3.0 * s2 - s3) / 6.0,
        (4.0 - 6.0 * s2 + 3.0 * s3) / 6.0,
        (1.0 + 3.0 * s + 3.0 * s2 - 3.0 * s3) / 6.0,
        s3 / 6.0,
    ];
    let mut acc = match c[i] {
        Value::Vec3(_) => Value::Vec3([0.0; 3]),
        _ => Value::Float(0.0),
    };
    for (k, w) in b.iter().enumerate() {
        let term = map2(c[i + k], Value::Float(*w), |x, y| x * y);
        acc = map2(acc, term, |x, y| x + y);
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floored_remainder_has_divisor_sign() {
        assert_eq!(floored_rem(-1.0, 360.0), 359.0);
        assert_eq!(floored_rem(370.0, 360.0), 10.0);
    }

    #[test]
    fn trig_is_in_degrees() {
        let v = call(Builtin::Sin, &[Value::Float(90.0)])
            .as_float()
            .unwrap();
        assert!((v - 1.0).abs() < 1e-12);
        let v = call(Builtin::Atan2, &[Value::Float(1.0), Value::Float(1.0)])
            .as_float()
            .unwrap();
        assert!((v - 45.0).abs() < 1e-12);
    }

    #[test]
    fn spline_of_equal_controls_is_constant() {
        let c = [Value::Float(2.0); 5];
        for t in [0.0, 0.3, 0.5, 1.0] {
            let v = spline(t, &c).as_float().unwrap();
            assert!((v - 2.0).abs() < 1e-12);
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
