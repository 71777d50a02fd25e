// The layout view's 3D mode (editors/preview/src/layout-3d.ts): the
// `grm/layoutCity` answer's mesh buffers decode as the preview's do (base64
// text, quads, or protocol 3's bytes put in place), the caption says what
// grew, and the first camera shows the whole city from above at an angle.

import assert from 'node:assert/strict';
import { test } from 'node:test';
import { cityCaption, decodeLayoutCity, frameCity } from '../preview/src/layout-3d.js';
import { bytesToBase64 } from '../preview/src/protocol.js';

const f32 = (xs: number[]) => new Uint8Array(new Float32Array(xs).buffer);
const u32 = (xs: number[]) => new Uint8Array(new Uint32Array(xs).buffer);

/** One triangle and one quad (three corners), a grey and a brick material. */
function answer(bytes: (b: Uint8Array) => unknown) {
  return {
    uri: 'file:///c/city.grm',
    encoding: 'base64-le',
    materials: [
      { name: 'ground', color: [0.5, 0.5, 0.5], roughness: 1, metallic: 0, emissive: [0, 0, 0], opacity: 1 },
      { name: 'brick', color: [0.6, 0.3, 0.2], roughness: 0.9, metallic: 0, emissive: [0, 0, 0], opacity: 1 },
    ],
    parts: [
      { material: 0, vertexCount: 3, triangleCount: 1, positions: bytes(f32([0, 0, 0, 10, 0, 0, 0, 0, -10])), normals: '', indices: bytes(u32([0, 1, 2])), pickCount: 0, picks: '' },
      { material: 1, vertexCount: 4, triangleCount: 2, positions: bytes(f32([0, 0, 0, 4, 0, 0, 4, 12, 0])), normals: '', indices: '', pickCount: 0, picks: '', layout: 'quads' },
    ],
    boundsMin: [0, 0, -10],
    boundsMax: [10, 12, 0],
    buildings: 196,
    reused: 181,
    edited: 2,
    parcels: 197,
    triangles: 3,
    vertices: 7,
    problems: [{ code: 'R1032', message: 'edit 2: parcel 00000000000000ff is not in the layout' }],
    growMs: 18.4,
  };
}

test("the city's buffers decode as the preview's, base64 or a blob's bytes", () => {
  for (const enc of [(b: Uint8Array) => bytesToBase64(b), (b: Uint8Array) => b]) {
    const c = decodeLayoutCity(answer(enc));
    assert.equal(c.model.parts.length, 2);
    assert.equal(c.model.triangles, 3, 'the quad is two triangles');
    assert.equal(c.model.parts[1].positions.length, 12, 'its fourth corner rebuilt');
    assert.deepEqual(Array.from(c.model.parts[1].positions.slice(9)), [0, 12, 0]);
    assert.deepEqual(c.model.bounds, { min: [0, 0, -10], max: [10, 12, 0] });
    assert.equal(c.model.materials[1].name, 'brick');
    assert.deepEqual(c.problems, [{ code: 'R1032', message: 'edit 2: parcel 00000000000000ff is not in the layout' }]);
  }
  assert.throws(() => decodeLayoutCity({ png: 'iVBO' }), /parts/);
  assert.throws(() => decodeLayoutCity({ ...answer(bytesToBase64), buildings: 'many' }), /buildings/);
  const bad = answer(bytesToBase64);
  bad.parts[0].indices = bytesToBase64(u32([0, 1, 7]));
  assert.throws(() => decodeLayoutCity(bad), /out of range/);
});

test('the caption says what grew, what the cache kept and what was edited', () => {
  const c = decodeLayoutCity(answer(bytesToBase64));
  assert.equal(cityCaption(c), '196 buildings on 197 parcels; 15 grown in 18 ms, 181 kept from the last update; 2 with building edits');
  assert.equal(cityCaption({ ...c, edited: 0 }), '196 buildings on 197 parcels; 15 grown in 18 ms, 181 kept from the last update');
});

test('the first camera looks at the middle of the city from above at an angle, and sees all of it', () => {
  const b = { min: [0, 0, -400] as [number, number, number], max: [700, 40, 0] as [number, number, number] };
  const f = frameCity(b, 45);
  assert.deepEqual(f.target, [350, 20, -200]);
  const d = [f.position[0] - f.target[0], f.position[1] - f.target[1], f.position[2] - f.target[2]];
  const dist = Math.hypot(d[0], d[1], d[2]);
  const radius = Math.hypot(700, 40, 400) / 2;
  assert.ok(Math.abs(dist - radius / Math.sin((22.5 * Math.PI) / 180)) < 1e-6, 'the bounding sphere fits the field of view');
  assert.ok(Math.abs(Math.asin(d[1] / dist) - (35 * Math.PI) / 180) < 1e-9, '35 degrees up');
  assert.ok(f.near < dist - radius && f.far > dist + radius, 'near and far hold the city');
});
