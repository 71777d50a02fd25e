// Direct manipulation (issue 28) without a browser: the split planes a
// shape pick makes draggable (`grm/pick`'s scopes with `key` and
// `planes`), the geometry of a drag (the pointer's ray projected onto a
// plane's axis; onto the view plane through a bone's tip), the answers of
// `grm/drag`, `grm/sketch` and `grm/writeParams` decoded and said in the
// status line, the sketch's poses, the sliders to write, and the messages
// the page and the extension exchange for them (the extension forwards
// them to the language server, for the shown document only).
import assert from 'node:assert/strict';
import { test } from 'node:test';
import type { V3 } from '../preview/src/bezier.js';
import {
  SketchKeys,
  alongLine,
  closestOnLine,
  describeTarget,
  dragPlaneAt,
  manipSummary,
  paramsToWrite,
  planeAxis,
  provenanceSummary,
  planeCentre,
  planeHandles,
  rayPlane,
  sliderNameProblem,
  tipDragNormal,
  boneGrips,
  draggedLength,
  rotatedTip,
  BONE_GRIP_OFFSET,
} from '../preview/src/manip.js';
import { type HostToPage, METHODS, parsePageMessage } from '../preview/src/messages.js';
import { ProtocolError, bytesToBase64, decodeManipResult, decodePick, decodePreview, decodeProvenance } from '../preview/src/protocol.js';
import { type HostDeps, PreviewHost } from '../vscode/src/host.js';

const X = [1, 0, 0];
const Y = [0, 1, 0];
const Z = [0, 0, 1];
const RANGE = { start: { line: 9, character: 4 }, end: { line: 9, character: 40 } };

/** A facade 24 wide and 12 high in the plane z = 0 (model frame), split at 4 along y, and a tile of an upper floor split along x. */
const SCOPES = [
  { node: 0, label: 'Facade', command: false, origin: [0, 0, 0], axes: [X, Y, Z], size: [24, 12, 0] },
  { node: 3, label: 'split.y', command: true, key: '0a1b2c3d', origin: [0, 0, 0], axes: [X, Y, Z], size: [24, 12, 0], axis: 1, cuts: [4], planes: [{ edge: 1, at: 4 }] },
  { node: 8, label: 'Tile', command: false, origin: [3, 4, 0], axes: [X, Y, Z], size: [3, 4, 0] },
  {
    node: 9,
    label: 'split.x',
    command: true,
    key: 'DEADBEEF',
    origin: [3, 4, 0],
    axes: [X, Y, Z],
    size: [3, 4, 0],
    axis: 0,
    cuts: [0.9, 2.1],
    planes: [
      { edge: 1, at: 0.9 },
      { edge: 2, at: 2.1 },
    ],
  },
  // An old server: a command without a key has no draggable planes.
  { node: 10, label: 'repeat.x', command: true, origin: [3, 4, 0], axes: [X, Y, Z], size: [3, 4, 0], axis: 0, cuts: [1.5] },
  { node: 12, label: 'Wall', command: false, origin: [3, 4, 0], axes: [X, Y, Z], size: [0.9, 4, 0] },
];

function pick(scopes: unknown[] = SCOPES) {
  return {
    uri: 'file:///t.grm',
    range: RANGE,
    symbol: 'Wall',
    version: 3,
    module: 12,
    key: '615544b3',
    shape: { node: 12, exact: '{Lot, 1, Wall}', semantic: '(facade = 1/1) Wall', madeBy: 'split.x', scopes },
  };
}

const close = (a: number, b: number, eps = 1e-9) => assert.ok(Math.abs(a - b) <= eps, `${a} != ${b}`);
const closeV = (a: V3 | null, b: V3, eps = 1e-9) => {
  assert.ok(a, 'a point');
  a.forEach((x, i) => close(x, b[i], eps));
};

