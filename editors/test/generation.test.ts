// The generation scrubber of sample systems without a browser: the request's
// `generation` for a position, the slider and its label, when it goes back to
// the end (the result), the decoding of the result's `sample.generation`,
// that "Save picture" asks for the generation shown, and the Play button's
// replay of the search (its steps, their pacing, when it stops, the button).
import assert from 'node:assert/strict';
import { test } from 'node:test';
import {
  GenerationScrub,
  PLAY_INTERVAL_MS,
  type PlayAt,
  SearchPlayer,
  generationParam,
  isSearchResult,
  playButtonView,
  scrubberView,
  searchKey,
  showsUpdate,
} from '../preview/src/generation.js';
import { pictureParams } from '../preview/src/picture.js';
import { type SampleInfo, decodePreview } from '../preview/src/protocol.js';
import { PageState } from '../preview/src/state.js';

const CURVES = JSON.stringify({ version: 1, curves: [{ name: 'trunk', points: [[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, 3, 0]] }] });

function sample(over: Partial<SampleInfo> = {}): SampleInfo {
  return { objective: -100, generations: 100, candidates: 15, stoppedEarly: false, curves: 'request', generation: null, coverage: [], refinements: 0, ...over };
}

function result(over: Record<string, unknown> = {}) {
  return decodePreview({
    uri: 'file:///t.grm',
    system: 'Tree',
    mode: 'sample',
    seed: 5,
    params: [{ name: 'spread', value: 30, min: 10, max: 60, default: 30 }],
    sample: { objective: -100, generations: 100, candidates: 15, stoppedEarly: false, curves: 'request' },
    parts: [],
    ...over,
  });
}

/** A sample system's page state after its first result, curves loaded. */
function sampleState(): PageState {
  const s = new PageState();
  s.setDocument('file:///t.grm');
  s.absorb(result());
  s.loadCurves('/t.curves.json', CURVES);
  return s;
}

test('the request asks for a generation before the end, none at the end or past it (the result)', () => {
  assert.equal(generationParam(0, 100), 0);
  assert.equal(generationParam(12, 100), 12);
  assert.equal(generationParam(98, 100), 98);
  // The last generation holds the result: asked as the result, without a generation.
  assert.equal(generationParam(99, 100), undefined);
  assert.equal(generationParam(500, 100), undefined);
  assert.equal(generationParam(null, 100), undefined);
  // Not a position: the result.
  for (const p of [-1, 1.5, Number.NaN, Number.POSITIVE_INFINITY]) assert.equal(generationParam(p, 100), undefined, String(p));
  // A search of one generation (or none known): nothing but the result.
  assert.equal(generationParam(0, 1), undefined);
  assert.equal(generationParam(0, 0), undefined);
});

test("a result is the search's when no generation was asked or the last one was", () => {
  assert.equal(isSearchResult(null), true);
  assert.equal(isSearchResult(sample()), true);
  assert.equal(isSearchResult(sample({ generation: 99 })), true);
  assert.equal(isSearchResult(sample({ generation: 12 })), false);
  assert.equal(isSearchResult(sample({ generation: 0 })), false);
  // Stopped early by the time budget: the generations run are the search.
  assert.equal(isSearchResult(sample({ generations: 40, stoppedEarly: true, generation: 39 })), true);
});

