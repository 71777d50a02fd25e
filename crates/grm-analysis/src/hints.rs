//! Inlay hints: the normalized probability after each weight of a
//! stochastic group, and the inferred type after each parameter a
//! predecessor or context binds.

use crate::hover::percent;
use crate::{FileAnalysis, Span};
use grm_sema::Ty;
use grm_syntax::lexer::TokKind;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum InlayHintKind {
    /// `: float` after a bound parameter.
    Type,
    /// `= 66.7%` after a weight.
    Probability,
}

/// A hint shown at `offset` (between characters) of the analysed file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InlayHint {
    pub offset: u32,
    pub label: String,
    pub kind: InlayHintKind,
    pub tooltip: Option<String>,
}

impl FileAnalysis {
    /// Hints whose position lies in `range`.
    pub fn inlay_hints(&self, range: Span) -> Vec<InlayHint> {
        let inside = |o: u32| range.start <= o && o <= range.end;
        let mut out = Vec::new();
        for sys in self.root_systems() {
            if sys.span.end < range.start || sys.span.start > range.end {
                continue;
            }
            for g in &sys.groups {
                let probs = g.probabilities();
                let stochastic =
                    g.alternatives.len() > 1 || g.alternatives.iter().any(|a| a.weight_written);
                for (i, a) in g.alternatives.iter().enumerate() {
                    if stochastic && let Some(ps) = &probs {
                        // After the weight's `)`, or after `->` when unweighted.
                        let at = if a.weight_written {
                            self.closing_paren_after(a.weight.span.end)
                        } else {
                            Some(a.arrow.end)
                        };
                        if let Some(at) = at.filter(|&o| inside(o)) {
                            out.push(InlayHint {
                                offset: at,
                                label: percent(ps[i]),
                                kind: InlayHintKind::Probability,
                                tooltip: Some(format!(
                                    "probability of this alternative: weight / sum of the {} weights of the group",
                                    g.alternatives.len()
                                )),
                            });
                        }
                    }
                    for b in &a.bindings {
                        if b.ty == Ty::Error || !inside(b.span.end) {
                            continue;
                        }
                        out.push(InlayHint {
                            offset: b.span.end,
                            label: format!(": {}", b.ty),
                            kind: InlayHintKind::Type,
                            tooltip: None,
                        });
                    }
                }
            }
        }
        out.sort_by_key(|h| h.offset);
        out.dedup();
        out
    }

    /// The end of the first `)` at or after `from`.
    fn closing_paren_after(&self, from: u32) -> Option<u32> {
        let i = self.tokens().partition_point(|(_, s)| s.start < from);
        self.tokens()[i..]
            .iter()
            .find(|(k, _)| *k == TokKind::RParen)
            .map(|(_, s)| s.end)
    }
}