test("a shape pick's split and repeat scopes with a key give draggable planes, from the axiom down", () => {
  const r = decodePick(pick());
  assert.ok(r?.shape);
  const split = r.shape.scopes[1];
  assert.equal(split.key, '0a1b2c3d');
  assert.deepEqual(split.planes, [{ edge: 1, at: 4 }]);
  assert.equal(r.shape.scopes[0].key, null);
  assert.deepEqual(r.shape.scopes[0].planes, []);
  const h = planeHandles(r.shape.scopes);
  assert.deepEqual(
    h.map((x) => [x.label, x.command, x.edge, x.at, x.axis]),
    [
      ['split.y', '0a1b2c3d', 1, 4, 1],
      ['split.x', 'DEADBEEF', 1, 0.9, 0],
      ['split.x', 'DEADBEEF', 2, 2.1, 0],
    ],
  );
  // The grip: the middle of the plane's rectangle across its scope.
  assert.deepEqual(planeCentre(h[0]), [12, 4, 0]);
  assert.deepEqual(planeCentre(h[2]), [3 + 2.1, 6, 0]);
  assert.deepEqual(planeCentre(h[2], 1.5), [4.5, 6, 0]);
  assert.deepEqual(planeAxis(h[1]), [1, 0, 0]);
});

test('scope keys that are not 8 hex digits are dropped; planes that are not numbered children are refused', () => {
  const bad = (planes: unknown, key: unknown = 'abcdef01') => decodePick(pick([{ ...SCOPES[1], key, planes }]));
  assert.equal(bad([], 'xyz')?.shape?.scopes[0].key, null);
  assert.equal(bad([], 12)?.shape?.scopes[0].key, null);
  assert.throws(() => bad([{ edge: 0, at: 1 }]), ProtocolError);
  assert.throws(() => bad([{ edge: 1.5, at: 1 }]), ProtocolError);
  assert.throws(() => bad([{ edge: 1, at: 'x' }]), ProtocolError);
  assert.throws(() => bad([3]), ProtocolError);
  // Not a list: no planes.
  assert.deepEqual(bad('no')?.shape?.scopes[0].planes, []);
});

test("the pointer's ray projected onto a line: where along it the ray passes closest", () => {
  // A ray straight down the -z axis at x = 3, y = 2, and the x axis: closest at x = 3.
  close(closestOnLine([3, 2, 10], [0, 0, -1], [0, 0, 0], [1, 0, 0]) ?? NaN, 3);
  // In units of the line's direction: a direction twice as long halves the parameter.
  close(closestOnLine([3, 2, 10], [0, 0, -1], [0, 0, 0], [2, 0, 0]) ?? NaN, 1.5);
  // Against the line's origin and whatever the ray's length.
  close(closestOnLine([3, 2, 10], [0, 0, -7], [1, 5, 0], [1, 0, 0]) ?? NaN, 2);
  // An oblique ray: from (0, 0, 10) towards (4, 1, 0) passes closest to the y axis at...
  const s = closestOnLine([0, 0, 10], [4, 1, -10], [0, 0, 0], [0, 1, 0]) ?? NaN;
  // ...the y where the ray's distance to the axis is least: minimise x^2 + z^2 over the ray, t = 100/116.
  close(s, 100 / 116, 1e-12);
  // A ray along the line, or no direction: no one closest point.
  assert.equal(closestOnLine([0, 0, 0], [1, 0, 0], [0, 1, 0], [3, 0, 0]), null);
  assert.equal(closestOnLine([0, 0, 0], [0, 0, 0], [0, 1, 0], [1, 0, 0]), null);
  assert.equal(closestOnLine([0, 0, 0], [0, 0, 1], [0, 1, 0], [0, 0, 0]), null);
});