test('the slider spans the last search, its label counts from 1, the end is the result; hidden in derive mode', () => {
  assert.deepEqual(scrubberView('sample', sample(), null), {
    hidden: false,
    disabled: false,
    max: 99,
    value: 99,
    label: '100 / 100 (result)',
    title: "The search's result, after its 100 generations. Drag back to see the model it held after an earlier generation.",
  });
  const g0 = scrubberView('sample', sample(), 0);
  assert.deepEqual([g0.hidden, g0.disabled, g0.max, g0.value, g0.label], [false, false, 99, 0, '1 / 100']);
  // The tooltip names the frame as grmc sample --frames does (from 0).
  assert.match(g0.title, /after generation 1 of 100 .*frame 0 of grmc sample --frames/);
  assert.equal(scrubberView('sample', sample(), 12).label, '13 / 100');
  // The last generation, or past it: the result.
  assert.equal(scrubberView('sample', sample(), 99).label, '100 / 100 (result)');
  assert.equal(scrubberView('sample', sample(), 250).value, 99);
  // A grammar edited to fewer generations: the range follows, a position past it is the result.
  assert.deepEqual([scrubberView('sample', sample({ generations: 20 }), 50).max, scrubberView('sample', sample({ generations: 20 }), 50).label], [19, '20 / 20 (result)']);
  // One generation: shown, nothing to scrub.
  assert.deepEqual([scrubberView('sample', sample({ generations: 1 }), null).hidden, scrubberView('sample', sample({ generations: 1 }), null).disabled], [false, true]);
  // Derive mode, or no search answered yet (or one of no generation): hidden.
  assert.equal(scrubberView('derive', sample(), 12).hidden, true);
  assert.equal(scrubberView('derive', null, null).hidden, true);
  assert.equal(scrubberView('sample', null, null).hidden, true);
  assert.equal(scrubberView('sample', sample({ generations: 0 }), null).hidden, true);
});

test('the search key is what decides the search: not the generation, focus, spread or live; parameters in any order', () => {
  const base = { textDocument: { uri: 'file:///t.grm' }, mode: 'sample' as const, seed: 3, params: { a: 1, b: 2 } };
  const k = searchKey(base);
  assert.equal(searchKey({ ...base, generation: 4, focus: { line: 1, character: 0 }, spreadSeeds: 8, live: true }), k);
  assert.equal(searchKey({ ...base, params: { b: 2, a: 1 } }), k);
  assert.notEqual(searchKey({ ...base, seed: 4 }), k);
  assert.notEqual(searchKey({ ...base, params: { a: 1, b: 3 } }), k);
  assert.notEqual(searchKey({ ...base, curves: { version: 1, curves: [] } }), k);
  assert.notEqual(searchKey({ ...base, mode: 'derive' }), k);
  assert.notEqual(searchKey({ ...base, system: 'Other' }), k);
  assert.notEqual(searchKey({ ...base, textDocument: { uri: 'file:///u.grm' } }), k);
});

test('the scrubber holds its position in one search; another search puts it back at the end for good', () => {
  const s = new GenerationScrub();
  assert.equal(s.current('A'), null);
  s.set(12, 100, 'A');
  assert.equal(s.current('A'), 12);
  assert.equal(s.current('A'), 12);
  // Another search: the end, and still the end when the first search's inputs come back.
  assert.equal(s.current('B'), null);
  assert.equal(s.current('A'), null);
  s.set(3, 100, 'A');
  s.set(99, 100, 'A');
  assert.equal(s.current('A'), null, 'the end is the result');
  s.set(3, 100, 'A');
  s.reset();
  assert.equal(s.current('A'), null);
});

