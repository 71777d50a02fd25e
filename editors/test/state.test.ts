import assert from 'node:assert/strict';
import { test } from 'node:test';
import { Coalescer } from '../preview/src/coalesce.js';
import { parseCurves } from '../preview/src/curves.js';
import { decodePreview } from '../preview/src/protocol.js';
import { PageState, ShownVersion } from '../preview/src/state.js';

const CURVES = JSON.stringify({ version: 1, defaults: { utilization_scale: 100 }, curves: [{ name: 'trunk', points: [[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, 3, 0]] }] });

function result(over: Record<string, unknown> = {}) {
  return decodePreview({
    uri: 'file:///t.grm',
    system: 'Tree',
    mode: 'sample',
    seed: 5,
    params: [{ name: 'spread', value: 30, min: 10, max: 60, default: 30 }],
    parts: [],
    ...over,
  });
}

function sampleState(): PageState {
  const s = new PageState();
  s.setDocument('file:///t.grm');
  s.absorb(result());
  s.loadCurves('/t.curves.json', CURVES);
  return s;
}

test('the first preview sets mode, seed and parameters; overrides are clamped and sent', () => {
  const s = new PageState();
  s.setDocument('file:///t.grm');
  assert.deepEqual(s.previewParams(), { textDocument: { uri: 'file:///t.grm' }, mode: 'derive', live: true });
  s.absorb(result());
  // The shown seed is the file's: shown, not picked (no seed in the next request).
  assert.equal(s.seed, null);
  assert.equal(s.currentSeed, 5);
  assert.equal(s.mode, 'sample');
  s.setParam('spread', 99);
  s.setParam('unknown', 1);
  s.nextVariation();
  s.focus = { line: 3, character: 1 };
  assert.deepEqual(s.previewParams(), { textDocument: { uri: 'file:///t.grm' }, mode: 'sample', live: true, seed: 6, params: { spread: 60 }, focus: { line: 3, character: 1 } });
});

test("the file's seed is followed until the user picks one in the page", () => {
  const s = new PageState();
  s.setDocument('file:///t.grm');
  s.absorb(result({ seed: 1 }));
  assert.equal(s.previewParams().seed, undefined);
  // The grammar's `seed = 1;` edited to `seed = 2;`: the server's update (of the same request options) is the
  // file's seed, and so is every later request.
  s.absorb(result({ seed: 2 }));
  assert.equal(s.currentSeed, 2);
  assert.equal(s.previewParams().seed, undefined);
  // Picked in the page: sent from now on, whatever the file says.
  s.setSeed(7);
  assert.equal(s.previewParams().seed, 7);
  s.absorb(result({ seed: 7 }));
  assert.equal(s.previewParams().seed, 7);
  assert.equal(s.currentSeed, 7);
  // Next variation goes on from the seed shown.
  const t = new PageState();
  t.setDocument('file:///t.grm');
  t.absorb(result({ seed: 2 }));
  t.nextVariation();
  assert.equal(t.previewParams().seed, 3);
  // Another document starts from its own file's seed.
  t.setDocument('file:///u.grm');
  assert.equal(t.currentSeed, null);
  assert.equal(t.previewParams().seed, undefined);
});

test('sample systems send their curves, loaded from the file (or none yet)', () => {
  const s = sampleState();
  assert.equal(s.curves?.curves[0].params.utilization_scale, 100);
  const sent = s.previewParams().curves as { curves: Array<{ utilization_scale: number }> };
  assert.equal(sent.curves[0].utilization_scale, 100);
  s.loadCurves('/t.curves.json', null);
  assert.deepEqual(s.curves, { curves: [] });
  assert.equal(s.previewParams().curves, undefined);
  s.loadCurves('/t.curves.json', '{"version": 9}');
  assert.match(s.curvesError ?? '', /version 9/);
});

test('a drawn stroke becomes a selected curve with the template parameters, and is sent and saveable', () => {
  const s = sampleState();
  const i = s.addStroke([[0, 3, 0], [-0.5, 3.5, 0], [-1, 3.8, 0], [-2, 4, 0]]);
  assert.equal(i, 1);
  assert.equal(s.selected, 1);
  const c = s.curves!.curves[1];
  assert.equal(c.name, 'curve1');
  assert.equal(c.params.utilization_scale, 100); // copied from the last curve
  const sent = s.previewParams().curves as { curves: unknown[] };
  assert.equal(sent.curves.length, 2);
  const out = s.curvesText();
  assert.ok('text' in out);
  assert.deepEqual(parseCurves(out.text), s.curves);
  // A later preview does not touch the edited curves.
  s.absorb(result());
  assert.equal(s.curves!.curves.length, 2);
});