test('a plane drag moves the plane along its axis by what the pointer moved along it, not to the pointer', () => {
  const [splitY, splitX1] = planeHandles(decodePick(pick())?.shape?.scopes ?? []);
  // A camera in front of the facade at z = 30, looking at it; rays through points of the facade.
  const eye: V3 = [10, 5, 30];
  const ray = (p: V3) => ({ origin: eye, dir: [p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]] as V3 });
  const look: V3 = [0, 0, -1];
  // Grabbed at the grip (y = 4), dragged to y = 5.5 on the facade: the plane is at 5.5.
  close(dragPlaneAt(splitY, 4, ray([12, 4, 0]), ray([12, 5.5, 0]), look) ?? NaN, 5.5, 1e-9);
  // Grabbed off the grip (0.5 above it, 3 to the side): the plane keeps that offset.
  close(dragPlaneAt(splitY, 4, ray([9, 4.5, 0]), ray([9, 6, 0]), look) ?? NaN, 5.5, 1e-9);
  // Without the view's direction, the grabbing ray's: the plane through the grip facing it is tilted a little.
  close(dragPlaneAt(splitY, 4, ray([9, 4.5, 0]), ray([9, 6, 0])) ?? NaN, 5.5, 0.01);
  // Moves across the axis (along x) do not move a y plane, in perspective too.
  close(dragPlaneAt(splitY, 4, ray([12, 4, 0]), ray([2, 4, 0]), look) ?? NaN, 4, 1e-9);
  // An x plane of a tile, grabbed at 0.9 (world x 3.9), dragged to world x 4.4: at 1.4 from the tile's corner.
  close(dragPlaneAt(splitX1, 0.9, ray([3.9, 6, 0]), ray([4.4, 6, 0]), look) ?? NaN, 1.4, 1e-9);
  // Back where it was grabbed: where it was.
  close(dragPlaneAt(splitX1, 0.9, ray([3.9, 6, 0]), ray([3.9, 6, 0])) ?? NaN, 0.9, 1e-12);
  // Looking straight along the axis (a camera above the y plane's axis line): no answer, the drag holds.
  const down = { origin: [12, 30, 0] as V3, dir: [0, -1, 0] as V3 };
  assert.equal(dragPlaneAt(splitY, 4, down, down), null);
});

test('a turned scope drags along its own axis, in its own units', () => {
  // A wall facing -x: its x axis runs along -z from z = 5.
  const r = decodePick(
    pick([{ node: 1, label: 'split.x', command: true, key: '00000001', origin: [0, 0, 5], axes: [[0, 0, -1], Y, [-1, 0, 0]], size: [5, 3, 0], axis: 0, cuts: [1], planes: [{ edge: 1, at: 1 }] }]),
  );
  const [h] = planeHandles(r?.shape?.scopes ?? []);
  assert.deepEqual(planeCentre(h), [0, 1.5, 4]);
  const eye: V3 = [-20, 1.5, 2.5];
  const ray = (p: V3) => ({ origin: eye, dir: [p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]] as V3 });
  // Dragged from z = 4 to z = 2: 2 further along the wall's x.
  close(dragPlaneAt(h, 1, ray([0, 1.5, 4]), ray([0, 1.5, 2]), [1, 0, 0]) ?? NaN, 3, 1e-9);
});

test('the pointer along a line: in the plane through the line that faces the view, else the closest point', () => {
  // Looking down -z from (0, 0, 10) at the x axis: the pointer's x.
  close(alongLine({ origin: [0, 0, 10], dir: [3, 7, -10] }, [0, 0, 0], [1, 0, 0], [0, 0, -1]) ?? NaN, 3);
  // A line slanting away from the view (along x and -z): the plane through it facing the view most is x + z = 0,
  // met at (2.5, 7.5, -2.5), which is 2.5 lengths of (1, 0, -1) along it.
  close(alongLine({ origin: [0, 0, 10], dir: [1, 3, -5] }, [0, 0, 0], [1, 0, -1], [0, 0, -1]) ?? NaN, 2.5, 1e-12);
  // Seen end on (the ray along the line): no point along it.
  assert.equal(alongLine({ origin: [0, 0, 10], dir: [0, 0, -1] }, [0, 0, 0], [0, 0, 1], [0, 0, -1]), null);
  assert.equal(alongLine({ origin: [0, 0, 10], dir: [1, 0, 0] }, [0, 0, 0], [0, 0, 0], [0, 0, -1]), null);
});

