// The generation scrubber of sample systems without a browser: the request's
// `generation` for a position, the slider and its label, when it goes back to
// the end (the result), the decoding of the result's `sample.generation`, and
// that "Save picture" asks for the generation shown.
import assert from 'node:assert/strict';
import { test } from 'node:test';
import { GenerationScrub, generationParam, isSearchResult, scrubberView, searchKey, showsUpdate } from '../preview/src/generation.js';
import { pictureParams } from '../preview/src/picture.js';
import { type SampleInfo, decodePreview } from '../preview/src/protocol.js';
import { PageState } from '../preview/src/state.js';

const CURVES = JSON.stringify({ version: 1, curves: [{ name: 'trunk', points: [[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, 3, 0]] }] });

function sample(over: Partial<SampleInfo> = {}): SampleInfo {
  return { objective: -100, generations: 100, candidates: 15, stoppedEarly: false, curves: 'request', generation: null, ...over };
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