test("the page state sends the scrubber's generation in sample mode, and forgets it when the search changes", () => {
  const s = sampleState();
  assert.equal(s.generation, null);
  assert.equal('generation' in s.previewParams(), false, 'the end: no generation');
  s.setGeneration(0, 100);
  assert.equal(s.generation, 0);
  assert.equal(s.previewParams().generation, 0);
  s.setGeneration(41, 100);
  assert.equal(s.previewParams().generation, 41);
  // The focus highlight does not change the search: the generation stays.
  s.focus = { line: 3, character: 1 };
  assert.equal(s.previewParams().generation, 41);
  // Moved to the end: the result, no generation (the last index is the result too).
  s.setGeneration(99, 100);
  assert.equal('generation' in s.previewParams(), false);

  // What resets it: each change of what decides the search.
  const resets: [string, (st: PageState) => void][] = [
    ['the seed', (st) => st.setSeed(9)],
    ['the next variation', (st) => st.nextVariation()],
    ['a meta-parameter', (st) => st.setParam('spread', 45)],
    ['a control point', (st) => st.moveControlPoint(0, 3, [0, 4, 0])],
    ['a curve parameter', (st) => st.setCurveParam(0, 'alignment_offset', 0.3)],
    ['a drawn curve', (st) => st.addStroke([[0, 3, 0], [-0.5, 3.5, 0], [-1, 3.8, 0], [-2, 4, 0]])],
    ['a deleted curve', (st) => st.deleteCurve(0)],
    ['the curves file reloaded', (st) => st.loadCurves('/t.curves.json', CURVES.replace('[0, 3, 0]', '[0, 5, 0]').replace('[0,3,0]', '[0,5,0]'))],
    ['the mode', (st) => (st.mode = 'derive')],
    ['the document edited (a new search, same parameters)', (st) => st.showResult()],
    ['another document', (st) => st.setDocument('file:///u.grm')],
  ];
  for (const [what, change] of resets) {
    const st = sampleState();
    st.setGeneration(7, 100);
    assert.equal(st.previewParams().generation, 7, what);
    change(st);
    assert.equal(st.generation, null, what);
    assert.equal('generation' in st.previewParams(), false, what);
  }
  // A meta-parameter moved away and back is two new searches: still the end.
  const st = sampleState();
  st.setGeneration(7, 100);
  st.setParam('spread', 45);
  assert.equal(st.generation, null);
  st.setParam('spread', 30);
  assert.equal(st.generation, null);
  // Undo of a curve edit: another search too.
  st.setGeneration(7, 100);
  st.moveControlPoint(0, 3, [0, 4, 0]);
  st.finishEdit();
  st.setGeneration(8, 100);
  assert.equal(st.undo(), true);
  assert.equal(st.generation, null);
});

test('derive mode never sends a generation', () => {
  const s = new PageState();
  s.setDocument('file:///t.grm');
  s.absorb(result({ mode: 'derive', sample: null }));
  s.setGeneration(3, 100);
  assert.equal(s.generation, null);
  assert.equal('generation' in s.previewParams(), false);
});

test("the result's sample.generation is decoded (absent: the result); a model regrown after an edit is shown only if it is a result", () => {
  assert.equal(result().sample?.generation, null);
  const g = result({ sample: { objective: -10, generations: 100, candidates: 15, stoppedEarly: false, curves: 'request', generation: 0 } });
  assert.equal(g.sample?.generation, 0);
  for (const bad of [-1, 1.5, '3', null]) {
    assert.equal(result({ sample: { generations: 100, generation: bad } }).sample?.generation, null, JSON.stringify(bad));
  }
  assert.equal(showsUpdate(result()), true);
  assert.equal(showsUpdate(g), false);
  assert.equal(showsUpdate(result({ sample: { generations: 100, generation: 99 } })), true);
  assert.equal(showsUpdate(result({ mode: 'derive', sample: null })), true);
});

test('Save picture asks for the generation shown, from the same state as the preview', () => {
  const s = sampleState();
  s.setGeneration(0, 100);
  s.focus = { line: 2, character: 0 };
  const preview = s.previewParams();
  const p = pictureParams(preview, { azimuth: 10, elevation: 20 }, { width: 800, height: 500 });
  assert.equal(p.generation, 0);
  const { live: _live, focus: _focus, ...rest } = preview;
  assert.deepEqual({ ...p, view: undefined, width: undefined, height: undefined }, { ...rest, view: undefined, width: undefined, height: undefined });
  // At the end: the result, no generation.
  s.setGeneration(99, 100);
  assert.equal('generation' in pictureParams(s.previewParams(), null, { width: 1, height: 1 }), false);
});

const at = (generation: number | null, key = 'A'): PlayAt => ({ generation, key });