test("a bone tip is dragged in the plane of the bone and its parent, else in the plane through the bone facing the view", () => {
  const up: V3 = [0, 1, 0];
  // A flat L-system: a bone at 30 degrees off its parent, in the plane z = 0, seen from the front-ish.
  const n = tipDragNormal([0, 2, 0], [0.5, 2.866, 0], up, [-0.4, -0.3, -1]);
  closeV([Math.abs(n[0]), Math.abs(n[1]), Math.abs(n[2])], [0, 0, 1], 1e-12);
  // The turtle's plane seen edge on (the camera in it): the plane through the bone that faces the view.
  const edge = tipDragNormal([0, 2, 0], [0.5, 2.866, 0], up, [1, 0, 0]);
  const u: V3 = [0.5, 0.866, 0];
  close(edge[0] * u[0] + edge[1] * u[1] + edge[2] * u[2], 0, 1e-9);
  assert.ok(Math.abs(edge[0]) > 0.4, `it faces the view: ${edge}`);
  // A bone in line with its parent, or a root: the plane through the bone facing the view.
  const inline = tipDragNormal([0, 0, 0], [0, 1, 0], up, [0, 0, -1]);
  closeV(inline, [0, 0, -1], 1e-12);
  closeV(tipDragNormal([0, 0, 0], [0, 1, 0], null, [0, -0.6, -0.8]), [0, 0, -1], 1e-12);
  // Looking along the bone: the view plane.
  closeV(tipDragNormal([0, 0, 0], [0, 0, 1], null, [0, 0, -2]), [0, 0, -1], 1e-12);
  // The tip dragged along the bone on screen stays on its line: a ray through a point of the line meets the plane there.
  const eye: V3 = [3, 4, 9];
  const target: V3 = [0.75, 3.299, 0];
  closeV(rayPlane({ origin: eye, dir: [target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]] }, n, [0.5, 2.866, 0]), target, 1e-9);
});

test("a bone tip's drag: the pointer's ray meets the view plane through the tip", () => {
  // Looking down -z: the view plane through (1, 2, 3) is z = 3.
  closeV(rayPlane({ origin: [0, 0, 10], dir: [0.5, 0.25, -1] }, [0, 0, -1], [1, 2, 3]), [3.5, 1.75, 3]);
  // Along the plane, or behind the eye: nothing.
  assert.equal(rayPlane({ origin: [0, 0, 10], dir: [1, 0, 0] }, [0, 0, -1], [1, 2, 3]), null);
  assert.equal(rayPlane({ origin: [0, 0, 10], dir: [0, 0, 1] }, [0, 0, -1], [1, 2, 3]), null);
});

test("drag, sketch and writeParams answers decode; bad ones are refused", () => {
  const solved = decodeManipResult(
    {
      outcome: 'solved',
      changes: [{ range: RANGE, old: '1.2', new: '1.7' }],
      residual: 0,
      moved: 16,
      applied: true,
      edit: { documentChanges: [] },
      text: 'system ...',
    },
    'drag',
  );
  assert.deepEqual(solved.changes, [{ range: RANGE, old: '1.2', new: '1.7' }]);
  assert.equal(solved.outcome, 'solved');
  assert.equal(solved.moved, 16);
  assert.equal(solved.applied, true);
  assert.equal(solved.why, null);
  assert.deepEqual(manipSummary(solved), { text: 'drag: 1.2 → 1.7 · moves 16 parts', error: false });

  const shared = decodeManipResult({ outcome: 'solved', changes: [{ range: RANGE, old: 'H', new: 'H - 0.5' }], residual: 0.02, moved: 1, applied: true }, 'drag');
  assert.deepEqual(manipSummary(shared), { text: 'drag: H → H - 0.5 · moves 1 part · off by 0.02', error: false });

  const unreachable = decodeManipResult({ outcome: 'unreachable', why: 'the plane is placed by a random draw', changes: [] }, 'drag');
  assert.deepEqual(manipSummary(unreachable), { text: 'drag: cannot be written: the plane is placed by a random draw', error: true });
  assert.equal(manipSummary(decodeManipResult({ outcome: 'unchanged', changes: [] }, 'drag')).error, false);
  const refused = decodeManipResult({ outcome: 'solved', changes: [{ range: RANGE, old: '3', new: '4' }], moved: 2, applied: false, failureReason: 'the document changed' }, 'drag');
  assert.deepEqual(manipSummary(refused), { text: 'drag: 3 → 4 · moves 2 parts · not applied: the document changed', error: true });

  const sketch = decodeManipResult(
    { outcome: 'solved', name: 'stretch', changes: [{ range: RANGE, old: '4', new: 'mix(4, 6.5, stretch)' }], residuals: [[0.5, 0.01], [1, 0]], exactAtZero: true, moved: 3, applied: true },
    'sketch',
  );
  assert.deepEqual(sketch.residuals, [[0.5, 0.01], [1, 0]]);
  assert.equal(sketch.exactAtZero, true);
  assert.equal(manipSummary(sketch, 'sketch').text, 'sketch: 4 → mix(4, 6.5, stretch) · moves 3 parts · slider stretch · residuals t=0.5: 0.01, t=1: 0 · exact at t = 0');

  // writeParams: no outcome.
  const written = decodeManipResult({ changes: [{ range: RANGE, old: '4', new: '6' }], applied: true }, 'writeParams');
  assert.equal(written.outcome, null);
  assert.equal(manipSummary(written, 'slider values written').text, 'slider values written: 4 → 6');

  assert.throws(() => decodeManipResult(null, 'drag'), ProtocolError);
  assert.throws(() => decodeManipResult({ changes: [1] }, 'drag'), ProtocolError);
  assert.throws(() => decodeManipResult({ changes: [{ old: '1', new: '2' }] }, 'drag'), ProtocolError);
  assert.throws(() => decodeManipResult({ residuals: [[1]] }, 'sketch'), ProtocolError);
  assert.throws(() => decodeManipResult({ residuals: [[1, 'x']] }, 'sketch'), ProtocolError);
});

