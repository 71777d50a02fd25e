// The preview's words for curve coverage (grm/preview's `sample.coverage`,
// docs/curves.md 2.8): how much of each guiding curve the model follows,
// and a curve no bone reaches said so, not silently dropped.

import type { CurveCoverage } from './protocol.js';

/** The status line's coverage: each curve's followed share, and a curve no bone reaches said so (docs/curves.md 2.8). */
export function coverageText(coverage: CurveCoverage[]): string {
  const name = (c: CurveCoverage, i: number) => c.name ?? `curve ${i + 1}`;
  const shares = coverage.map((c, i) => `${name(c, i)} ${(100 * c.fraction).toFixed(0)}%`);
  const unreached = coverage.flatMap((c, i) => (c.unreached ? [`⚠ ${name(c, i)}: ${c.note}`] : []));
  return [`curves followed: ${shares.join(', ')}`, ...unreached].join(' · ');
}
