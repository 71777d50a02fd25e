//! Sketched meta-parameters (Merz et al., seed 004): keyframes of a
//! part's pose over a new parameter t in [0, 1] become the source
//! numbers that place it written as interpolating splines of t.
//!
//! The spline is the piecewise-linear B-spline through the keyframes,
//! written with `mix` (which every engine computes as `a * (1 - t) + b *
//! t`): t = 0 gives each number exactly as written, t = 1 exactly the
//! solved value, and an intermediate keyframe's value to within one
//! rounding. `spline(...)`, the language's cubic B-spline, approximates
//! its control values and passes through none of them, so the tool does
//! not emit it.

use serde::Serialize;

use crate::candidates::{self, CandidateKind, format_number};
use crate::probe::{self, Setup};
use crate::solve::{Change, DragOutcome, Manip};
use crate::{ManipError, Part, Target, TextEdit};

/// A sketched pose of the part at parameter value `t` (0 < t <= 1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct Keyframe {
    pub t: f64,
    pub target: Target,
}

/// The proposed meta-parameter.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct SketchOutcome {
    pub name: String,
    /// The edits of the root file: the `param` declaration and each
    /// number rewritten as a spline of it.
    pub edits: Vec<TextEdit>,
    /// The edited text.
    #[serde(skip)]
    pub text: String,
    /// The numbers the t = 1 pose changes.
    pub changes: Vec<Change>,
    /// Per keyframe: t and the part's distance from its sketched pose when
    /// the edited text is grown at that t.
    pub residuals: Vec<(f64, f64)>,
    /// Whether t = 0 grows the original model exactly (every part's
    /// measures bit for bit).
    pub exact_at_zero: bool,
}

/// The language's keywords (grm-syntax's lexer).
const KEYWORDS: [&str; 18] = [
    "import", "const", "param", "mesh", "material", "system", "module", "skeleton", "geometry",
    "wrapup", "axiom", "ignore", "in", "if", "then", "else", "true", "false",
];

fn valid_name(name: &str) -> bool {
    let mut cs = name.chars();
    cs.next().is_some_and(|c| c.is_alphabetic() || c == '_')
        && cs.all(|c| c.is_alphanumeric() || c == '_')
        && !KEYWORDS.contains(&name)
}

impl Manip {
    /// A setup like this one's with these parameter values.
    fn at_t(&self, params: &[String]) -> Setup {
        Setup {
            params: params.to_vec(),
            ..self.setup.clone()
        }
    }

    /// Propose the meta-parameter `name` that sweeps `part` from where it
    /// is (t = 0) through the keyframes (t = 1 required).
    pub fn sketch(
        &self,
        part: &Part,
        keyframes: &[Keyframe],
        name: &str,
    ) -> Result<SketchOutcome, ManipError> {
        if !valid_name(name) {
            return Err(ManipError::Mismatch {
                why: format!("`{name}` is not a name a meta-parameter can have"),
            });
        }
        let taken = grm_syntax::lexer::lex(grm_diag::FileId(0), &self.text)
            .tokens
            .iter()
            .any(|t| t.text == name);
        if taken {
            return Err(ManipError::Mismatch {
                why: format!("`{name}` is already used in this file: choose another name"),
            });
        }
        let mut keys: Vec<Keyframe> = keyframes.to_vec();
        keys.sort_by(|a, b| a.t.total_cmp(&b.t));
        if keys.iter().any(|k| !(k.t > 0.0 && k.t <= 1.0)) {
            return Err(ManipError::Mismatch {
                why: "every keyframe's t lies in (0, 1]: t = 0 is the model as it is".into(),
            });
        }
        keys.dedup_by(|a, b| a.t == b.t);
        let Some(last) = keys.last().filter(|k| k.t == 1.0) else {
            return Err(ManipError::Mismatch {
                why: "a sketch needs the pose at t = 1".into(),
            });
        };
        let solution = match self.drag(part, &last.target)? {
            DragOutcome::Solved(s) => s,
            DragOutcome::Unchanged => {
                return Err(ManipError::Mismatch {
                    why: "the pose at t = 1 is the model as it is: nothing to sweep".into(),
                });
            }
            DragOutcome::Unreachable { why, .. } => return Err(ManipError::Unsupported { why }),
        };
        let cands: Vec<usize> = solution.changes.iter().map(|c| c.candidate).collect();
        // Values at each keyframe: the t = 1 solution's, the others solved
        // with the same numbers.
        let mut values: Vec<Vec<f64>> = Vec::new();
        for k in &keys[..keys.len() - 1] {
            let base = self.measures(part)?;
            let g0 = k.target.residual(part, &base)?;
            let v = self
                .solve_with(part, &k.target, &cands, &g0)
                .ok_or_else(|| ManipError::Unsupported {
                    why: format!(
                        "the pose at t = {} is not reached by the numbers the pose at t = 1 changes",
                        k.t
                    ),
                })?;
            values.push(v);
        }
        values.push(solution.changes.iter().map(|c| c.value).collect());
        // Each number as a spline of the parameter.
        let mut edits: Vec<TextEdit> = Vec::new();
        for (j, &c) in cands.iter().enumerate() {
            let cand = &self.candidates[c];
            let mut knots: Vec<(f64, String)> = vec![(
                0.0,
                match cand.kind {
                    CandidateKind::Literal => cand.text.clone(),
                    CandidateKind::Name { .. } => "0".into(),
                },
            )];
            for (k, v) in keys.iter().zip(&values) {
                knots.push((k.t, format_number(v[j], 6)));
            }
            let spline = piecewise(name, &knots);
            let text = match &cand.kind {
                CandidateKind::Literal => spline,
                CandidateKind::Name { name: n } if cand.bare => format!("{n} + {spline}"),
                CandidateKind::Name { name: n } => format!("({n} + {spline})"),
            };
            edits.push(TextEdit {
                span: cand.span,
                text,
            });
        }
        edits.push(self.param_declaration(name));
        let text = candidates::apply(
            &self.text,
            &edits
                .iter()
                .map(|e| (e.span, e.text.clone()))
                .collect::<Vec<_>>(),
        );
        // Grown at t = 0 and at every keyframe.
        let mut params = self.setup.params.to_vec();
        params.push(format!("{name}=0"));
        let zero = probe::grow(&self.at_t(&params), &text)?;
        let exact_at_zero = zero.measures == self.base.measures;
        let mut residuals = Vec::new();
        for k in &keys {
            *params.last_mut().expect("the parameter") = format!("{name}={}", k.t);
            let snap = probe::grow(&self.at_t(&params), &text)?;
            let m = snap
                .get(&Manip::measure(part))
                .ok_or(ManipError::NoPart { part: *part })?;
            let r = k.target.residual(part, m)?;
            residuals.push((k.t, r.iter().map(|x| x * x).sum::<f64>().sqrt()));
        }
        Ok(SketchOutcome {
            name: name.to_string(),
            edits,
            text,
            changes: solution.changes,
            residuals,
            exact_at_zero,
        })
    }