test('targets are said shortly', () => {
  assert.equal(describeTarget({ kind: 'plane', at: 4.123456 }), 'plane at 4.123');
  assert.equal(describeTarget({ kind: 'tip', at: [1, 2.5, -0.0004] }), 'tip at (1, 2.5, 0)');
  assert.equal(describeTarget({ kind: 'size', axis: 2, size: 4 }), 'size 4 along z');
});

test("a sketch's poses: one per t, sorted, t = 1 needed; another part starts over", () => {
  const k = new SketchKeys();
  const part = JSON.stringify({ kind: 'plane', command: 'deadbeef', edge: 1 });
  assert.equal(k.ready, false);
  assert.equal(k.set(part, 0, { kind: 'plane', at: 1 }), false, 't = 0 is the model as it is');
  assert.equal(k.set(part, 1.5, { kind: 'plane', at: 1 }), false);
  assert.equal(k.set(part, Number.NaN, { kind: 'plane', at: 1 }), false);
  assert.ok(k.set(part, 1, { kind: 'plane', at: 6 }));
  assert.ok(k.ready);
  assert.ok(k.set(part, 0.5, { kind: 'plane', at: 4 }));
  assert.ok(k.set(part, 0.5, { kind: 'plane', at: 4.5 }), 'a later pose at the same t replaces');
  assert.deepEqual(k.keyframes(), [
    { t: 0.5, target: { kind: 'plane', at: 4.5 } },
    { t: 1, target: { kind: 'plane', at: 6 } },
  ]);
  assert.equal(k.part, part);
  k.set(JSON.stringify({ kind: 'bone', key: '00000001' }), 0.25, { kind: 'tip', at: [0, 1, 0] });
  assert.equal(k.size, 1);
  assert.equal(k.ready, false);
  k.clear();
  assert.equal(k.size, 0);
  assert.equal(k.part, '');
});

test("a slider's name is an identifier; only sliders moved off their defaults are written, and the page says which", () => {
  assert.equal(sliderNameProblem('stretch'), null);
  assert.equal(sliderNameProblem('_a1'), null);
  assert.ok(sliderNameProblem(''));
  assert.ok(sliderNameProblem('1a'));
  assert.ok(sliderNameProblem('a b'));
  const info = [
    { name: 'floors', default: 4 },
    { name: 'width', default: 12 },
    { name: 'depth', default: 8 },
  ];
  const values: Record<string, number> = { floors: 6, width: 12 };
  const w = paramsToWrite(info, (n) => values[n]);
  assert.deepEqual(w.params, { floors: 6 });
  assert.match(w.prompt, /floors: 4 → 6/);
  assert.doesNotMatch(w.prompt, /width/);
  assert.deepEqual(paramsToWrite(info, () => undefined), { params: {}, prompt: '' });
});

test('the page may ask for provenance, drag, sketch and writeParams', () => {
  for (const method of ['provenance', 'drag', 'sketch', 'writeParams']) {
    assert.ok((METHODS as readonly string[]).includes(method));
    assert.deepEqual(parsePageMessage({ type: 'request', id: 4, method, params: { a: 1 } }), { type: 'request', id: 4, method, params: { a: 1 } });
  }
  assert.equal(parsePageMessage({ type: 'request', id: 4, method: 'applyEdit', params: {} }), null);
});

