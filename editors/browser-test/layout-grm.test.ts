// The layout view of a grammar's `layout` item (issue 29, item 6) in
// headless Chromium against `grmc view examples/city.grm` (a copy): the
// toolbar offers the item's layout; the view lists the item's layers with
// the sidecar's; a base street dragged with the mouse lands in the sidecar
// beside the grammar (its `base` layer's moves, the item's generated
// sources not written); the 3D mode draws the city's buildings with the
// page's three.js (a WebGL canvas with drawn triangles), grown again after
// a second drag with most buildings kept; a generator's argument changed in
// the grammar on disk regrows the view. The picture goes to
// target/browser-test/layout-grm-city.png.
//
// Needs: `cargo build -p grmc` (or GRMC=path), Debian's chromium
// (CHROMIUM=path). PAGE_DIST=editors/preview/dist serves the page from that
// folder instead of the copy built into grmc.

import assert from 'node:assert/strict';
import { copyFileSync, readFileSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { test } from 'node:test';
import { type Page } from 'playwright-core';
import { artifacts, harness, pageErrors, root } from './harness.js';

const h = harness();
const { view, openPage } = h;

/** examples/city.grm and what it reads, in a fresh folder (the view rewrites its sidecar). */
function city(): string {
  const dir = h.temp();
  for (const f of ['city.grm', 'city.layout.json', 'city_park.geojson', 'city_building.grm']) copyFileSync(join(root, 'examples', f), join(dir, f));
  return join(dir, 'city.grm');
}

type P = [number, number];

/** The base layer's streets as drawn (screen points relative to the plan) and the fit. */
async function baseStreets(page: Page): Promise<{ streets: { id: string; layerId: string; points: P[] }[]; fit: { scale: number; ox: number; oy: number } }> {
  return page.evaluate(() => {
    const svg = document.getElementById('layout-plan') as unknown as SVGSVGElement;
    const streets = Array.from(svg.querySelectorAll('polyline[data-layer="0"]')).map((p) => ({
      id: p.getAttribute('data-street') ?? '',
      // Its identity in its layer (a piece of a street the merge cut: the whole street's).
      layerId: p.getAttribute('data-layer-id') ?? '',
      points: (p.getAttribute('points') ?? '')
        .trim()
        .split(/\s+/)
        .map((xy: string) => xy.split(',').map(Number) as [number, number]),
    }));
    return { streets, fit: JSON.parse(svg.dataset.fit ?? '{}') };
  });
}

/** Drag the middle of a two-point base street inside the world box by (8, -4) pixels; its id. */
async function drag(page: Page, x0: number, x1: number, y0: number, y1: number): Promise<{ id: string; scale: number }> {
  const { streets, fit } = await baseStreets(page);
  const world = (p: P): P => [(p[0] - fit.ox) / fit.scale, -(p[1] - fit.oy) / fit.scale];
  const s = streets.find((x) => x.points.length === 2 && x.points.every((p) => {
    const [wx, wy] = world(p);
    return wx > x0 && wx < x1 && wy > y0 && wy < y1;
  }));
  assert.ok(s, `a base street in ${x0}..${x1} x ${y0}..${y1}`);
  const box = await page.locator('#layout-plan').boundingBox();
  assert.ok(box);
  const mid: P = [(s.points[0][0] + s.points[1][0]) / 2, (s.points[0][1] + s.points[1][1]) / 2];
  await page.mouse.move(box.x + mid[0], box.y + mid[1]);
  await page.mouse.down();
  for (let k = 1; k <= 4; k++) await page.mouse.move(box.x + mid[0] + 2 * k, box.y + mid[1] - k);
  await page.mouse.up();
  return { id: s.layerId, scale: fit.scale };
}

/** The sidecar's `base` layer's moves, once there are `n`. */
async function moves(page: Page, file: string, n: number): Promise<{ select: unknown; translate: number[] }[]> {
  const deadline = Date.now() + 30_000;
  for (;;) {
    const side = JSON.parse(readFileSync(file, 'utf8'));
    const base = side.layers.find((l: { name: string }) => l.name === 'base');
    if ((base?.moves ?? []).length >= n) return base.moves;
    assert.ok(Date.now() < deadline, `no move ${n} in the sidecar: ${await page.textContent('#layout-status')}`);
    await new Promise((r) => setTimeout(r, 100));
  }
}

test("a grammar's layout item: offered, dragged into its sidecar, and its buildings drawn in 3D", async () => {
  const grm = city();
  const side = grm.replace(/\.grm$/, '.layout.json');
  const before = JSON.parse(readFileSync(side, 'utf8'));
  const page = await openPage(await view(grm));
  const errors = pageErrors(page);
  // The toolbar offers the item's layout; the preview is shown until it is opened.
  await page.waitForSelector('#layout-open:not([hidden])', { timeout: 30_000 });
  assert.equal(await page.textContent('#layout-open'), 'Layout City');
  assert.equal(await page.locator('#layout-view').isVisible(), false);
  await page.click('#layout-open');
  await page.waitForSelector('#layout-view:not([hidden])');
  await page.waitForFunction(() => Number(document.getElementById('layout-plan')?.dataset.draws ?? 0) > 0, undefined, { timeout: 60_000 });
  await page.waitForSelector('#layout-layers .layout-layer');
  const names = await page.$$eval('#layout-layers .layout-layer span:nth-of-type(1)', (xs) => xs.map((x) => x.textContent));
  assert.deepEqual(names, ['old town', 'park', 'avenue', 'base'], "the sidecar's own layer on top of the item's");

  // A base street in the east dragged: the move lands in city.layout.json.
  const d = await drag(page, 480, 680, 100, 300);
  const m = await moves(page, side, 1);
  assert.deepEqual(m[0].select, { ids: [d.id] });
  assert.ok(Math.abs(m[0].translate[0] - 8 / d.scale) < 0.01 && Math.abs(m[0].translate[1] - 4 / d.scale) < 0.01, JSON.stringify(m[0]));
  const after = JSON.parse(readFileSync(side, 'utf8'));
  for (const l of before.layers) {
    const now = after.layers.find((x: { name: string }) => x.name === l.name);
    assert.deepEqual(now.source, l.source, `${l.name}: the sidecar's own source is kept`);
  }
  assert.equal(after.layers.length, before.layers.length, 'no layer added');

  // 3D: the page's three.js draws the city's buildings.
  await page.locator('#layout-3d').check();
  await page.waitForFunction(() => Number(document.getElementById('layout-city')?.dataset.buildings ?? 0) > 100, undefined, { timeout: 120_000 });
  await page.waitForFunction(() => Number(document.getElementById('layout-city')?.dataset.drawnTriangles ?? 0) > 0, undefined, { timeout: 30_000 });
  const first = await page.evaluate(() => ({ ...document.getElementById('layout-city')?.dataset }));
  assert.ok(Number(first.modelTriangles) > 10_000, JSON.stringify(first));
  assert.equal(await page.locator('#layout-plan').isVisible(), false, 'plan or 3D');
  await page.screenshot({ path: join(artifacts, 'layout-grm-city.png') });

  // Back to the plan, a second drag; in 3D again most buildings come from the cache.
  await page.locator('#layout-3d').uncheck();
  await page.waitForFunction(() => document.getElementById('layout-plan')?.style.display === '');
  await drag(page, 480, 680, 0, 200);
  await moves(page, side, 2);
  await page.locator('#layout-3d').check();
  await page.waitForFunction(
    (frames) => {
      const c = document.getElementById('layout-city');
      return Number(c?.dataset.frames ?? 0) > frames && Number(c?.dataset.reused ?? 0) > 0;
    },
    Number(first.frames),
    { timeout: 60_000 },
  );
  const again = await page.evaluate(() => ({ ...document.getElementById('layout-city')?.dataset }));
  assert.ok(Number(again.reused) > Number(again.buildings) / 2, `most kept: ${JSON.stringify(again)}`);

  // A generator's argument changed in the grammar on disk: grmc view's watcher tells the server, the view regrows.
  const baseInfo = () => page.textContent('#layout-layers .layout-layer[data-layer="0"]');
  const was = await baseInfo();
  writeFileSync(grm, readFileSync(grm, 'utf8').replace('grid(7, 5, 80, 60, 11)', 'grid(8, 5, 80, 60, 11)'));
  await page.waitForFunction((old) => document.querySelector('#layout-layers .layout-layer[data-layer="0"]')?.textContent !== old, was, { timeout: 60_000 });
  assert.notEqual(await baseInfo(), was, 'a wider grid: more base streets');

  // Back to the preview of the grammar.
  await page.click('#layout-close');
  assert.equal(await page.locator('#layout-view').isVisible(), false);
  assert.deepEqual(errors, []);
});
