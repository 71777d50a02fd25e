//! The expression bytecode: the one definition of the op set.
//!
//! Every expression of a compiled system (successor parameters, conditions,
//! weights) is straight-line code for a stack machine over `f32`. The CPU VM
//! ([`crate::vm`]) and the GPU interpreter (WGSL, generated from or checked
//! against [`Op::ALL`]) run the same words.
//!
//! # Encoding
//!
//! An instruction is one `u32` word: `op as u32 | operand << 8`. The low 8
//! bits are the opcode (the `#[repr(u32)]` discriminant below), the high 24
//! bits an unsigned operand (`0 ..= 0xFF_FFFF`). [`Op::RandChoose`] is the
//! only instruction followed by one extra word (its draw index). An
//! expression ends with [`Op::Ret`]; at `Ret` the stack holds exactly the
//! expression's value (1 word for `float`/`bool`, 3 for `vec3`).
//!
//! There are no jumps: `if c then a else b` evaluates both branches and
//! selects ([`Op::Select`]); `&&` and `||` evaluate both sides. Expressions
//! have no side effects (random draws are counter-based), so this is
//! observably the same as short-circuiting, and code runs without control
//! flow on a GPU. The maximal stack depth of every expression is computed
//! when it is compiled ([`crate::verify`]) and must not exceed
//! [`STACK_SIZE`].
//!
//! # Values
//!
//! - `float`: one slot; `vec3`: three consecutive slots `x y z` (x deepest);
//!   `bool`: one slot, `0.0` false / `1.0` true. A bool *read* is true when
//!   it is not `0.0` (so a NaN bool is true).
//! - Ops marked "width w" take the operand `w` (1 or 3) and work
//!   component-wise on `w`-slot values. A `float` mixed with a `vec3` is first
//!   widened by [`Op::Splat`].
//!
//! # f32 semantics
//!
//! IEEE 754 single precision, round to nearest even, no fused multiply-add:
//! every op rounds its result to f32. Division by zero gives `±inf` (or NaN
//! for `0 / 0`); NaN propagates through arithmetic. Comparisons with a NaN
//! operand are false, except `!=` which is true. `min`/`max` return the other
//! operand when one is NaN (IEEE minNum/maxNum). `%` is the floored
//! remainder `x - y * floor(x / y)` (sign of the divisor). `round` rounds
//! half away from zero (as `f32::round`; a WGSL interpreter must not use its
//! half-to-even `round`). `sign(0)` and `sign(NaN)` are 0. Trigonometry is in
//! degrees: `sin(x) = sin_rad(x * (PI / 180))` and the inverse functions
//! return `to_degrees(result)`. Transcendental functions (`sin`, `exp`, `ln`,
//! `pow`, ...) are not correctly rounded: CPU and GPU results agree to a
//! few ulps, not bit for bit; arithmetic, comparisons and the random hash
//! agree exactly.

/// Maximal stack depth (in f32 slots) of any expression.
pub const STACK_SIZE: usize = 64;

/// The largest operand an instruction word can carry.
pub const MAX_OPERAND: u32 = 0x00FF_FFFF;

/// How an op reads its operand, for disassembly, verification and the GPU
/// interpreter generator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Operand {
    /// No operand (must be 0).
    None,
    /// An index into the constant pool (`Const`) or the binding words (`Load`).
    Index,
    /// A width: 1 or 3.
    Width,
    /// A vec3 component: 0, 1 or 2.
    Component,
    /// A random draw index.
    Draw,
    /// `count | width << 16`: a number of values (`spline` control values,
    /// `choose` pairs) and their width.
    CountWidth,
}