test('the extension forwards direct manipulation to the language server, for the shown document only', async () => {
  const posted: HostToPage[] = [];
  const requests: Array<[string, unknown]> = [];
  const deps: HostDeps = {
    request: async (method, params) => {
      requests.push([method, params]);
      if (method === 'grm/drag') return { outcome: 'solved', changes: [{ range: RANGE, old: '4', new: '5' }], moved: 3, applied: true, edit: {} };
      if (method === 'grm/writeParams') throw Object.assign(new Error('floors is not declared in this file'), { code: -32602 });
      return { ok: method };
    },
    readFile: async () => null,
    writeFile: async () => {},
    savePicture: async () => null,
    reveal: async () => {},
    fsPath: (uri) => uri.slice('file://'.length),
    post: (m) => posted.push(m),
  };
  const host = new PreviewHost(deps);
  host.setDocument('file:///w/house.grm', 'house.grm');
  await host.handle({ type: 'ready' });
  posted.length = 0;
  const doc = { uri: 'file:///w/house.grm' };
  const drag = { textDocument: doc, system: 'House', seed: 0, version: 3, part: { kind: 'plane', command: 'deadbeef', edge: 1 }, target: { kind: 'plane', at: 5 } };
  await host.handle({ type: 'request', id: 1, method: 'drag', params: drag });
  await host.handle({ type: 'request', id: 2, method: 'provenance', params: { textDocument: doc, part: drag.part } });
  await host.handle({ type: 'request', id: 3, method: 'sketch', params: { textDocument: doc, part: drag.part, name: 's', keyframes: [{ t: 1, target: drag.target }] } });
  await host.handle({ type: 'request', id: 4, method: 'writeParams', params: { textDocument: doc, params: { floors: 6 } } });
  // Another document than the one shown, or none: refused without asking the server.
  await host.handle({ type: 'request', id: 5, method: 'drag', params: { ...drag, textDocument: { uri: 'file:///w/other.grm' } } });
  await host.handle({ type: 'request', id: 6, method: 'sketch', params: { part: drag.part } });
  assert.deepEqual(
    requests.map(([m]) => m),
    ['grm/drag', 'grm/provenance', 'grm/sketch', 'grm/writeParams'],
  );
  // The page's parameters go as they are.
  assert.deepEqual(requests[0][1], drag);
  assert.deepEqual(posted[0], { type: 'response', id: 1, result: { outcome: 'solved', changes: [{ range: RANGE, old: '4', new: '5' }], moved: 3, applied: true, edit: {} } });
  assert.deepEqual(posted[1], { type: 'response', id: 2, result: { ok: 'grm/provenance' } });
  assert.deepEqual(posted[2], { type: 'response', id: 3, result: { ok: 'grm/sketch' } });
  // The server's refusal, with its code.
  assert.deepEqual(posted[3], { type: 'response', id: 4, error: 'floors is not declared in this file', code: -32602 });
  assert.equal(posted[4].type, 'response');
  assert.match((posted[4] as { error: string }).error, /shows file:\/\/\/w\/house\.grm, not file:\/\/\/w\/other\.grm/);
  assert.match((posted[5] as { error: string }).error, /names no document/);
});

test("a preview's skeleton says each bone's parent (-1 a root); a server that does not is read as before", () => {
  const f32 = (xs: number[]) => bytesToBase64(new Uint8Array(new Float32Array(xs).buffer));
  const i32 = (xs: number[]) => bytesToBase64(new Uint8Array(new Int32Array(xs).buffer));
  const bones = f32([0, 0, 0, 0, 2, 0, 0.1, 0.1, 0, 2, 0, 0.5, 2.866, 0, 0.1, 0.1]);
  const base = { uri: 'file:///b.grm', version: 1, system: 'Bar', mode: 'derive', seed: 0, encoding: 'base64-le', materials: [], parts: [], origins: [] };
  const r = decodePreview({ ...base, skeleton: { boneCount: 2, bones, parents: i32([-1, 0]) } });
  assert.deepEqual(
    r.model.bones.map((b) => b.parent),
    [null, 0],
  );
  assert.equal(decodePreview({ ...base, skeleton: { boneCount: 2, bones } }).model.bones[1].parent, null);
  // A parent past the bones is no parent.
  assert.equal(decodePreview({ ...base, skeleton: { boneCount: 2, bones, parents: i32([-1, 7]) } }).model.bones[1].parent, null);
  assert.throws(() => decodePreview({ ...base, skeleton: { boneCount: 2, bones, parents: i32([-1]) } }), ProtocolError);
});

