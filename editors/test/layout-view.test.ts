// The layout view's pure logic (editors/preview/src/layout-view.ts): which
// documents it shows, the fit between metres and pixels, hit tests on
// streets, regions, tags typed by the artist, the operators' JSON as the
// sidecar writes selections, and the server's answers decoded.

import assert from 'node:assert/strict';
import { test } from 'node:test';
import {
  type LayoutStreet,
  decodeLayout,
  decodeLayoutEdit,
  distToPolyline,
  draggedStreets,
  fitView,
  hitStreet,
  isGrmUri,
  isLayoutUri,
  moveOp,
  parseTags,
  pointInRing,
  rectRing,
  toScreen,
  toWorld,
} from '../preview/src/layout-view.js';

const street = (id: string, points: [number, number][], layer: number | null = 0, width = 8): LayoutStreet => ({
  id,
  layer,
  layerId: layer === null ? null : id,
  points,
  cls: 'minor',
  width,
  protected: false,
});

test('only NAME.layout.json documents are layouts', () => {
  assert.ok(isLayoutUri('file:///x/city.layout.json'));
  assert.ok(!isLayoutUri('file:///x/.layout.json'));
  assert.ok(!isLayoutUri('file:///x/city.grm'));
  assert.ok(!isLayoutUri('file:///x/city.layout.json.tmp'));
});

test('the fit shows the bounds centred with y up, and screen and world points round-trip', () => {
  const v = fitView([0, 0, 200, 100], 440, 240, 20);
  assert.equal(v.scale, 2);
  assert.deepEqual(toScreen(v, [0, 0]), [20, 220]);
  assert.deepEqual(toScreen(v, [200, 100]), [420, 20]);
  const w = toWorld(v, toScreen(v, [37.5, 12.25]));
  assert.ok(Math.abs(w[0] - 37.5) < 1e-9 && Math.abs(w[1] - 12.25) < 1e-9);
  // A degenerate box still gives a finite scale.
  assert.ok(Number.isFinite(fitView([5, 5, 5, 5], 100, 100).scale));
});

test('a click hits the nearest street within its half width and the tolerance', () => {
  const a = street('a', [
    [0, 0],
    [100, 0],
  ]);
  const b = street('b', [
    [0, 20],
    [100, 20],
  ]);
  assert.equal(distToPolyline([50, 3], a.points), 3);
  assert.equal(distToPolyline([-4, 3], a.points), 5);
  assert.equal(hitStreet([a, b], [50, 5], 2)?.id, 'a');
  assert.equal(hitStreet([a, b], [50, 16], 2)?.id, 'b');
  assert.equal(hitStreet([a, b], [50, 10], 2), null);
  // At the same place, a layer's street wins over one a merge made.
  const merged = street('m', a.points, null);
  assert.equal(hitStreet([merged, a], [50, 1], 2)?.id, 'a');
});

test('a region is a counter-clockwise box; points inside it are found', () => {
  const r = rectRing([10, 5], [0, 0]);
  assert.deepEqual(r, [
    [0, 0],
    [10, 0],
    [10, 5],
    [0, 5],
  ]);
  assert.ok(pointInRing([5, 2], r));
  assert.ok(!pointInRing([11, 2], r));
});

test('tags read numbers and booleans as such, and refuse what is not name=value', () => {
  assert.deepEqual(parseTags('height=30, style=brick, building=false'), { height: 30, style: 'brick', building: false });
  assert.throws(() => parseTags('height'), /not name=value/);
  assert.throws(() => parseTags(' , '), /no tags/);
});

