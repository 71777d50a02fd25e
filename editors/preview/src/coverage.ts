// The preview's words for curve coverage (grm/preview's `sample.coverage`,
// docs/curves.md 2.8): how much of each guiding curve the model follows,
// and a curve no bone reaches said so, not silently dropped. The curve
// list shows each curve's label (the status line stays one line: its
// height is the view's).

import type { CurveCoverage } from './protocol.js';

/** A curve's label in the curve list: its followed share, and a warning when no bone reaches it. */
export function coverageLabel(c: CurveCoverage): string {
  return c.unreached ? `⚠ 0%: ${c.note}` : `${(100 * c.fraction).toFixed(0)}%`;
}
