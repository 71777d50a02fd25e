// The generation scrubber of a sample system, without any DOM: which
// generation's model the next preview request asks for, what the slider and
// its label show, and when it goes back to the end (the search's result).
// Unit-tested under node.
//
// The guided search is deterministic for its inputs (the document, system,
// mode, seed, meta-parameters and curves), so the model it held after
// generation K is the same each time it is asked for: the scrubber is a
// position in one search. Whatever changes an input starts another search,
// and the scrubber goes back to the end, to show that search's result (a
// position in the old search would show a model of the new one no one chose).

import type { PreviewParams, PreviewResult, SampleInfo } from './protocol.js';

/**
 * The `generation` of a preview request for scrubber position `position`
 * (0-based) of a search of `generations` generations: none at the end or
 * past it (the result, which is what the last generation holds anyway), nor
 * for a position that is not one (null, a fraction, negative).
 */
export function generationParam(position: number | null, generations: number): number | undefined {
  if (position === null || !Number.isInteger(position) || position < 0) return undefined;
  if (!(position < generations - 1)) return undefined;
  return position;
}

/**
 * Whether a result is the search's result: not a generation's model (none
 * asked), or the last generation's, which is the result.
 */
export function isSearchResult(sample: SampleInfo | null): boolean {
  return !sample || sample.generation === null || sample.generation >= sample.generations - 1;
}

/** JSON with every object's keys sorted: the same parameters give the same text whatever order they were set in. */
function stableJson(v: unknown): string {
  if (Array.isArray(v)) return `[${v.map(stableJson).join(',')}]`;
  if (typeof v === 'object' && v !== null) {
    const o = v as Record<string, unknown>;
    const keys = Object.keys(o)
      .filter((k) => o[k] !== undefined)
      .sort();
    return `{${keys.map((k) => `${JSON.stringify(k)}:${stableJson(o[k])}`).join(',')}}`;
  }
  return JSON.stringify(v) ?? 'null';
}

/**
 * What decides the search, as text to compare: the preview parameters less
 * those that only choose what is shown of it (`generation`, the `focus`
 * highlight and its `spreadSeeds`) or how it is served (`live`).
 */
export function searchKey(p: PreviewParams): string {
  const { generation: _generation, focus: _focus, spreadSeeds: _spread, live: _live, ...search } = p;
  return stableJson(search);
}

/**
 * Where the scrubber is, and in which search (its `searchKey`). Another
 * search puts it back at the end for good: moving a slider away and back
 * is two new searches, not a return to the old position.
 */
export class GenerationScrub {
  private at: { generation: number; key: string } | null = null;

  /** Move to `position` of `generations` in the search `key`; the end (or past it) is the result. */
  set(position: number, generations: number, key: string): void {
    const g = generationParam(position, generations);
    this.at = g === undefined ? null : { generation: g, key };
  }

  /** The generation to show of the search `key` (null: its result). */
  current(key: string): number | null {
    if (this.at && this.at.key !== key) this.at = null;
    return this.at?.generation ?? null;
  }

  /** Back to the end: a new search with the same parameters (the document was edited) or another document. */
  reset(): void {
    this.at = null;
  }
}

/** What the scrubber shows. */
export interface ScrubberView {
  /** Hidden: a derived system, or no search has answered yet. */
  hidden: boolean;
  /** A search of one generation: nothing to scrub. */
  disabled: boolean;
  /** The slider's range is 0 .. max (the last generation: the result). */
  max: number;
  value: number;
  /** `13 / 100`; at the end `100 / 100 (result)`. */
  label: string;
  /** The tooltip: what the position shows, with the 0-based number `grmc sample --frames` names its files by. */
  title: string;
}

/**
 * The scrubber for the page's mode, the last search's `sample` info (its
 * number of generations) and the generation asked for (null: the result).
 * Generations are counted from 1 in the label (the model after the first
 * generation is `1 / 100`, the result `100 / 100`), from 0 in the requests
 * and in `grmc sample --frames` (said in the tooltip).
 */
export function scrubberView(mode: 'derive' | 'sample', sample: SampleInfo | null, generation: number | null): ScrubberView {
  const n = sample ? Math.max(0, Math.floor(sample.generations)) : 0;
  if (mode !== 'sample' || n < 1) return { hidden: true, disabled: true, max: 0, value: 0, label: '', title: '' };
  const max = n - 1;
  const g = generationParam(generation, n);
  if (g === undefined) {
    return {
      hidden: false,
      disabled: n < 2,
      max,
      value: max,
      label: `${n} / ${n} (result)`,
      title: `The search's result, after its ${n} generations. Drag back to see the model it held after an earlier generation.`,
    };
  }
  return {
    hidden: false,
    disabled: false,
    max,
    value: g,
    label: `${g + 1} / ${n}`,
    title: `The model the search held after generation ${g + 1} of ${n} (its best particle, wrapped up; frame ${g} of grmc sample --frames). The end is the result.`,
  };
}

/**
 * Whether a model the server regrew after an edit of the document (`grm/previewUpdated`)
 * is the one to show. An edit starts a new search, whose result the page
 * shows: a generation's model (the live request the server regrew was a
 * scrubbed one) is not, and the page asks for the result instead.
 */
export function showsUpdate(r: PreviewResult): boolean {
  return isSearchResult(r.sample);
}
