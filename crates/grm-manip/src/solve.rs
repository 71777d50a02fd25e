//! Provenance and drags: finite differences through the real engines,
//! Gauss-Newton over the fewest source numbers, every step grown.

use std::sync::OnceLock;

use grm_diag::Span;
use serde::Serialize;

use crate::candidates::{self, Candidate, CandidateKind, exact_number, format_number};
use crate::probe::{self, Facts, Grown, Measure, Setup, Snapshot};
use crate::{ManipError, Part, Target, TextEdit, part_name};

/// A root text ready to be manipulated: its base growth and candidates.
pub struct Manip {
    pub(crate) setup: Setup,
    pub(crate) text: String,
    pub(crate) facts: Facts,
    pub(crate) candidates: Vec<Candidate>,
    pub(crate) base: Snapshot,
    /// Per candidate: its probe (step, growth), grown on first need;
    /// `None` when the perturbed text does not grow.
    probes: Vec<OnceLock<Option<(f64, Snapshot)>>>,
    /// Per candidate: its probe the other way (provenance's smoothness).
    back: Vec<OnceLock<Option<Snapshot>>>,
    /// The largest distance a solved part may be from its target.
    pub tolerance: f64,
    /// Texts grown since the base (probes and trials).
    growths: std::sync::atomic::AtomicUsize,
}

impl std::fmt::Debug for Manip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Manip")
            .field("setup", &self.setup)
            .field("candidates", &self.candidates.len())
            .field("tolerance", &self.tolerance)
            .finish_non_exhaustive()
    }
}

/// A part of the base growth.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct PartInfo {
    pub part: Part,
    /// What it is: a shape's path of symbols, a plane's command and part,
    /// a bone's number and symbol.
    pub label: String,
    pub measures: Vec<f64>,
}

/// One source of a part: a candidate whose change moves it.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Source {
    #[serde(flatten)]
    pub candidate: Candidate,
    /// The derivative of each of the part's measures with respect to the
    /// candidate's value (forward difference, `step`).
    pub derivative: Vec<f64>,
    pub step: f64,
    /// Whether the part moves smoothly with it: a step either way gives
    /// the same derivative (a number that changes a count, a repeat's
    /// tiles or a choice, does not).
    pub smooth: bool,
    /// Terminal parts (leaf shapes, bones) that move with it.
    pub moves: usize,
}

/// What places a part.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Provenance {
    pub part: Part,
    pub mode: Grown,
    pub system: String,
    /// The part's measures now (a shape: corner, size, x axis, z axis; a
    /// plane: its distance; a bone: base, tip).
    pub measures: Vec<f64>,
    /// The candidates that move it, in source order.
    pub sources: Vec<Source>,
    /// Whether a random draw's arguments move it (it is placed, in part,
    /// by a draw).
    pub random: bool,
    /// Candidates probed (every source number of the system).
    pub probed: usize,
}

/// One number changed by a solution.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Change {
    pub candidate: usize,
    pub span: Span,
    /// As written before.
    pub old: String,
    /// As written after (`2.75`, `STOREY + 0.4`).
    pub new: String,
    /// The candidate's new value (a name's offset).
    pub value: f64,
}

/// A solved drag.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Solution {
    pub changes: Vec<Change>,
    /// The root file's text with the changes.
    #[serde(skip)]
    pub text: String,
    /// The edits, by span of the root file.
    pub edits: Vec<TextEdit>,
    /// The part's distance from the target after the edit (grown).
    pub residual: f64,
    /// Terminal parts that move (the part itself included).
    pub moved: usize,
    /// The part's measures after the edit.
    pub measures: Vec<f64>,
}

/// The answer to a drag.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "camelCase", tag = "outcome")]
pub enum DragOutcome {
    /// The fewest changes that reproduce the drag.
    Solved(Solution),
    /// The part is already there.
    Unchanged,
    /// Nothing expressible reproduces it: why, and the closest reached.
    Unreachable {
        why: String,
        #[serde(skip_serializing_if = "Option::is_none")]
        closest: Option<Solution>,
    },
}

/// A trial: candidates and their values (a literal's value, a name's
/// offset), grown.
struct Trial {
    values: Vec<f64>,
    residual: Vec<f64>,
    snap: Snapshot,
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

impl Manip {
    /// Grow `text` as `setup` says and find its candidates.
    pub fn new(setup: Setup, text: &str) -> Result<Self, ManipError> {
        let facts = probe::facts(&setup, text)?;
        let candidates = candidates::find(text, facts.system, &facts.consts, &facts.names);
        let base = probe::grow_labelled(&setup, text)?;
        let probes = candidates.iter().map(|_| OnceLock::new()).collect();
        let back = candidates.iter().map(|_| OnceLock::new()).collect();
        Ok(Manip {
            setup,
            text: text.to_string(),
            facts,
            candidates,
            base,
            probes,
            back,
            tolerance: 1e-3,
            growths: std::sync::atomic::AtomicUsize::new(0),
        })
    }

