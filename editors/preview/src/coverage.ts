// The preview's words for curve coverage (grm/preview's `sample.coverage`,
// docs/curves.md 2.8): how much of each guiding curve the model follows,
// and a curve no bone reaches said so, not silently dropped. The curve
// list shows each curve's label (the status line stays one line: its
// height is the view's).

import type { CurveCoverage, SampleInfo } from './protocol.js';

/** A curve's label in the curve list: its followed share, and a warning when no bone reaches it. */
export function coverageLabel(c: CurveCoverage): string {
  return c.unreached ? `⚠ 0%: ${c.note}` : `${(100 * c.fraction).toFixed(0)}%`;
}

/**
 * The words under the curve list: how many refinement rounds the search
 * ran after its pass (`sample.refinements`, docs/sampling.md 4.5), so a
 * model that took longer says why; null for a model the search did not
 * finish (an earlier generation's, from the scrubber) or no search.
 */
export function refinementsLabel(s: SampleInfo | null | undefined): { text: string; title: string } | null {
  if (!s || s.generation !== null) return null;
  const n = s.refinements;
  return n === 0
    ? { text: 'no refinement rounds', title: 'The search covered every curve (or could not be refined): the model is its pass.' }
    : {
        text: `${n} refinement round${n === 1 ? '' : 's'}`,
        title: 'The search left a curve under 80%: the model is the best of its pass and these rounds.',
      };
}

/** [`refinementsLabel`] as the curve list's last line (class `refinements`). */
export function refinementsLine(s: SampleInfo | null | undefined): HTMLElement | null {
  const label = refinementsLabel(s);
  if (!label) return null;
  const el = document.createElement('div');
  el.className = 'refinements';
  el.textContent = label.text;
  el.title = label.title;
  return el;
}