/// Declares the op set once: discriminant, name, operand kind, pops and
/// pushes (as functions of the operand), extra words.
macro_rules! ops {
    ($(
        $(#[$m:meta])*
        $variant:ident = $code:literal, $name:literal, $operand:ident, $extra:literal;
    )*) => {
        /// A bytecode operation. Discriminants are the opcodes in the code
        /// words; they are stable (a GPU interpreter switches on them).
        #[repr(u32)]
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Op {
            $( $(#[$m])* $variant = $code, )*
        }

        impl Op {
            /// Every op, in opcode order.
            pub const ALL: &'static [Op] = &[ $( Op::$variant, )* ];

            /// The mnemonic used by the disassembler.
            pub const fn name(self) -> &'static str {
                match self { $( Op::$variant => $name, )* }
            }

            /// How the operand is read.
            pub const fn operand(self) -> Operand {
                match self { $( Op::$variant => Operand::$operand, )* }
            }

            /// Words following the instruction word (only `RandChoose` has one).
            pub const fn extra_words(self) -> u32 {
                match self { $( Op::$variant => $extra, )* }
            }

            /// The op with this opcode.
            pub fn from_code(code: u32) -> Option<Op> {
                match code { $( $code => Some(Op::$variant), )* _ => None }
            }

            /// The op with this mnemonic.
            pub fn from_name(name: &str) -> Option<Op> {
                match name { $( $name => Some(Op::$variant), )* _ => None }
            }
        }
    };
}

ops! {
    /// End of the expression; the stack holds its value.
    Ret = 0, "ret", None, 0;
    /// Push `consts[i]`.
    Const = 1, "const", Index, 0;
    /// Push `consts[i], consts[i+1], consts[i+2]`.
    Const3 = 2, "const3", Index, 0;
    /// Push binding word `i` (a parameter of a matched module).
    Load = 3, "load", Index, 0;
    /// Push binding words `i, i+1, i+2`.
    Load3 = 4, "load3", Index, 0;
    /// `x -> x x x`: widen a float to a vec3.
    Splat = 5, "splat", None, 0;
    /// `x y z -> c`: component `c` of a vec3 (`.x .y .z`).
    Pick = 6, "pick", Component, 0;
    /// Width w: `a -> -a`.
    Neg = 7, "neg", Width, 0;
    /// Width w: `a b -> a + b`.
    Add = 8, "add", Width, 0;
    /// Width w: `a b -> a - b`.
    Sub = 9, "sub", Width, 0;
    /// Width w: `a b -> a * b`.
    Mul = 10, "mul", Width, 0;
    /// Width w: `a b -> a / b`.
    Div = 11, "div", Width, 0;
    /// Width w: `a b -> a - b * floor(a / b)` (floored remainder).
    Rem = 12, "rem", Width, 0;
    /// Width w: `a b -> bool` all components equal.
    Eq = 13, "eq", Width, 0;
    /// Width w: `a b -> bool` some component differs.
    Ne = 14, "ne", Width, 0;
    /// `a b -> a < b`.
    Lt = 15, "lt", None, 0;
    /// `a b -> a <= b`.
    Le = 16, "le", None, 0;
    /// `a b -> a > b`.
    Gt = 17, "gt", None, 0;
    /// `a b -> a >= b`.
    Ge = 18, "ge", None, 0;
    /// `a -> !a`.
    Not = 19, "not", None, 0;
    /// `a b -> a && b` (both evaluated).
    And = 20, "and", None, 0;
    /// `a b -> a || b` (both evaluated).
    Or = 21, "or", None, 0;
    /// Width w: `c a b -> c ? a : b`.
    Select = 22, "select", Width, 0;
    /// `x -> sin(x degrees)`.
    Sin = 23, "sin", None, 0;
    /// `x -> cos(x degrees)`.
    Cos = 24, "cos", None, 0;
    /// `x -> tan(x degrees)`.
    Tan = 25, "tan", None, 0;
    /// `x -> asin(x)` in degrees.
    Asin = 26, "asin", None, 0;
    /// `x -> acos(x)` in degrees.
    Acos = 27, "acos", None, 0;
    /// `x -> atan(x)` in degrees.
    Atan = 28, "atan", None, 0;
    /// `y x -> atan2(y, x)` in degrees.
    Atan2 = 29, "atan2", None, 0;
    /// `x -> sqrt(x)`.
    Sqrt = 30, "sqrt", None, 0;
    /// `x -> e^x`.
    Exp = 31, "exp", None, 0;
    /// `x -> ln(x)`.
    Ln = 32, "ln", None, 0;
    /// `x -> log10(x)`.
    Log10 = 33, "log10", None, 0;
    /// `x y -> x^y`.
    Pow = 34, "pow", None, 0;
    /// Width w: `|a|`.
    Abs = 35, "abs", Width, 0;
    /// Width w: `floor(a)`.
    Floor = 36, "floor", Width, 0;
    /// Width w: `ceil(a)`.
    Ceil = 37, "ceil", Width, 0;
    /// Width w: `round(a)`, half away from zero.
    Round = 38, "round", Width, 0;
    /// Width w: `a - floor(a)`.
    Fract = 39, "fract", Width, 0;
    /// Width w: `-1, 0 or 1` (0 for NaN).
    Sign = 40, "sign", Width, 0;
    /// Width w: `a b -> min(a, b)`.
    Min = 41, "min", Width, 0;
    /// Width w: `a b -> max(a, b)`.
    Max = 42, "max", Width, 0;
    /// Width w: `edge x -> x < edge ? 0 : 1`.
    Step = 43, "step", Width, 0;
    /// Width w: `x lo hi -> min(max(x, lo), hi)`.
    Clamp = 44, "clamp", Width, 0;
    /// Width w: `x y t -> x * (1 - t) + y * t`.
    Mix = 45, "mix", Width, 0;
    /// Width w: `e0 e1 x -> t * t * (3 - 2 t)`, `t = clamp((x - e0) / (e1 - e0), 0, 1)`.
    Smoothstep = 46, "smoothstep", Width, 0;
    /// `u v -> u . v` (vec3, vec3 -> float).
    Dot = 47, "dot", None, 0;
    /// `u v -> u x v` (vec3).
    Cross = 48, "cross", None, 0;
    /// `u -> |u|`.
    Length = 49, "length", None, 0;
    /// `u -> u / |u|` (the zero vector stays zero).
    Normalize = 50, "normalize", None, 0;
    /// `u v -> |u - v|`.
    Distance = 51, "distance", None, 0;
    /// `count | width << 16`: `t c0 .. c(count-1) -> value`, uniform cubic
    /// B-spline (see `grm_sema::eval::spline`), `count >= 4`.
    Spline = 52, "spline", CountWidth, 0;
    /// Draw d: `a b -> a + (b - a) * u(d)`.
    RandUniform = 53, "rand.uniform", Draw, 0;
    /// Draw d (and d + 1): `mean sd -> mean + sd * z`, Box-Muller
    /// `z = sqrt(-2 ln(1 - u(d))) * cos(2 PI u(d + 1))` (radians, f32).
    RandNormal = 54, "rand.normal", Draw, 0;
    /// Draw d: `a b -> lo + min(floor(u(d) * (hi - lo + 1)), hi - lo)`,
    /// `lo = round(min(a, b))`, `hi = round(max(a, b))`.
    RandInt = 55, "rand.int", Draw, 0;
    /// Draw d: `p -> u(d) < p`.
    RandChance = 56, "rand.chance", Draw, 0;
    /// `count | width << 16`, then one word: the draw index d.
    /// `v0 w0 .. v(count-1) w(count-1) -> vk`, the first `k` with
    /// `u(d) * W < w0' + .. + wk'` where `wi' = max(wi, 0)` (NaN counts as 0)
    /// and `W` their sum; the last value if rounding leaves none; NaN (in
    /// every component) if `W` is not positive.
    RandChoose = 57, "rand.choose", CountWidth, 1;
}

impl Op {
    /// The instruction word for this op and operand (the operand must fit in
    /// 24 bits; the compiler checks it before encoding).
    pub const fn encode(self, operand: u32) -> u32 {
        self as u32 | (operand << 8)
    }

    /// `(pops, pushes)` in slots for an operand, or `None` when the operand
    /// is invalid for this op.
    pub fn stack_effect(self, operand: u32) -> Option<(u32, u32)> {
        let w = || match operand {
            1 | 3 => Some(operand),
            _ => None,
        };
        let count_width = || {
            let (n, w) = (operand & 0xFFFF, operand >> 16);
            match w {
                1 | 3 => Some((n, w)),
                _ => None,
            }
        };
        use Op::*;
        Some(match self {
            Ret => (0, 0),
            Const | Load => (0, 1),
            Const3 | Load3 => (0, 3),
            Splat => (1, 3),
            Pick => {
                if operand > 2 {
                    return None;
                }
                (3, 1)
            }
            Neg | Abs | Floor | Ceil | Round | Fract | Sign => {
                let w = w()?;
                (w, w)
            }
            Add | Sub | Mul | Div | Rem | Min | Max | Step => {
                let w = w()?;
                (2 * w, w)
            }
            Eq | Ne => (2 * w()?, 1),
            Lt | Le | Gt | Ge | And | Or | Atan2 | Pow => (2, 1),
            Not | Sin | Cos | Tan | Asin | Acos | Atan | Sqrt | Exp | Ln | Log10 => (1, 1),
            Select => {
                let w = w()?;
                (1 + 2 * w, w)
            }
            Clamp | Mix | Smoothstep => {
                let w = w()?;
                (3 * w, w)
            }
            Dot | Distance => (6, 1),
            Cross => (6, 3),
            Length => (3, 1),
            Normalize => (3, 3),
            Spline => {
                let (n, w) = count_width()?;
                if n < 4 {
                    return None;
                }
                (1 + n * w, w)
            }
            RandUniform | RandNormal | RandInt => (2, 1),
            RandChance => (1, 1),
            RandChoose => {
                let (n, w) = count_width()?;
                if n < 1 {
                    return None;
                }
                (n * (w + 1), w)
            }
        })
    }

    /// Whether the op draws random numbers.
    pub fn is_random(self) -> bool {
        matches!(
            self,
            Op::RandUniform | Op::RandNormal | Op::RandInt | Op::RandChance | Op::RandChoose
        )
    }
}

/// Split an instruction word into its opcode and operand.
pub const fn decode(word: u32) -> (u32, u32) {
    (word & 0xFF, word >> 8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opcodes_are_dense_and_round_trip() {
        for (i, op) in Op::ALL.iter().enumerate() {
            assert_eq!(*op as u32, i as u32, "{op:?} is not at its index");
            assert_eq!(Op::from_code(*op as u32), Some(*op));
            assert_eq!(Op::from_name(op.name()), Some(*op));
            let (code, operand) = decode(op.encode(0x12_3456));
            assert_eq!(code, *op as u32);
            assert_eq!(operand, 0x12_3456);
        }
        assert_eq!(Op::from_code(Op::ALL.len() as u32), None);
    }

    #[test]
    fn names_are_unique() {
        let mut names: Vec<&str> = Op::ALL.iter().map(|o| o.name()).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), Op::ALL.len());
    }

    #[test]
    fn width_ops_reject_other_widths() {
        assert_eq!(Op::Add.stack_effect(1), Some((2, 1)));
        assert_eq!(Op::Add.stack_effect(3), Some((6, 3)));
        assert_eq!(Op::Add.stack_effect(2), None);
        assert_eq!(Op::Pick.stack_effect(3), None);
        assert_eq!(Op::Spline.stack_effect(3 | 1 << 16), None);
        assert_eq!(Op::Spline.stack_effect(5 | 3 << 16), Some((16, 3)));
        assert_eq!(Op::RandChoose.stack_effect(2 | 1 << 16), Some((4, 1)));
    }
}