test('Play starts after the scrubber, or at the first generation from the end; a search of one generation has nothing to play', () => {
  const p = new SearchPlayer();
  assert.equal(p.playing, false);
  assert.equal(p.play(at(null), 100, 0), 0, 'from the end (the result): the whole search');
  assert.deepEqual([p.playing, p.position, p.generations], [true, 0, 100]);
  assert.equal(p.play(at(12), 100, 0), 13, 'from generation 12 (its model on screen): the next one');
  assert.equal(p.play(at(98), 100, 0), 99, 'the step after the last generation before the end is the result');
  assert.equal(p.play(at(99), 100, 0), 0, 'the last generation is the end');
  for (const n of [1, 0, Number.NaN]) {
    assert.equal(p.play(at(null), n, 0), null, String(n));
    assert.equal(p.playing, false, String(n));
  }
});

test('a replay asks for the next position only once the last one is on screen, no sooner than the interval after it was asked', () => {
  const p = new SearchPlayer(80);
  assert.equal(p.play(at(null), 100, 1000), 0);
  // The page set its scrubber to 0 and asked; the result still on screen (an older model) is not the step's.
  assert.deepEqual(p.shown(null, at(0), 1010), { kind: 'wait' });
  assert.deepEqual(p.shown(7, at(0), 1010), { kind: 'wait' });
  // Generation 0 on screen 30 ms after it was asked: the next in 50 ms.
  assert.deepEqual(p.shown(0, at(0), 1030), { kind: 'next', position: 1, delayMs: 50 });
  // The same model again (a second answer for the same state) does not step twice.
  assert.deepEqual(p.shown(0, at(0), 1040), { kind: 'wait' });
  assert.equal(p.position, 0, 'nothing asked before the wait is over');
  assert.equal(p.advance(at(0), 1080), 1);
  assert.equal(p.position, 1);
  // Nothing waits now: a second advance asks nothing.
  assert.equal(p.advance(at(1), 1081), null);
  assert.equal(p.playing, true);
  // A slow server: on screen 300 ms after it was asked, the next at once.
  assert.deepEqual(p.shown(1, at(1), 1380), { kind: 'next', position: 2, delayMs: 0 });
  assert.equal(PLAY_INTERVAL_MS, new SearchPlayer().intervalMs);
});

/** A replay of a `generations`-generation search as the page runs it: the positions asked, in order, and how it ended. */
function replay(p: SearchPlayer, from: number | null, generations: number): { asked: number[]; end: string } {
  const asked: number[] = [];
  let t = 0;
  let position = p.play(at(from), generations, t);
  while (position !== null) {
    asked.push(position);
    // The page's scrubber: the position asked (its last one is the result).
    const shownAt = at(generationParam(position, generations) ?? null);
    t += 25;
    const a = p.shown(shownAt.generation, shownAt, t);
    if (a.kind !== 'next') return { asked, end: a.kind };
    assert.equal(a.position, position + 1);
    t += a.delayMs;
    position = p.advance(shownAt, t);
    assert.equal(position, a.position);
    if (asked.length > generations) break;
  }
  return { asked, end: 'stuck' };
}

test('a replay steps through every generation in order and ends at the result', () => {
  const p = new SearchPlayer();
  assert.deepEqual(replay(p, null, 5), { asked: [0, 1, 2, 3, 4], end: 'done' });
  assert.equal(p.playing, false);
  assert.deepEqual(replay(p, 2, 5), { asked: [3, 4], end: 'done' });
  assert.deepEqual(replay(p, 3, 5), { asked: [4], end: 'done' }, 'from the last generation before the end: the result');
  assert.deepEqual(replay(p, null, 2), { asked: [0, 1], end: 'done' });
});