test("a part's provenance: the numbers that place it, said with their lines and what moves with them", () => {
  const wire = {
    part: { kind: 'plane', command: 1888792066, edge: 1 },
    mode: 'shape',
    system: 'Row',
    measures: [4],
    random: false,
    probed: 12,
    sources: [
      { range: { start: { line: 7, character: 25 }, end: { line: 7, character: 26 } }, text: '4', value: 4, kind: 'literal', derivative: [1.00004], step: 0.004, moves: 49 },
      { range: { start: { line: 2, character: 10 }, end: { line: 2, character: 11 } }, text: 'H', value: 3, kind: 'name', name: 'H', derivative: [0.5], moves: 1 },
    ],
  };
  const p = decodeProvenance(wire);
  assert.deepEqual(p.measures, [4]);
  assert.equal(p.sources[0].moves, 49);
  assert.deepEqual(p.sources[1].derivative, [0.5]);
  assert.equal(provenanceSummary(p), 'placed by 4 (line 8, moves 49 parts), H (line 3, moves 1 part)');
  assert.equal(provenanceSummary(decodeProvenance({ sources: [], random: true })), 'no number in this file places it; a random draw places it too');
  assert.throws(() => decodeProvenance([]), ProtocolError);
  assert.throws(() => decodeProvenance({ sources: [{ text: '4', value: 4 }] }), ProtocolError);
  assert.throws(() => decodeProvenance({ sources: [{ range: wire.sources[0].range, value: 'x' }] }), ProtocolError);
});

test("a pick's ancestry is read (key, symbol and production per node, the root's symbol null); entries without a key are left out", () => {
  const r = decodePick({
    ...pick(),
    shape: null,
    ancestry: [
      { key: '00c0ffee', symbol: null, child: null, production: 0 },
      { key: 'ABCDEF01', symbol: 'A', child: 0, production: 1 },
      { key: 'nope', symbol: 'B' },
      { symbol: 'C' },
      { key: '12345678', symbol: 'F', child: 2, production: null },
    ],
  });
  assert.deepEqual(r?.ancestry, [
    { key: '00c0ffee', symbol: null, production: 0 },
    { key: 'ABCDEF01', symbol: 'A', production: 1 },
    { key: '12345678', symbol: 'F', production: null },
  ]);
  assert.deepEqual(decodePick(pick())?.ancestry, []);
});

test("a bone's length and angle grips sit beside its tip; dragging them scales it along itself or turns it about its base", () => {
  const base: V3 = [1, 0, 0];
  const tip: V3 = [1, 2, 0];
  const normal: V3 = [0, 0, 1];
  const g = boneGrips(base, tip, normal);
  assert.ok(g);
  closeV(g.length, [1, 2 + 2 * BONE_GRIP_OFFSET, 0]);
  // Across the bone, in the plane (z x y = -x).
  closeV(g.angle, [1 - 2 * BONE_GRIP_OFFSET, 2, 0]);
  assert.equal(boneGrips(base, base, normal), null);
  // Length: the move along the bone counts, the move across it does not.
  close(draggedLength(base, tip, g.length, [1.4, 2.5 + 2 * BONE_GRIP_OFFSET, 0]) ?? NaN, 2.5);
  assert.equal(draggedLength(base, tip, g.length, [1, -1, 0]), null);
  // Angle: the grip turned a quarter turn about the base (counter-clockwise about +z) turns the bone with it.
  const r = rotatedTip(base, tip, normal, [1, 2, 0], [-1, 0, 0]);
  assert.ok(r);
  close(r.degrees, 90);
  closeV(r.tip, [-1, 0, 0]);
  // Off the plane: projected into it; the length stays.
  const r2 = rotatedTip(base, tip, normal, [1, 2, 0], [1 + Math.SQRT2, Math.SQRT2, 5]);
  assert.ok(r2);
  close(r2.degrees, -45);
  close(Math.hypot(r2.tip[0] - 1, r2.tip[1], r2.tip[2]), 2);
  assert.equal(rotatedTip(base, tip, normal, base, [2, 0, 0]), null);
});