test('moving control points, editing parameters, renaming and deleting', () => {
  const s = sampleState();
  const before = s.curves;
  s.moveControlPoint(0, 2, [1, 2, 3]);
  assert.notEqual(s.curves, before, 'edits make a new set (the old one is untouched)');
  assert.deepEqual(before!.curves[0].points[2], [0, 2, 0]);
  assert.deepEqual(s.curves!.curves[0].points[2], [1, 2, 3]);
  s.moveControlPoint(0, 4, [0, 0, 0]);
  s.moveControlPoint(0, 1, [NaN, 0, 0]);
  assert.deepEqual(s.curves!.curves[0].points[1], [0, 1, 0]);
  s.setCurveParam(0, 'alignment_offset', 0.3);
  assert.equal(s.curves!.curves[0].params.alignment_offset, 0.3);
  s.addStroke([[0, 0, 0], [1, 1, 0]]);
  assert.equal(s.renameCurve(1, 'trunk'), false);
  assert.equal(s.renameCurve(1, 'arm'), true);
  s.deleteCurve(0);
  s.deleteCurve(0);
  assert.equal(s.selected, null);
  const out = s.curvesText();
  assert.ok('error' in out && /at least one curve/.test(out.error));
});

test('switching documents forgets the old one; parameters the grammar dropped are dropped', () => {
  const s = sampleState();
  s.setParam('spread', 20);
  // A result without a parameter list (the server's) leaves the sliders alone...
  s.absorb(result({ params: [] }));
  assert.equal(s.paramValue('spread'), 20);
  // ...the symbols of a grammar that no longer declares it drop the override.
  s.setParamInfo([{ name: 'other', value: 1, min: 0, max: 2, default: 1 }]);
  assert.equal(s.paramValue('spread'), undefined);
  assert.deepEqual(s.params, {});
  s.setDocument('file:///u.grm');
  assert.deepEqual(s.previewParams(), { textDocument: { uri: 'file:///u.grm' }, mode: 'derive', live: true });
  assert.equal(s.curves, null);
});

test('derive systems draw no curves', () => {
  const s = new PageState();
  s.setDocument('file:///k.grm');
  s.absorb(result({ mode: 'derive' }));
  assert.equal(s.curves, null);
  assert.deepEqual(s.beziers(), []);
  assert.equal(s.previewParams().curves, undefined);
});

test('coalescer: one request in flight, the latest state follows, results in order', async () => {
  let state = 0;
  const sent: number[] = [];
  const delivered: Array<[number, boolean, number]> = [];
  const resolvers: Array<() => void> = [];
  let clock = 100;
  const c = new Coalescer<number, number>(
    () => state,
    (s) => {
      sent.push(s);
      return new Promise((r) => resolvers.push(() => r(s * 10)));
    },
    (d) => delivered.push([d.result, d.final, d.editedAt]),
    () => assert.fail('no failure expected'),
    () => clock,
  );
  state = 1;
  c.trigger();
  clock = 110;
  state = 2;
  c.trigger();
  clock = 120;
  state = 3;
  c.trigger();
  assert.deepEqual(sent, [1]);
  assert.equal(c.pending, true, 'edits wait for the request in flight');
  resolvers.shift()!();
  await new Promise((r) => setImmediate(r));
  assert.deepEqual(sent, [1, 3], 'the edits made meanwhile are merged into one request with the latest state');
  resolvers.shift()!();
  await new Promise((r) => setImmediate(r));
  assert.deepEqual(delivered, [
    [10, false, 100],
    [30, true, 110],
  ]);
  assert.equal(c.busy, false);
});

test('coalescer: a failure is reported only when no newer edit is waiting', async () => {
  const failures: unknown[] = [];
  let n = 0;
  let release!: () => void;
  const c = new Coalescer<number, number>(
    () => n,
    async (s) => {
      if (s === 1) {
        await new Promise<void>((r) => (release = r));
        throw new Error('stale failure');
      }
      throw new Error('current failure');
    },
    () => {},
    (e) => failures.push((e as Error).message),
  );
  n = 1;
  c.trigger();
  n = 2;
  c.trigger();
  release();
  await new Promise((r) => setTimeout(r, 5));
  assert.deepEqual(failures, ['current failure']);
});

test('undo and redo: a drag (many moves) is one step; a new edit clears redo; loading a file clears both', () => {
  const s = sampleState();
  assert.equal(s.canUndo, false);
  const original = s.curves!;
  // A drag: several moves, then the release ends the edit.
  s.moveControlPoint(0, 3, [0, 3.5, 0]);
  s.moveControlPoint(0, 3, [0.5, 4, 0]);
  s.moveControlPoint(0, 3, [1, 4.5, 0]);
  s.finishEdit();
  const dragged = s.curves!;
  s.addStroke([[0, 0, 0], [1, 1, 0], [2, 1, 0]]);
  s.finishEdit();
  assert.equal(s.curves!.curves.length, 2);
  assert.equal(s.undo(), true);
  assert.equal(s.curves, dragged);
  assert.equal(s.selected, null, 'the selected (new) curve is gone');
  assert.equal(s.undo(), true);
  assert.equal(s.curves, original);
  assert.deepEqual(s.curves!.curves[0].points[3], [0, 3, 0]);
  assert.equal(s.undo(), false);
  assert.equal(s.redo(), true);
  assert.deepEqual(s.curves!.curves[0].points[3], [1, 4.5, 0]);
  // A new edit after an undo drops what could have been redone.
  s.setCurveParam(0, 'thickness', 0.2);
  s.finishEdit();
  assert.equal(s.canRedo, false);
  assert.equal(s.undo(), true);
  assert.equal(s.curves!.curves[0].params.thickness, 0);
  s.loadCurves('/t.curves.json', CURVES);
  assert.equal(s.canUndo, false);
  assert.equal(s.canRedo, false);
});

