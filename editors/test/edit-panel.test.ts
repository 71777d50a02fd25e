// The edit panel's pure logic (editors/preview/src/edit-panel.ts) and the
// persistent edits' wire format (edits-protocol.ts): semantic locators
// read, widened to a row, a column, all facades, anchored from the end;
// the levels a pick offers; the alternatives of a rule; the preview's
// `edits` and the edit requests' answers decoded.

import assert from 'node:assert/strict';
import { test } from 'node:test';
import {
  alternativesOf,
  assetsFromSymbols,
  candidateText,
  entryKey,
  entryText,
  fieldNumber,
  levelsOf,
  opText,
  parseSemanticLocator,
  semanticQuery,
  targetOf,
  widen,
  type TagMatch,
} from '../preview/src/edit-panel.js';
import { decodeEditAnswer, decodeEdits, decodeTarget, targetParam } from '../preview/src/edits-protocol.js';
import type { HostToPage } from '../preview/src/messages.js';
import { type HostDeps, PreviewHost } from '../vscode/src/host.js';
import { type Origin, type PickResult, ProtocolError, decodePick, decodePreview } from '../preview/src/protocol.js';

const WINDOW = '(house = 2/3, facade = 1/2, floor = 3/3, column = 4/5) Window';

test('a semantic locator reads as grm/pick writes it; one that does not is null', () => {
  assert.deepEqual(parseSemanticLocator(WINDOW), {
    entries: [
      { tag: 'house', index: 2, count: 3 },
      { tag: 'facade', index: 1, count: 2 },
      { tag: 'floor', index: 3, count: 3 },
      { tag: 'column', index: 4, count: 5 },
    ],
    label: 'Window',
  });
  assert.deepEqual(parseSemanticLocator('() Lot'), { entries: [], label: 'Lot' });
  assert.equal(parseSemanticLocator('(floor = 3) Window'), null, 'a query is not a locator');
  assert.equal(parseSemanticLocator('{Lot, 1, Mass}'), null);
  assert.equal(parseSemanticLocator('(floor = 3/3)'), null, 'a locator names its label');
});

test('the query of a selection names every tag from the start; widened, the row, column or facades are any', () => {
  const loc = parseSemanticLocator(WINDOW)!;
  assert.equal(semanticQuery(loc), '(house = 2, facade = 1, floor = 3, column = 4) Window');
  const row = widen(loc, new Map(), 'row')!;
  assert.equal(semanticQuery(loc, row), '(house = 2, facade = 1, floor = 3) Window', 'its row: every column of its floor');
  const column = widen(loc, new Map(), 'column')!;
  assert.equal(semanticQuery(loc, column), '(house = 2, facade = 1, column = 4) Window', 'its column: every floor');
  const facades = widen(loc, column, 'facades')!;
  assert.equal(semanticQuery(loc, facades), '(house = 2, column = 4) Window', 'widenings add up');
  // A part without a floor tag has no column to widen to.
  const ground = parseSemanticLocator('(house = 1/3, facade = 2/2) Door')!;
  assert.equal(widen(ground, new Map(), 'column'), null);
  assert.equal(widen(ground, new Map(), 'row'), null);
  assert.ok(widen(ground, new Map(), 'facades'));
});

test('a tag anchored at the end counts from the last (every floor\'s last window)', () => {
  const loc = parseSemanticLocator(WINDOW)!;
  const m = new Map<string, TagMatch>([
    ['column', 'end'],
    ['floor', 'any'],
  ]);
  assert.equal(semanticQuery(loc, m), '(house = 2, facade = 1, column = end 2) Window');
  const last = parseSemanticLocator('(floor = 3/3, column = 5/5) Window')!;
  assert.equal(semanticQuery(last, new Map([['column', 'end']])), '(floor = 3, column = end 1) Window');
});

test('a tag twice on the path is two entries, each matched on its own', () => {
  const loc = parseSemanticLocator('(bay = 2/4, bay = 1/3) Pane')!;
  assert.deepEqual([entryKey(loc, 0), entryKey(loc, 1)], ['bay', 'bay#2']);
  assert.equal(semanticQuery(loc, new Map([['bay#2', 'any']])), '(bay = 2) Pane');
});

const scope = (label: string, command: boolean, key: string, exact?: string, semantic?: string) => ({
  node: 0,
  label,
  command,
  origin: [0, 0, 0],
  axes: [
    [1, 0, 0],
    [0, 1, 0],
    [0, 0, 1],
  ],
  size: [1, 1, 1],
  key,
  ...(exact ? { exact } : {}),
  ...(semantic ? { semantic } : {}),
});

