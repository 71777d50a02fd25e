// The layout view (issue 29, item 6) in headless Chromium against
// `grmc view examples/city.layout.json` (a copy): the page shows the plan
// and its layers; a street of the base layer dragged with the mouse lands
// in the sidecar as a move and the view redraws it where it was dropped; a
// layer's checkbox hides its streets (the sidecar says `visible: false`);
// the 3D mode shows the city with its buildings (a WebGL canvas that draws
// triangles). The pictures of the view
// go to target/browser-test/layout-view.png and layout-city.png
// (docs/img/layout-editor.png is the first).
//
// Needs: `cargo build -p grmc` (or GRMC=path), Debian's chromium
// (CHROMIUM=path). PAGE_DIST=editors/preview/dist serves the page from that
// folder instead of the copy built into grmc.

import assert from 'node:assert/strict';
import { copyFileSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import { test } from 'node:test';
import { type Page } from 'playwright-core';
import { artifacts, harness, pageErrors, root } from './harness.js';

const h = harness();
const { view, openPage } = h;

/** The example city in a fresh folder (the view rewrites its sidecar). */
function city(): string {
  const dir = h.temp();
  for (const f of ['city.layout.json', 'city_park.geojson', 'city_building.grm']) copyFileSync(join(root, 'examples', f), join(dir, f));
  return join(dir, 'city.layout.json');
}

interface Drawn {
  id: string;
  layer: string;
  /** Screen points, relative to the plan. */
  points: [number, number][];
}

/** The plan's streets as drawn, its draw count, and the fit (metres to pixels). */
async function plan(page: Page): Promise<{ draws: number; streets: Drawn[]; fit: { scale: number; ox: number; oy: number } }> {
  return page.evaluate(() => {
    const svg = document.getElementById('layout-plan') as unknown as SVGSVGElement;
    const streets = Array.from(svg.querySelectorAll('polyline[data-street]')).map((p) => ({
      id: p.getAttribute('data-street') ?? '',
      layer: p.getAttribute('data-layer') ?? '',
      points: (p.getAttribute('points') ?? '')
        .trim()
        .split(/\s+/)
        .map((xy: string) => xy.split(',').map(Number) as [number, number]),
    }));
    return { draws: Number(svg.dataset.draws ?? 0), streets, fit: JSON.parse(svg.dataset.fit ?? '{}') };
  });
}

test('a street dragged in grmc view lands in the sidecar, the view redraws it, and a hidden layer hides its streets', async () => {
  const file = city();
  const page = await openPage(await view(file));
  const errors = pageErrors(page);
  await page.waitForSelector('#layout-view:not([hidden])');
  await page.waitForFunction(() => Number(document.getElementById('layout-plan')?.dataset.draws ?? 0) > 0);
  await page.waitForSelector('#layout-layers .layout-layer');
  const names = await page.$$eval('#layout-layers .layout-layer span:nth-of-type(1)', (xs) => xs.map((x) => x.textContent));
  assert.deepEqual(names, ['avenue', 'park', 'old town', 'base'], 'top layer first');
  const before = await plan(page);
  const f = before.fit;
  const world = (p: [number, number]): [number, number] => [(p[0] - f.ox) / f.scale, -(p[1] - f.oy) / f.scale];
  // A base street in the east, away from the old town and the avenue.
  const s = before.streets.find(
    (x) =>
      x.layer === '0' &&
      x.points.length === 2 &&
      x.points.every((p) => {
        const [wx, wy] = world(p);
        return wx > 480 && wx < 680 && wy > 100 && wy < 300;
      }),
  );
  assert.ok(s, 'a base street in the east');
  const box = await page.locator('#layout-plan').boundingBox();
  assert.ok(box);
  const mid: [number, number] = [(s.points[0][0] + s.points[1][0]) / 2, (s.points[0][1] + s.points[1][1]) / 2];
  await page.mouse.move(box.x + mid[0], box.y + mid[1]);
  await page.mouse.down();
  for (let k = 1; k <= 4; k++) await page.mouse.move(box.x + mid[0] + 2 * k, box.y + mid[1] - k);
  await page.mouse.up();

  // The sidecar has the move; the view drew the street where it was dropped.
  const deadline = Date.now() + 30_000;
  while (!readFileSync(file, 'utf8').includes('"moves"')) {
    assert.ok(Date.now() < deadline, `no move in the sidecar: ${await page.textContent('#layout-status')}`);
    await new Promise((r) => setTimeout(r, 100));
  }
  const sidecar = JSON.parse(readFileSync(file, 'utf8'));
  const move = sidecar.layers[0].moves[0];
  assert.deepEqual(move.select, { ids: [s.id] });
  assert.ok(Math.abs(move.translate[0] - 8 / f.scale) < 0.01 && Math.abs(move.translate[1] - 4 / f.scale) < 0.01, JSON.stringify(move));
  await page.waitForFunction(
    ([id, x]) => {
      const p = document.querySelector(`#layout-plan polyline[data-street="${id}"]`);
      const first = Number((p?.getAttribute('points') ?? '').split(',')[0]);
      return Math.abs(first - x) < 1;
    },
    [s.id, s.points[0][0] + 8] as const,
    { timeout: 30_000 },
  );
  await page.screenshot({ path: join(artifacts, 'layout-view.png') });

  // Hide the avenue: its streets leave the plan, and the sidecar says so.
  const avenue = (await plan(page)).streets.filter((x) => x.layer === '3');
  assert.ok(avenue.length > 0);
  await page.locator('#layout-layers .layout-layer[data-layer="3"] .layout-visible').uncheck();
  await page.waitForFunction(() => document.querySelectorAll('#layout-plan polyline[data-layer="3"]').length === 0, undefined, { timeout: 30_000 });
  assert.equal(JSON.parse(readFileSync(file, 'utf8')).layers[3].visible, false);
  const after = await plan(page);
  for (const a of avenue) assert.ok(!after.streets.some((x) => x.id === a.id), `${a.id} hidden`);

  // 3D: the buildings grown on the parcels, drawn by the page's three.js from the server's mesh buffers.
  await page.locator('#layout-3d').check();
  await page.waitForFunction(() => Number(document.getElementById('layout-city')?.dataset.buildings ?? 0) > 100, undefined, { timeout: 60_000 });
  assert.equal(await page.locator('#layout-city').isVisible(), true);
  await page.waitForFunction(() => Number(document.getElementById('layout-city')?.dataset.drawnTriangles ?? 0) > 0, undefined, { timeout: 30_000 });
  await page.screenshot({ path: join(artifacts, 'layout-city.png') });
  assert.deepEqual(errors, []);
});