test('undo takes back an edit that was not finished yet', () => {
  const s = sampleState();
  s.moveControlPoint(0, 1, [5, 5, 5]);
  assert.equal(s.undo(), true);
  assert.deepEqual(s.curves!.curves[0].points[1], [0, 1, 0]);
});

test('a model of an older document version is never shown over a newer one or its errors', () => {
  const v = new ShownVersion();
  assert.equal(v.model(3), true);
  // The update for version 4 came first; the answer of a request begun at version 3 after it.
  assert.equal(v.model(4), true);
  assert.equal(v.model(3), false);
  assert.equal(v.model(4), true, 'the same version again (another request of the same text)');
  // Version 5 has errors: the error stays on screen, not a model of version 4 still on its way.
  assert.equal(v.error(5), true);
  assert.equal(v.model(4), false);
  assert.equal(v.model(6), true);
  // Errors of an older version do not hold back the newer model's, and are not shown over it.
  assert.equal(v.error(2), false);
  assert.equal(v.model(6), true);
  assert.equal(v.error(6), true, 'errors of the text shown are shown');
  assert.equal(v.error(7), true);
  assert.equal(v.model(6), false);
  v.reset();
  assert.equal(v.model(1), true);
});

test("a request's failure after a newer model was shown is about an older text", () => {
  const v = new ShownVersion();
  v.model(3);
  // A request goes (its text, `seed = 2`, has errors); the model of the finished text comes first.
  const mark = v.mark();
  assert.equal(v.shownSince(mark), false);
  assert.equal(v.model(5), true);
  assert.equal(v.shownSince(mark), true);
  // A model not shown (older) is not news.
  const again = v.mark();
  assert.equal(v.model(4), false);
  assert.equal(v.shownSince(again), false);
});

test("a request's failure that names its version is shown only when no newer text is on screen", () => {
  const v = new ShownVersion();
  assert.equal(v.model(4), true);
  const mark = v.mark();
  // The server names the version whose text failed: `seed = 2` (version 5) went, the finished text's model (version 6) came first.
  assert.equal(v.model(6), true);
  assert.equal(v.failure(5, mark), false, 'an older text than the model on screen');
  assert.equal(v.failure(6, mark), true, "the text on screen's own failure (other parameters) is shown, though a model came since the mark");
  // A newer text's failure is shown, and then no model of an older text comes over it.
  assert.equal(v.failure(7, v.mark()), true);
  assert.equal(v.model(6), false);
  // Without a version (a server that does not name it): a model since the mark says the text was older.
  const m2 = v.mark();
  assert.equal(v.failure(undefined, m2), true);
  assert.equal(v.model(8), true);
  assert.equal(v.failure(undefined, m2), false);
});

test("a model's status goes on screen only when no answer came after it (the errors of a newer text stay)", () => {
  const v = new ShownVersion();
  // The model of version 5 is shown; its frame (and status line) is drawn a moment later.
  assert.equal(v.model(5), true);
  const five = v.answer();
  assert.equal(v.latest(five), true);
  // Before that frame the errors of version 6 are shown: the model's status must not replace them.
  assert.equal(v.error(6), true);
  const six = v.answer();
  assert.equal(v.latest(five), false);
  assert.equal(v.latest(six), true);
  // The finished text's model (version 7): its status is the one on screen once its frame is drawn.
  assert.equal(v.model(7), true);
  const seven = v.answer();
  assert.equal(v.latest(six), false);
  assert.equal(v.latest(seven), true);
  // A new document starts the versions afresh, not the tickets: an answer before it is still not the latest.
  v.reset();
  assert.equal(v.latest(seven), true);
  assert.equal(v.model(1), true);
  const one = v.answer();
  assert.equal(v.latest(seven), false);
  assert.equal(v.latest(one), true);
});

test('focus and context goes with shape- and derive-mode requests, not sample mode, and a new document drops it', () => {
  const s = new PageState();
  s.setDocument('file:///h.grm');
  s.absorb(result({ mode: 'shape' }));
  s.context = { key: '5ad0c3e1', depth: 2 };
  assert.deepEqual(s.previewParams().context, { key: '5ad0c3e1', depth: 2 });
  s.absorb(result({ mode: 'derive' }));
  assert.deepEqual(s.previewParams().context, { key: '5ad0c3e1', depth: 2 });
  s.absorb(result({ mode: 'sample' }));
  assert.equal(s.previewParams().context, undefined);
  s.setDocument('file:///other.grm');
  assert.equal(s.context, null);
});