    /// Grow an edited text (a probe, a trial), counted.
    fn grow(&self, text: &str) -> Result<Snapshot, ManipError> {
        self.growths
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        probe::grow(&self.setup, text)
    }

    /// How many edited texts were grown so far (each probe once: a drag
    /// after a provenance of the same part grows only its trials).
    pub fn growths(&self) -> usize {
        self.growths.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// How many parts the base growth measured (shapes, planes, bones).
    pub fn part_count(&self) -> usize {
        self.base.measures.len()
    }

    /// Every candidate source number of the system.
    pub fn candidates(&self) -> &[Candidate] {
        &self.candidates
    }

    /// Every part a drag can move, named in words, with its measures:
    /// shapes, split and repeat planes (shape mode), bones (derive mode),
    /// ordered by what they are.
    pub fn parts(&self) -> Vec<PartInfo> {
        let mut out: Vec<PartInfo> = self
            .base
            .measures
            .iter()
            .map(|(m, v)| PartInfo {
                part: match *m {
                    Measure::Shape(key) => Part::Shape { key },
                    Measure::Plane(command, edge) => Part::Plane { command, edge },
                    Measure::Bone(key) => Part::Bone { key },
                },
                label: self.base.labels.get(m).cloned().unwrap_or_default(),
                measures: v.clone(),
            })
            .collect();
        out.sort_by(|a, b| {
            a.label.cmp(&b.label).then(
                a.measures
                    .iter()
                    .partial_cmp(b.measures.iter())
                    .unwrap_or(std::cmp::Ordering::Equal),
            )
        });
        out
    }

    /// The engine the system grows on.
    pub fn mode(&self) -> Grown {
        self.facts.mode
    }

    pub(crate) fn measure(part: &Part) -> Measure {
        match *part {
            Part::Shape { key } => Measure::Shape(key),
            Part::Plane { command, edge } => Measure::Plane(command, edge),
            Part::Bone { key } => Measure::Bone(key),
        }
    }

    /// The part's measures in the base growth.
    pub fn measures(&self, part: &Part) -> Result<Vec<f64>, ManipError> {
        self.base
            .get(&Self::measure(part))
            .map(<[f64]>::to_vec)
            .ok_or(ManipError::NoPart { part: *part })
    }

    /// The text with candidates set to `values` (written exactly).
    pub(crate) fn text_with(&self, cands: &[usize], values: &[f64]) -> String {
        let edits: Vec<(Span, String)> = cands
            .iter()
            .zip(values)
            .map(|(&c, &v)| {
                let cand = &self.candidates[c];
                (cand.span, cand.replacement(v, &exact_number))
            })
            .collect();
        candidates::apply(&self.text, &edits)
    }

    /// The probe of candidate `c`: its value moved by a small step.
    fn probe(&self, c: usize) -> Option<&(f64, Snapshot)> {
        self.probes[c]
            .get_or_init(|| {
                let cand = &self.candidates[c];
                let step = match cand.kind {
                    CandidateKind::Literal => 1e-3 * cand.value.abs().max(1.0),
                    CandidateKind::Name { .. } => 1e-2,
                };
                let text = self.text_with(&[c], &[cand.value + step]);
                self.grow(&text).ok().map(|s| (step, s))
            })
            .as_ref()
    }

    /// Whether a random draw's arguments move the part: a literal or a
    /// use inside `uniform(...)`, `normal(...)`, ... whose probe moves it.
    /// (Another seed cannot tell: identity keys are minted from the seed.)
    fn random(&self, part: &Part) -> bool {
        let m = Self::measure(part);
        let Some(base) = self.base.get(&m) else {
            return false;
        };
        self.candidates.iter().enumerate().any(|(c, cand)| {
            cand.random.is_some()
                && self
                    .probe(c)
                    .and_then(|(_, s)| s.get(&m))
                    .is_some_and(|v| v != base)
        })
    }

    /// The probe of candidate `c` the other way (its value less the step).
    fn back_probe(&self, c: usize) -> Option<&Snapshot> {
        self.back[c]
            .get_or_init(|| {
                let (step, _) = self.probe(c)?;
                let cand = &self.candidates[c];
                let text = self.text_with(&[c], &[cand.value - step]);
                self.grow(&text).ok()
            })
            .as_ref()
    }

    /// The source numbers that place `part`, with their derivatives.
    pub fn provenance(&self, part: &Part) -> Result<Provenance, ManipError> {
        let m = Self::measure(part);
        let base = self.measures(part)?;
        let mut sources = Vec::new();
        for (c, cand) in self.candidates.iter().enumerate() {
            let Some((step, snap)) = self.probe(c) else {
                continue;
            };
            let Some(after) = snap.get(&m) else {
                continue;
            };
            let derivative: Vec<f64> = after
                .iter()
                .zip(&base)
                .map(|(a, b)| (a - b) / step)
                .collect();
            if derivative.iter().all(|d| d.abs() < 1e-6) {
                continue;
            }
            // Smooth where the step the other way agrees (a count that
            // changes, a choice that flips, is not).
            let smooth = self.back_probe(c).and_then(|s| s.get(&m)).is_some_and(|b| {
                derivative.iter().zip(b).zip(&base).all(|((d, b), a)| {
                    let back = (a - b) / step;
                    (d - back).abs() <= 0.05 * d.abs().max(back.abs()) + 1e-4
                })
            });
            sources.push(Source {
                candidate: cand.clone(),
                smooth,
                derivative,
                step: *step,
                moves: snap.moved_from(&self.base, 1e-6),
            });
        }
        Ok(Provenance {
            part: *part,
            mode: self.facts.mode,
            system: self.facts.system_name.clone(),
            measures: base,
            sources,
            random: self.random(part),
            probed: self.candidates.len(),
        })
    }

    /// Grow the text with `cands` at `values`; the part's residual.
    fn trial(
        &self,
        part: &Part,
        target: &Target,
        cands: &[usize],
        values: &[f64],
    ) -> Option<Trial> {
        let text = self.text_with(cands, values);
        let snap = self.grow(&text).ok()?;
        let m = snap.get(&Self::measure(part))?;
        let residual = target.residual(part, m).ok()?;
        Some(Trial {
            values: values.to_vec(),
            residual,
            snap,
        })
    }

    /// Gauss-Newton over `cands` from their current values, every step
    /// grown; the Jacobian from the candidates' probes first, then from
    /// the last two steps (Broyden's update).
    fn gauss_newton(
        &self,
        part: &Part,
        target: &Target,
        cands: &[usize],
        g0: &[f64],
    ) -> Option<Trial> {
        let k = cands.len();
        let n = g0.len();
        // Columns: d residual / d candidate.
        let mut jac: Vec<Vec<f64>> = Vec::with_capacity(k);
        let m = Self::measure(part);
        for &c in cands {
            let (step, snap) = self.probe(c)?;
            let r = target.residual(part, snap.get(&m)?).ok()?;
            jac.push(r.iter().zip(g0).map(|(a, b)| (a - b) / step).collect());
        }
        let start: Vec<f64> = cands.iter().map(|&c| self.candidates[c].value).collect();
        let mut x = start.clone();
        let mut g = g0.to_vec();
        let mut best: Option<Trial> = None;
        for _ in 0..8 {
            let dx = least_squares(&jac, &g)?;
            if dx.iter().any(|d| !d.is_finite()) {
                return best;
            }
            let x1: Vec<f64> = x.iter().zip(&dx).map(|(a, d)| a - d).collect();
            let t = self.trial(part, target, cands, &x1)?;
            // Broyden: J += (dg - J dx') dx'^T / |dx'|^2, dx' = x1 - x.
            let step: Vec<f64> = x1.iter().zip(&x).map(|(a, b)| a - b).collect();
            let s2: f64 = step.iter().map(|s| s * s).sum();
            if s2 > 0.0 {
                for i in 0..n {
                    let pred: f64 = (0..k).map(|j| jac[j][i] * step[j]).sum();
                    let err = (t.residual[i] - g[i]) - pred;
                    for j in 0..k {
                        jac[j][i] += err * step[j] / s2;
                    }
                }
            }
            let done = norm(&t.residual) <= self.tolerance * 0.25;
            x = x1;
            g = t.residual.clone();
            if best
                .as_ref()
                .is_none_or(|b| norm(&t.residual) < norm(&b.residual))
            {
                best = Some(t);
            }
            if done {
                break;
            }
        }
        best
    }

    /// The values of `cands` that put `part` at `target` (within the
    /// tolerance), solved from their current values.
    pub(crate) fn solve_with(
        &self,
        part: &Part,
        target: &Target,
        cands: &[usize],
        g0: &[f64],
    ) -> Option<Vec<f64>> {
        let t = self.gauss_newton(part, target, cands, g0)?;
        let (_, t) = self.rounded(part, target, cands, t);
        (norm(&t.residual) <= self.tolerance).then_some(t.values)
    }

    /// A trial's values rounded to the fewest decimals (up to 7) that
    /// still reach the target, grown; the trial itself when none does.
    fn rounded(&self, part: &Part, target: &Target, cands: &[usize], t: Trial) -> (u32, Trial) {
        for decimals in 0..=7u32 {
            let rounded: Vec<f64> = t
                .values
                .iter()
                .map(|v| format_number(*v, decimals).parse::<f64>().unwrap_or(*v))
                .collect();
            if let Some(r) = self.trial(part, target, cands, &rounded)
                && norm(&r.residual) <= self.tolerance
            {
                return (decimals, r);
            }
        }
        (9, t)
    }

    /// Round a trial's values to few decimals that still reach the
    /// target; the solution it writes.
    fn finish(&self, part: &Part, target: &Target, cands: &[usize], t: Trial) -> Solution {
        let (decimals, t) = self.rounded(part, target, cands, t);
        let changes: Vec<Change> = cands
            .iter()
            .zip(&t.values)
            .map(|(&c, &v)| {
                let cand = &self.candidates[c];
                Change {
                    candidate: c,
                    span: cand.span,
                    old: cand.text.clone(),
                    new: cand.replacement(v, &|x| format_number(x, decimals)),
                    value: v,
                }
            })
            .collect();
        let edits: Vec<TextEdit> = changes
            .iter()
            .map(|c| TextEdit {
                span: c.span,
                text: c.new.clone(),
            })
            .collect();
        let text = candidates::apply(
            &self.text,
            &edits
                .iter()
                .map(|e| (e.span, e.text.clone()))
                .collect::<Vec<_>>(),
        );
        let measures = t
            .snap
            .get(&Self::measure(part))
            .map(<[f64]>::to_vec)
            .unwrap_or_default();
        Solution {
            changes,
            text,
            edits,
            residual: norm(&t.residual),
            moved: t.snap.moved_from(&self.base, self.tolerance.min(1e-4)),
            measures,
        }
    }

    /// Solve a drag of `part` to `target`: the fewest source numbers
    /// changed (one, else two), among those the edit that moves the
    /// fewest other parts, a literal before a `NAME + offset`.
    pub fn drag(&self, part: &Part, target: &Target) -> Result<DragOutcome, ManipError> {
        let base = self.measures(part)?;
        let g0 = target.residual(part, &base)?;
        if norm(&g0) <= self.tolerance {
            return Ok(DragOutcome::Unchanged);
        }
        let m = Self::measure(part);
        // Each candidate's column and its one-number linear estimate.
        let mut columns: Vec<(usize, Vec<f64>, f64)> = Vec::new();
        for c in 0..self.candidates.len() {
            let Some((step, snap)) = self.probe(c) else {
                continue;
            };
            let Some(r) = snap.get(&m).and_then(|x| target.residual(part, x).ok()) else {
                continue;
            };
            let col: Vec<f64> = r.iter().zip(&g0).map(|(a, b)| (a - b) / step).collect();
            let jj: f64 = col.iter().map(|x| x * x).sum();
            if jj < 1e-12 {
                continue;
            }
            let d = -col.iter().zip(&g0).map(|(a, b)| a * b).sum::<f64>() / jj;
            let lin: Vec<f64> = g0.iter().zip(&col).map(|(g, a)| g + a * d).collect();
            columns.push((c, col, norm(&lin)));
        }
        if columns.is_empty() {
            let why = if self.random(part) {
                format!(
                    "{} is placed by a random draw and no number of this system moves it: change the draw's range, or pin the part with a persistent edit",
                    part_name(part)
                )
            } else {
                format!(
                    "no number written in this file moves {} (its place comes from an imported file, the lot, or a constraint)",
                    part_name(part)
                )
            };
            return Ok(DragOutcome::Unreachable { why, closest: None });
        }
        // Whether a candidate is a constant's declaration used more than
        // once here (a drag then writes `NAME + offset` at this use).
        let shared = |c: usize| {
            self.candidates[c].constant.as_ref().is_some_and(|n| {
                let uses = self
                    .candidates
                    .iter()
                    .filter(|d| matches!(&d.kind, CandidateKind::Name { name } if name == n));
                uses.count() > 1
            })
        };
        let mut solved: Vec<(Solution, bool)> = Vec::new();
        let mut closest: Option<Solution> = None;
        let mut consider = |s: Solution, literal: bool, solved: &mut Vec<(Solution, bool)>| {
            if s.residual <= self.tolerance {
                solved.push((s, literal));
            } else if closest.as_ref().is_none_or(|c| s.residual < c.residual) {
                closest = Some(s);
            }
        };
        // One number: the best linear estimates first.
        let mut singles: Vec<&(usize, Vec<f64>, f64)> = columns.iter().collect();
        singles.sort_by(|a, b| a.2.total_cmp(&b.2));
        let scale = norm(&g0);
        for (c, _, lin) in singles.iter().take(8) {
            if *lin > 0.5 * scale && !solved.is_empty() {
                break;
            }
            if let Some(t) = self.gauss_newton(part, target, &[*c], &g0) {
                let s = self.finish(part, target, &[*c], t);
                let literal = self.candidates[*c].kind == CandidateKind::Literal;
                consider(s, literal, &mut solved);
            }
        }
        // Two numbers where one does not reach it.
        if solved.is_empty() && g0.len() > 1 {
            let top: Vec<usize> = {
                let mut by_size: Vec<&(usize, Vec<f64>, f64)> = columns.iter().collect();
                by_size.sort_by(|a, b| norm(&b.1).total_cmp(&norm(&a.1)));
                by_size.iter().take(8).map(|c| c.0).collect()
            };
            let mut pairs: Vec<(f64, [usize; 2])> = Vec::new();
            for (i, &a) in top.iter().enumerate() {
                for &b in &top[i + 1..] {
                    let ca = &columns.iter().find(|c| c.0 == a).expect("a column").1;
                    let cb = &columns.iter().find(|c| c.0 == b).expect("a column").1;
                    let jac = vec![ca.clone(), cb.clone()];
                    if let Some(dx) = least_squares(&jac, &g0) {
                        let lin: Vec<f64> = (0..g0.len())
                            .map(|r| g0[r] - ca[r] * dx[0] - cb[r] * dx[1])
                            .collect();
                        pairs.push((norm(&lin), [a, b]));
                    }
                }
            }
            pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
            for (_, pair) in pairs.iter().take(4) {
                if let Some(t) = self.gauss_newton(part, target, pair, &g0) {
                    let s = self.finish(part, target, pair, t);
                    let literal = pair
                        .iter()
                        .all(|&c| self.candidates[c].kind == CandidateKind::Literal);
                    consider(s, literal, &mut solved);
                }
            }
        }
        if solved.is_empty() {
            let why = match &closest {
                Some(c) if self.random(part) => format!(
                    "{} is placed in part by a random draw; the closest an edit of its numbers reaches is {:.4} away",
                    part_name(part),
                    c.residual
                ),
                Some(c) => format!(
                    "no change of one or two numbers puts {} there: the closest reaches {:.4} away (a bound: a split cannot grow past its scope, a size below zero)",
                    part_name(part),
                    c.residual
                ),
                None => format!(
                    "no change of its numbers moves {} that way",
                    part_name(part)
                ),
            };
            return Ok(DragOutcome::Unreachable { why, closest });
        }
        let shares = |s: &Solution| s.changes.iter().any(|c| shared(c.candidate));
        solved.sort_by(|(a, la), (b, lb)| {
            (a.changes.len(), a.moved, shares(a), !la)
                .cmp(&(b.changes.len(), b.moved, shares(b), !lb))
                .then(a.residual.total_cmp(&b.residual))
        });
        Ok(DragOutcome::Solved(solved.swap_remove(0).0))
    }
}

/// The least-squares solution `x` of `J x = g` (columns `jac`), through
/// the normal equations; `None` when they are singular.
pub(crate) fn least_squares(jac: &[Vec<f64>], g: &[f64]) -> Option<Vec<f64>> {
    let k = jac.len();
    let mut a = vec![vec![0.0; k + 1]; k];
    for i in 0..k {
        for j in 0..k {
            a[i][j] = jac[i].iter().zip(&jac[j]).map(|(x, y)| x * y).sum();
        }
        a[i][k] = jac[i].iter().zip(g).map(|(x, y)| x * y).sum();
    }
    // Gaussian elimination with partial pivoting.
    for col in 0..k {
        let piv = (col..k).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))?;
        if a[piv][col].abs() < 1e-12 {
            return None;
        }
        a.swap(col, piv);
        for r in 0..k {
            if r != col {
                let f = a[r][col] / a[col][col];
                let pivot_row = a[col].clone();
                for (x, p) in a[r].iter_mut().zip(&pivot_row).skip(col) {
                    *x -= f * p;
                }
            }
        }
    }
    Some((0..k).map(|i| a[i][k] / a[i][i]).collect())
}