    /// `param NAME = 0 in 0 .. 1;` after the file's last `param` (or
    /// before the system's line).
    fn param_declaration(&self, name: &str) -> TextEdit {
        let decl = format!("param {name} = 0 in 0 .. 1;");
        match self.facts.params_end {
            Some(end) => TextEdit {
                span: grm_diag::Span::new(end, end),
                text: format!("\n{decl}"),
            },
            None => {
                let at = self.text[..self.facts.system.start as usize]
                    .rfind('\n')
                    .map_or(0, |i| i + 1) as u32;
                TextEdit {
                    span: grm_diag::Span::new(at, at),
                    text: format!("{decl}\n\n"),
                }
            }
        }
    }
}

/// The piecewise-linear spline through `knots` (t from 0 to 1, values as
/// written), exact at t = 0 and t = 1: the last piece runs from its end.
fn piecewise(t: &str, knots: &[(f64, String)]) -> String {
    let n = knots.len() - 1;
    if n == 1 {
        return format!("mix({}, {}, {t})", knots[0].1, knots[1].1);
    }
    let num = |x: f64| format_number(x, 6);
    let mut out = String::new();
    for i in 0..n {
        let (a, b) = (&knots[i], &knots[i + 1]);
        let piece = if i == n - 1 {
            format!("mix({}, {}, (1 - {t}) / {})", b.1, a.1, num(1.0 - a.0))
        } else if i == 0 {
            format!("mix({}, {}, {t} / {})", a.1, b.1, num(b.0))
        } else {
            format!(
                "mix({}, {}, ({t} - {}) / {})",
                a.1,
                b.1,
                num(a.0),
                num(b.0 - a.0)
            )
        };
        if i < n - 1 {
            out.push_str(&format!("if {t} < {} then {piece} else ", num(b.0)));
        } else {
            out.push_str(&piece);
        }
    }
    format!("({out})")
}

#[cfg(test)]
mod tests {
    use super::piecewise;

    #[test]
    fn splines_are_written_exact_at_their_ends() {
        let k = |t: f64, v: &str| (t, v.to_string());
        assert_eq!(
            piecewise("t", &[k(0.0, "3.2"), k(1.0, "4")]),
            "mix(3.2, 4, t)"
        );
        assert_eq!(
            piecewise("t", &[k(0.0, "1"), k(0.5, "2"), k(1.0, "5")]),
            "(if t < 0.5 then mix(1, 2, t / 0.5) else mix(5, 2, (1 - t) / 0.5))"
        );
    }
}