function shapePick(): PickResult {
  return decodePick({
    uri: 'file:///t/row.grm',
    range: { start: { line: 12, character: 4 }, end: { line: 12, character: 10 } },
    symbol: 'Window',
    version: 3,
    module: 7,
    key: '0000000c',
    ancestry: [
      { key: '0000000a', symbol: 'Floor', child: null, production: 4 },
      { key: '0000000b', symbol: 'repeat.x', child: 1, production: null },
      { key: '0000000c', symbol: 'Window', child: 2, production: 6 },
    ],
    shape: {
      node: 9,
      exact: '{Floor, 1, repeat.x, 2, Window}',
      semantic: '(column = 2/5) Window',
      madeBy: 'repeat.x',
      scopes: [
        scope('Floor', false, '0000000a', '{Floor}', '() Floor'),
        scope('repeat.x', true, '0000000b'),
        scope('Window', false, '0000000c', '{Floor, 1, repeat.x, 2, Window}', '(column = 2/5) Window'),
      ],
    },
  })!;
}

test('a shape pick offers its shapes from the part up, commands left out, each with its locators and rule', () => {
  const levels = levelsOf(shapePick());
  assert.deepEqual(
    levels.map((l) => [l.label, l.key, l.exact, l.production]),
    [
      ['Window', '0000000c', '{Floor, 1, repeat.x, 2, Window}', 6],
      ['Floor', '0000000a', '{Floor}', 4],
    ],
  );
  assert.deepEqual(levels[1].semantic, { entries: [], label: 'Floor' });
  assert.deepEqual(targetOf(levels[0], 'exact', new Map()), { target: { kind: 'exact', text: '{Floor, 1, repeat.x, 2, Window}' } });
  assert.deepEqual(targetOf(levels[1], 'key', new Map()), { target: { kind: 'key', text: '0000000a' } });
  assert.deepEqual(targetOf(levels[0], 'semantic', new Map([['column', 'any' as TagMatch]])), { target: { kind: 'semantic', text: '() Window' } });
});

test('a derive-mode pick offers its modules by key, the axiom left out; they have no exact or semantic target', () => {
  const r = decodePick({
    uri: 'file:///t/tree.grm',
    range: { start: { line: 3, character: 0 }, end: { line: 3, character: 9 } },
    symbol: 'F',
    version: 1,
    module: 4,
    key: '000000f2',
    ancestry: [
      { key: '00000001', symbol: null },
      { key: '000000a1', symbol: 'A', production: 0 },
      { key: '000000f2', symbol: 'F' },
    ],
  })!;
  const levels = levelsOf(r);
  assert.deepEqual(
    levels.map((l) => [l.label, l.key, l.production]),
    [
      ['F', '000000f2', null],
      ['A', '000000a1', 0],
    ],
  );
  assert.ok('problem' in targetOf(levels[0], 'exact', new Map()));
  assert.ok('problem' in targetOf(levels[0], 'semantic', new Map()));
});

test('the alternatives of a rule are its productions in source order, numbered from 1', () => {
  const o = (symbol: string, line: number): Origin => ({ uri: '', symbol, range: { start: { line, character: 0 }, end: { line, character: 1 } } });
  const origins = [o('axiom', 0), o('Tile', 5), o('Window', 6), o('Wall', 7), o('Window', 8)];
  assert.deepEqual(alternativesOf(origins, 'Window'), [
    { k: 1, origin: 2, line: 7 },
    { k: 2, origin: 4, line: 9 },
  ]);
  assert.deepEqual(alternativesOf(origins, 'Glass'), []);
});

test('operations and entries read as the server writes them', () => {
  assert.equal(opText({ op: 'material', name: 'glass' }), 'material glass');
  assert.equal(opText({ op: 'force', alternative: 2 }), 'force alternative 2');
  assert.equal(opText({ op: 'offset', name: 'len', by: -0.5 }), 'offset len by -0.5');
  assert.equal(opText({ op: 'remove' }), 'remove');
  assert.equal(fieldNumber(' 2.5 '), 2.5);
  assert.equal(fieldNumber(''), null);
  assert.equal(fieldNumber('1e999'), null);
});

test('materials and meshes come from the document symbols (imports are no meshes)', () => {
  const symbols = [
    { name: 'glass', kind: 19 },
    { name: 'leaf', kind: 1, detail: 'leaf.obj' },
    { name: 'common', kind: 1, detail: 'common.grm' },
    { name: 'floors', kind: 13, detail: '4 in 1 .. 20' },
  ];
  assert.deepEqual(assetsFromSymbols(symbols), { materials: ['glass'], meshes: ['leaf'] });
  assert.deepEqual(assetsFromSymbols(null), { materials: [], meshes: [] });
});