test('moves name their selection as the sidecar writes it, in millimetres', () => {
  const s = street('00000000000000aa', [
    [0, 0],
    [10, 0],
  ]);
  assert.deepEqual(moveOp({ kind: 'street', street: s }, [1.23456, -2]), {
    move: { select: { ids: ['00000000000000aa'] }, translate: [1.235, -2] },
  });
  assert.deepEqual(moveOp({ kind: 'continuation', street: s, maxTurn: 30 }, [1, 0]), {
    move: { select: { continuation: { street: '00000000000000aa', max_turn: 30 } }, translate: [1, 0] },
  });
  assert.deepEqual(moveOp({ kind: 'soft', centre: [5, 5], radius: 40 }, [0, 1]), {
    move: { select: { soft: { centre: [5, 5], radius: 40 } }, translate: [0, 1] },
  });
  const ring = rectRing([0, 0], [1, 1]);
  assert.deepEqual(moveOp({ kind: 'region', ring }, [0, 1]), { move: { select: { region: ring }, translate: [0, 1] } });
  // A piece of a cut street is moved by its whole street's identity.
  const piece = { ...s, id: 'piece', layerId: 'whole' };
  assert.deepEqual(moveOp({ kind: 'street', street: piece }, [1, 0]), { move: { select: { ids: ['whole'] }, translate: [1, 0] } });
});

test('a drag carries the streets of its selection in the view', () => {
  const a = street('a', [
    [0, 0],
    [10, 0],
  ]);
  const far = street('far', [
    [500, 0],
    [510, 0],
  ]);
  assert.deepEqual(
    draggedStreets({ kind: 'soft', centre: [0, 0], radius: 20 }, [a, far]).map((s) => s.id),
    ['a'],
  );
  assert.deepEqual(
    draggedStreets({ kind: 'region', ring: rectRing([-1, -1], [11, 1]) }, [a, far]).map((s) => s.id),
    ['a'],
  );
});

test("the server's answers decode; malformed ones throw", () => {
  const raw = {
    uri: 'file:///c.layout.json',
    version: 3,
    layers: [{ index: 0, name: 'base', visible: true, merge: 'hard', source: 'grid', moves: 1, protected: [], assignments: 0, streets: 2, parcels: 4 }],
    streets: [{ id: 'a', layer: 0, layerId: 'a', points: [[0, 0], [1, 0]], class: 'major', width: 12, protected: true }],
    parcels: [{ id: 'p', layer: null, ring: [[0, 0], [1, 0], [1, 1]], protected: false, tags: { height: 3 } }],
    blocks: [],
    problems: [{ code: 'R1012', message: 'layer `park`: cannot read `x`' }],
    invalid: [],
    bounds: [0, 0, 1, 1],
  };
  const a = decodeLayout(raw);
  assert.equal(a.version, 3);
  assert.equal(a.streets[0].cls, 'major');
  assert.equal(a.streets[0].protected, true);
  assert.equal(a.parcels[0].layer, null);
  assert.deepEqual(a.problems, [{ code: 'R1012', message: 'layer `park`: cannot read `x`' }]);
  assert.throws(() => decodeLayout({ ...raw, streets: [{ id: 'a', points: [[0]] }] }));
  assert.throws(() => decodeLayout(null));
  assert.deepEqual(decodeLayoutEdit({ applied: false, rejected: { code: 'R1013', message: 'layer `base`: move 0 rejected' } }), {
    applied: false,
    written: false,
    rejected: { code: 'R1013', message: 'layer `base`: move 0 rejected' },
    failureReason: null,
    newLayer: null,
  });
  assert.equal(decodeLayoutEdit({ applied: true, written: true, newLayer: 2 }).newLayer, 2);
});

test("a grammar is offered the view (its layout item), and the answer says the item and the sidecar it edits", () => {
  assert.ok(isGrmUri('file:///x/city.grm'));
  assert.ok(!isGrmUri('file:///x/city.layout.json'));
  assert.ok(!isGrmUri('file:///x/.grm'));
  const probe = decodeLayout({ uri: 'file:///x/city.grm', version: 1, item: 'City', sidecar: 'file:///x/city.layout.json', layers: [], streets: [], parcels: [], problems: [], invalid: [], bounds: [0, 0, 0, 0] });
  assert.equal(probe.item, 'City');
  assert.equal(probe.sidecar, 'file:///x/city.layout.json');
  const side = decodeLayout({ layers: [], streets: [], parcels: [] });
  assert.equal(side.item, null, 'a sidecar has no item');
  assert.equal(side.sidecar, null);
});