test('a replay stops on Pause, when the scrubber is moved or the search changes, and asks nothing after', () => {
  // Pause while a step's model is on its way: it stays where it is; its model, once shown, asks for nothing.
  const p = new SearchPlayer();
  p.play(at(null), 100, 0);
  p.stop();
  assert.deepEqual([p.playing, p.position], [false, null]);
  assert.deepEqual(p.shown(0, at(0), 30), { kind: 'stop' });
  assert.equal(p.advance(at(0), 100), null);

  // Pause during the wait for the next step: the timer's advance asks nothing.
  p.play(at(null), 100, 0);
  assert.equal(p.shown(0, at(0), 30).kind, 'next');
  p.stop();
  assert.equal(p.advance(at(0), 80), null);

  const moves: [string, PlayAt][] = [
    ['the scrubber moved by hand', at(40)],
    ['the scrubber back at the end (an edit of the document: a new search, same parameters)', at(null)],
    ['another search (seed, parameters, curves: its scrubber at the end)', at(null, 'B')],
    ['another search, the same generation asked', at(0, 'B')],
  ];
  for (const [what, moved] of moves) {
    // Noticed when a model is on screen...
    const a = new SearchPlayer();
    a.play(at(null), 100, 0);
    assert.equal(a.stillAt(at(0)), true, what);
    assert.equal(a.stillAt(moved), false, what);
    assert.deepEqual(a.shown(0, moved, 30), { kind: 'stop' }, what);
    assert.equal(a.playing, false, what);
    // ...or when the wait for the next step is over.
    const b = new SearchPlayer();
    b.play(at(null), 100, 0);
    assert.equal(b.shown(0, at(0), 30).kind, 'next', what);
    assert.equal(b.advance(moved, 80), null, what);
    assert.equal(b.playing, false, what);
  }
});

test("a replay of the page state's search: it follows the scrubber, a new search stops it", () => {
  const s = sampleState();
  const p = new SearchPlayer();
  const here = (): PlayAt => ({ generation: s.generation, key: s.searchKey });
  // The page: Play, then set the scrubber to each position the player asks for.
  const first = p.play(here(), 100, 0);
  assert.equal(first, 0);
  s.setGeneration(0, 100);
  assert.equal(s.previewParams().generation, 0);
  assert.equal(p.stillAt(here()), true);
  assert.equal(p.shown(0, here(), 40).kind, 'next');
  s.setGeneration(p.advance(here(), 80) ?? -1, 100);
  assert.equal(s.previewParams().generation, 1);
  assert.equal(p.stillAt(here()), true);
  // The focus highlight does not change the search: the replay goes on.
  s.focus = { line: 2, character: 0 };
  assert.equal(p.stillAt(here()), true);
  // A meta-parameter moved: a new search, the scrubber at its end; the replay stops.
  s.setParam('spread', 45);
  assert.equal(p.stillAt(here()), false);
  assert.deepEqual(p.shown(1, here(), 200), { kind: 'stop' });
  // Played again from the end: from the first generation of the new search.
  assert.equal(p.play(here(), 100, 300), 0);
  s.setGeneration(0, 100);
  // The document edited: the same parameters, a new search; the replay stops.
  s.showResult();
  assert.equal(p.stillAt(here()), false);
});

test('the Play button: Play at rest (from the first generation at the end), Pause while playing, disabled with nothing to replay', () => {
  const end = scrubberView('sample', sample(), null);
  const mid = scrubberView('sample', sample(), 12);
  assert.deepEqual([playButtonView(end, false).label, playButtonView(end, false).disabled], ['Play', false]);
  assert.match(playButtonView(end, false).title, /from the first to the result/);
  assert.match(playButtonView(mid, false).title, /from here/);
  assert.deepEqual([playButtonView(mid, true).label, playButtonView(mid, true).disabled], ['Pause', false]);
  assert.match(playButtonView(mid, true).title, /Pause/);
  // One generation, derive mode, no search yet: nothing to replay.
  assert.equal(playButtonView(scrubberView('sample', sample({ generations: 1 }), null), false).disabled, true);
  assert.equal(playButtonView(scrubberView('derive', sample(), null), false).disabled, true);
  assert.equal(playButtonView(scrubberView('sample', null, null), false).disabled, true);
  // A replay can always be paused.
  assert.equal(playButtonView(scrubberView('derive', null, null), true).disabled, false);
});
