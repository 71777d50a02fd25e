// The generation scrubber of a sample system, without any DOM: which
// generation's model the next preview request asks for, what the slider and
// its label show, when it goes back to the end (the search's result), and
// the Play button's replay of the search, step by step. Unit-tested under
// node.
//
// The guided search is deterministic for its inputs (the document, system,
// mode, seed, meta-parameters and curves), so the model it held after
// generation K is the same each time it is asked for: the scrubber is a
// position in one search. Whatever changes an input starts another search,
// and the scrubber goes back to the end, to show that search's result (a
// position in the old search would show a model of the new one no one chose).

import type { Mode, PreviewParams, PreviewResult, SampleInfo } from './protocol.js';

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
export function scrubberView(mode: Mode, sample: SampleInfo | null, generation: number | null): ScrubberView {
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
    title: `What the search returns when stopped after generation ${g + 1} of ${n} (frame ${g} of grmc sample --frames). The end is the result.`,
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

// ------------------------------------------------------------- replay

/** The least time between two steps of a replay (ms): a fast server does not make it a blur. */
export const PLAY_INTERVAL_MS = 80;

/** Where the page's scrubber is now: the generation it asks for (null: the result) in the search `key` (its `searchKey`). */
export interface PlayAt {
  generation: number | null;
  key: string;
}

/** What the page does after a model is on screen during a replay. */
export type PlayAction =
  /** Not the model of the step asked (nor a sign the page moved): keep waiting for it. */
  | { kind: 'wait' }
  /** The step's model is on screen: ask for `position` after `delayMs` (then {@link SearchPlayer.advance}). */
  | { kind: 'next'; position: number; delayMs: number }
  /** The result is on screen: the replay is over. */
  | { kind: 'done' }
  /** The page is no longer where the replay left it (another position, another search): the replay stopped. */
  | { kind: 'stop' };

/**
 * The Play button's replay of a search, without any DOM or timer: which
 * position to ask for first and next, and when it stops. One step at a
 * time: the next position is asked for only once the model of the last one
 * is on screen (so a replay never queues requests and goes as fast as the
 * server answers), and not sooner than `intervalMs` after the last one was
 * asked (so the steps are about that far apart on screen when the server
 * is faster). It stops at the result, on Pause, and as soon as the page's
 * scrubber is anywhere else than where the replay put it: moved by hand,
 * or put back at the end by anything that starts a new search (which the
 * page's state does already), so the player needs no list of what does.
 */
export class SearchPlayer {
  private run: {
    key: string;
    generations: number;
    /** The position asked for last (0-based; `generations - 1`: the result). */
    position: number;
    askedAt: number;
    /** Its model is on screen and the next step waits for its time. */
    shown: boolean;
  } | null = null;

  constructor(readonly intervalMs: number = PLAY_INTERVAL_MS) {}

  get playing(): boolean {
    return this.run !== null;
  }

  /** The generations of the search being replayed (0 when not playing). */
  get generations(): number {
    return this.run?.generations ?? 0;
  }

  /** The position asked for last (0-based; the last one is the result); null when not playing. */
  get position(): number | null {
    return this.run?.position ?? null;
  }

  /**
   * Play from where the scrubber is: the first position to ask for (now),
   * the one after the scrubber's, or the first generation when it is at the
   * end (a replay of the whole search). Null, and not playing, when the
   * search has nothing to replay (one generation, or none known).
   */
  play(at: PlayAt, generations: number, now: number): number | null {
    const n = Number.isFinite(generations) ? Math.floor(generations) : 0;
    this.run = null;
    if (n < 2) return null;
    const g = generationParam(at.generation, n);
    const position = g === undefined ? 0 : g + 1;
    this.run = { key: at.key, generations: n, position, askedAt: now, shown: false };
    return position;
  }

  /** Whether the page's scrubber is where the replay put it (the position asked for last, in the replay's search). */
  stillAt(at: PlayAt): boolean {
    const r = this.run;
    return r !== null && at.key === r.key && at.generation === (generationParam(r.position, r.generations) ?? null);
  }

  /**
   * A model is on screen: `model` is the generation it is of (null: a
   * search's result), `at` where the page's scrubber is now.
   */
  shown(model: number | null, at: PlayAt, now: number): PlayAction {
    const r = this.run;
    if (!r) return { kind: 'stop' };
    if (!this.stillAt(at)) {
      this.run = null;
      return { kind: 'stop' };
    }
    // Another model (a second answer for the step already shown, or an older one): the step's is still to come.
    if (r.shown || model !== (generationParam(r.position, r.generations) ?? null)) return { kind: 'wait' };
    if (r.position >= r.generations - 1) {
      this.run = null;
      return { kind: 'done' };
    }
    r.shown = true;
    return { kind: 'next', position: r.position + 1, delayMs: Math.max(0, this.intervalMs - (now - r.askedAt)) };
  }

  /**
   * The wait of a `next` step is over: the position to ask for now, or null
   * (and the replay stopped) when the page moved meanwhile or no step waits.
   */
  advance(at: PlayAt, now: number): number | null {
    const r = this.run;
    if (!r || !r.shown) return null;
    if (!this.stillAt(at)) {
      this.run = null;
      return null;
    }
    r.position += 1;
    r.askedAt = now;
    r.shown = false;
    return r.position;
  }

  /** Pause, a failed step, or anything else that ends the replay; the scrubber stays where it is. */
  stop(): void {
    this.run = null;
  }
}

/** What the Play button shows. */
export interface PlayButtonView {
  label: 'Play' | 'Pause';
  title: string;
  /** Nothing to replay (the scrubber is hidden or disabled); never while playing, so a replay can always be paused. */
  disabled: boolean;
}

/** The Play button next to the scrubber `scrubber`, playing or not. */
export function playButtonView(scrubber: ScrubberView, playing: boolean): PlayButtonView {
  if (playing) return { label: 'Pause', title: 'Pause the replay; the scrubber stays at the generation shown (Space on the slider)', disabled: false };
  const atEnd = scrubber.value >= scrubber.max;
  return {
    label: 'Play',
    title: atEnd
      ? "Replay the search: each generation's model in turn, from the first to the result (Space on the slider)"
      : "Replay the search from here: each next generation's model in turn, to the result (Space on the slider)",
    disabled: scrubber.hidden || scrubber.disabled,
  };
}
