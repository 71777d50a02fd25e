//! Static verification of one expression's bytecode: every opcode and
//! operand valid, every constant and binding read in range, the stack never
//! under- or overflowing [`STACK_SIZE`], and exactly the expression's value
//! left at `ret`. Code is straight-line, so one linear pass decides it.
//!
//! The compiler verifies every expression it emits; a GPU loader can verify
//! tables it did not build ([`crate::CompiledSystem::validate`]).

use crate::op::{Op, STACK_SIZE, decode};

/// Facts about a verified expression.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExprInfo {
    /// Words left at `ret` (1 or 3).
    pub width: u32,
    /// Deepest stack, in slots.
    pub max_depth: u32,
    /// Offset just past the expression's `ret`.
    pub end: u32,
}

/// Why an expression is not well formed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VerifyError {
    /// Offset of the offending instruction.
    pub pc: u32,
    pub kind: VerifyErrorKind,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VerifyErrorKind {
    BadOpcode(u32),
    BadOperand,
    StackUnderflow,
    /// The expression needs more than [`STACK_SIZE`] slots.
    StackOverflow {
        depth: u32,
    },
    CodeEnd,
    ConstOutOfRange,
    BindOutOfRange,
    /// `ret` with a stack depth other than 1 or 3, or not the expected width.
    BadResult {
        depth: u32,
    },
}

impl std::fmt::Display for VerifyError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "invalid bytecode at {}: ", self.pc)?;
        match self.kind {
            VerifyErrorKind::BadOpcode(c) => write!(f, "invalid opcode {c}"),
            VerifyErrorKind::BadOperand => f.write_str("invalid operand"),
            VerifyErrorKind::StackUnderflow => f.write_str("stack underflow"),
            VerifyErrorKind::StackOverflow { depth } => {
                write!(f, "needs {depth} stack slots, more than {STACK_SIZE}")
            }
            VerifyErrorKind::CodeEnd => f.write_str("code ends without `ret`"),
            VerifyErrorKind::ConstOutOfRange => f.write_str("constant index out of range"),
            VerifyErrorKind::BindOutOfRange => f.write_str("binding word out of range"),
            VerifyErrorKind::BadResult { depth } => {
                write!(f, "`ret` leaves {depth} slots")
            }
        }
    }
}

impl std::error::Error for VerifyError {}

/// Verify the expression starting at `entry`, with `consts` constants and
/// `bind_words` binding words available. With `width = Some(w)` the result
/// must have exactly `w` words.
pub fn verify_expr(
    code: &[u32],
    entry: u32,
    consts: usize,
    bind_words: u32,
    width: Option<u32>,
) -> Result<ExprInfo, VerifyError> {
    let mut pc = entry as usize;
    let mut depth: u32 = 0;
    let mut max_depth: u32 = 0;
    loop {
        let at = pc as u32;
        let fail = |kind| Err(VerifyError { pc: at, kind });
        let Some(&word) = code.get(pc) else {
            return fail(VerifyErrorKind::CodeEnd);
        };
        let (opcode, a) = decode(word);
        let Some(op) = Op::from_code(opcode) else {
            return fail(VerifyErrorKind::BadOpcode(opcode));
        };
        let Some((pops, pushes)) = op.stack_effect(a) else {
            return fail(VerifyErrorKind::BadOperand);
        };
        match op {
            Op::Const if a as usize >= consts => return fail(VerifyErrorKind::ConstOutOfRange),
            Op::Const3 if a as usize + 3 > consts => {
                return fail(VerifyErrorKind::ConstOutOfRange);
            }
            Op::Load if a >= bind_words => return fail(VerifyErrorKind::BindOutOfRange),
            Op::Load3 if a.saturating_add(3) > bind_words => {
                return fail(VerifyErrorKind::BindOutOfRange);
            }
            _ => {}
        }
        if op == Op::Ret {
            let ok = matches!(depth, 1 | 3) && width.is_none_or(|w| w == depth);
            if !ok {
                return fail(VerifyErrorKind::BadResult { depth });
            }
            return Ok(ExprInfo {
                width: depth,
                max_depth,
                end: at + 1,
            });
        }
        if depth < pops {
            return fail(VerifyErrorKind::StackUnderflow);
        }
        // Temporaries: an op never needs more than max(pops, pushes) slots
        // above the base.
        let peak = depth - pops + pushes.max(pops);
        depth = depth - pops + pushes;
        max_depth = max_depth.max(peak);
        if max_depth as usize > STACK_SIZE {
            return fail(VerifyErrorKind::StackOverflow { depth: max_depth });
        }
        pc += 1 + op.extra_words() as usize;
        if pc > code.len() {
            return fail(VerifyErrorKind::CodeEnd);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accepts_well_formed() {
        let code = [
            Op::Load.encode(0),
            Op::Const.encode(0),
            Op::Mul.encode(1),
            Op::Ret.encode(0),
        ];
        let info = verify_expr(&code, 0, 1, 1, Some(1)).unwrap();
        assert_eq!(
            info,
            ExprInfo {
                width: 1,
                max_depth: 2,
                end: 4
            }
        );
    }

    #[test]
    fn rejects_broken() {
        let k =
            |code: &[u32], consts, bind| verify_expr(code, 0, consts, bind, None).unwrap_err().kind;
        assert_eq!(
            k(&[Op::Ret.encode(0)], 0, 0),
            VerifyErrorKind::BadResult { depth: 0 }
        );
        assert_eq!(
            k(&[Op::Const.encode(1), Op::Ret.encode(0)], 1, 0),
            VerifyErrorKind::ConstOutOfRange
        );
        assert_eq!(
            k(&[Op::Load3.encode(0), Op::Ret.encode(0)], 0, 2),
            VerifyErrorKind::BindOutOfRange
        );
        assert_eq!(
            k(&[Op::Neg.encode(1)], 0, 0),
            VerifyErrorKind::StackUnderflow
        );
        assert_eq!(k(&[Op::Const.encode(0)], 1, 0), VerifyErrorKind::CodeEnd);
        assert_eq!(
            k(
                &[Op::Const.encode(0), Op::Const.encode(0), Op::Ret.encode(0)],
                1,
                0
            ),
            VerifyErrorKind::BadResult { depth: 2 }
        );
        assert_eq!(
            verify_expr(&[Op::Const3.encode(0), Op::Ret.encode(0)], 0, 3, 0, Some(1))
                .unwrap_err()
                .kind,
            VerifyErrorKind::BadResult { depth: 3 }
        );
    }
}