test("the preview's edits decode with their classes and retarget candidates; a bad one is a ProtocolError", () => {
  const e = decodeEdits({
    uri: 'file:///t/row.edits.json',
    found: true,
    problems: 1,
    list: [
      { id: 1, system: 'Row', target: { exact: '{Lot, 1, Mass}' }, op: 'remove', class: 'valid', detail: '', replayed: true, parts: [114] },
      {
        id: 2,
        system: 'Row',
        target: { semantic: '(floor = 99) Window' },
        op: 'material glass',
        class: 'structurally_invalid',
        detail: 'the query selects no part now',
        replayed: false,
        parts: [],
        retarget: [{ target: { semantic: '(floor = 3) Window' }, reason: 'symbol_and_tags', parts: [210, 214] }],
      },
    ],
  })!;
  assert.equal(e.problems, 1);
  assert.equal(e.list.length, 2);
  assert.deepEqual(e.list[1].target, { kind: 'semantic', text: '(floor = 99) Window' });
  assert.equal(entryText(e.list[1]), '#2 material glass on (floor = 99) Window');
  assert.equal(candidateText(e.list[1].retarget[0]), '(floor = 3) Window (symbol and tags; 2 parts)');
  assert.deepEqual(targetParam(e.list[1].retarget[0].target), { semantic: '(floor = 3) Window' });
  assert.equal(decodeEdits(undefined), null);
  assert.throws(() => decodeEdits({ list: [{ id: 0, target: { key: '00000001' } }] }), ProtocolError);
  assert.throws(() => decodeTarget({ exact: '{A}', key: '00000001' }, 't'), ProtocolError, 'one kind of target');
  assert.throws(() => decodeEdits({ list: [{ id: 1, target: { key: 'x' }, parts: [-1] }] }), ProtocolError);
});

test('a preview result carries its edits; one without has none', () => {
  const base = { uri: 'file:///t/a.grm', version: 1, mode: 'shape', seed: 1, meshes: [], bones: [] };
  assert.equal(decodePreview(base).edits, null);
  const r = decodePreview({ ...base, edits: { uri: 'file:///t/a.edits.json', found: false, problems: 0, list: [] } });
  assert.deepEqual(r.edits, { uri: 'file:///t/a.edits.json', found: false, problems: 0, list: [] });
});

test("the edit requests' answer decodes; a missing id is a ProtocolError", () => {
  assert.deepEqual(decodeEditAnswer({ uri: 'file:///t/a.edits.json', id: 3, edit: {}, applied: true, written: true }), {
    uri: 'file:///t/a.edits.json',
    id: 3,
    applied: true,
    written: true,
    failureReason: null,
  });
  assert.equal(decodeEditAnswer({ id: 1, applied: false, failureReason: 'no' }).failureReason, 'no');
  assert.throws(() => decodeEditAnswer({ applied: true }), ProtocolError);
});

test("VS Code's host sends the panel's edit requests to the server as they are (the server applies them as workspace edits); another document's are refused", async () => {
  const requests: Array<[string, unknown]> = [];
  const posted: HostToPage[] = [];
  const deps: HostDeps = {
    request: async (method, params) => {
      requests.push([method, params]);
      return { uri: 'file:///w/row.edits.json', id: 3, edit: {}, applied: true, written: false };
    },
    readFile: async () => null,
    writeFile: async () => {},
    savePicture: async () => null,
    reveal: async () => {},
    fsPath: (uri) => uri.slice('file://'.length),
    post: (m) => posted.push(m),
  };
  const host = new PreviewHost(deps);
  host.setDocument('file:///w/row.grm', 'row.grm');
  await host.handle({ type: 'ready' });
  const edit = { uri: 'file:///w/row.grm', target: { semantic: '(floor = 2) Window' }, op: { op: 'force', alternative: 2 } };
  await host.handle({ type: 'request', id: 1, method: 'edit', params: edit });
  await host.handle({ type: 'request', id: 2, method: 'removeEdit', params: { uri: 'file:///w/row.grm', id: 3 } });
  await host.handle({ type: 'request', id: 3, method: 'retargetEdit', params: { uri: 'file:///w/row.grm', id: 3, target: { exact: '{Lot}' } } });
  assert.deepEqual(
    requests.map(([m]) => m),
    ['grm/edit', 'grm/removeEdit', 'grm/retargetEdit'],
  );
  assert.deepEqual(requests[0][1], edit);
  assert.equal(decodeEditAnswer((posted.at(-1) as { result: unknown }).result).id, 3);
  await host.handle({ type: 'request', id: 4, method: 'edit', params: { ...edit, uri: 'file:///w/other.grm' } });
  assert.equal(requests.length, 3, 'not sent');
  assert.match(String((posted.at(-1) as { error?: string }).error), /other\.grm/);
});
