// The derivation view's model against a server that answers `grm/tree`
// from a tree it holds, as the language server does (docs/lsp-extensions.md).
import assert from 'node:assert/strict';
import { test } from 'node:test';
import { DerivationTree, parseTreeAnswer } from '../preview/src/tree.js';

// node, parent, key, label
const NODES: Array<[number, number | null, string, string]> = [
  [0, null, '00000001', 'Lot'],
  [1, 0, '00000002', 'Mass'],
  [2, 1, '00000003', 'split.z'],
  [3, 2, '00000004', 'Ground'],
  [4, 2, '00000005', 'Top'],
  [5, 3, '00000006', 'Door'],
];

function server(version: { v: number }) {
  const asked: unknown[] = [];
  const out = (i: number) => {
    const [node, , key, label] = NODES[i]!;
    return { node, key, label, children: NODES.filter((n) => n[1] === node).length, uri: 'file:///h.grm', range: { start: { line: node, character: 0 }, end: { line: node, character: 4 } } };
  };
  const request = async (method: string, params: unknown) => {
    assert.equal(method, 'grm/tree');
    asked.push(params);
    const p = params as { node?: number; key?: string };
    let at = p.node ?? 0;
    const path: number[] = [];
    if (p.key !== undefined) {
      const i = NODES.findIndex((n) => n[2] === p.key);
      if (i < 0) return null;
      at = i;
      for (let j: number | null = i; j !== null; j = NODES[j]![1]) path.unshift(j);
    }
    if (at >= NODES.length) return null;
    return { version: version.v, mode: 'shape', node: out(at), children: NODES.filter((n) => n[1] === at).map((n) => out(n[0])), path };
  };
  return { request, asked };
}

test('levels are read on demand and cached; a pick key reveals its path with parents', async () => {
  const version = { v: 3 };
  const s = server(version);
  const t = new DerivationTree({ request: s.request });
  assert.deepEqual(await t.roots(), [], 'no document: an empty view');
  t.setDocument('file:///h.grm', 3);
  const [root] = await t.roots();
  assert.equal(root!.label, 'Lot');
  assert.equal(root!.range!.start.line, 0);
  const [mass] = await t.children(root!);
  assert.equal(mass!.label, 'Mass');
  assert.equal(t.parentOf(mass!), root);
  const before = s.asked.length;
  await t.children(root!);
  assert.equal(s.asked.length, before, 'a level read once');
  // The door, from a pick's key: every level down to it is known.
  const door = await t.find('00000006');
  assert.equal(door!.label, 'Door');
  const chain: string[] = [];
  for (let n: typeof door | undefined = door; n; n = t.parentOf(n)) chain.unshift(n.label);
  assert.deepEqual(chain, ['Lot', 'Mass', 'split.z', 'Ground', 'Door']);
  assert.equal(await t.find('ffffffff'), null);
  // A newer preview drops the old levels.
  version.v = 4;
  const again = await t.find('00000005');
  assert.equal(again!.label, 'Top');
  assert.equal(t.parentOf(again!)!.label, 'split.z');
});

test('stillCurrent: the same preview keeps what was read; another version or root key drops it', async () => {
  const version = { v: 3 };
  const s = server(version);
  const t = new DerivationTree({ request: s.request });
  t.setDocument('file:///h.grm', 3);
  const [root] = await t.roots();
  await t.children(root!);
  assert.equal(await t.stillCurrent(), true, 'the same version and root');
  const before = s.asked.length;
  await t.children(root!);
  assert.equal(s.asked.length, before, 'the levels read are kept');
  version.v = 4;
  assert.equal(await t.stillCurrent(), false, 'a newer preview');
  const asked = s.asked.length;
  const [again] = await t.roots();
  assert.equal(s.asked.length, asked, 'the new root is kept');
  assert.equal(again!.label, 'Lot');
  const [mass] = await t.children(again!);
  assert.equal(s.asked.length, asked, "the new root's answer brought its children");
  await t.children(mass!);
  assert.ok(s.asked.length > asked, 'the deeper levels are read again');
  assert.equal(await t.stillCurrent(), true);
  // Another seed's tree: the same version, another root key.
  NODES[0]![2] = '0000000a';
  try {
    assert.equal(await t.stillCurrent(), false, 'another root key');
  } finally {
    NODES[0]![2] = '00000001';
  }
});

test('answers that are not trees are refused', () => {
  assert.equal(parseTreeAnswer(null), null);
  assert.throws(() => parseTreeAnswer({ version: 1 }), /not a tree answer/);
  assert.throws(() => parseTreeAnswer({ version: 1, mode: 'shape', node: { node: 0 }, children: [] }), /lacks/);
});
