// The preview page's layout view (issue 29, item 6; docs/layout.md, "In the
// editor"): a top-down plan of a city layout, a `NAME.layout.json` sidecar
// or a `.grm` file's `layout` item (offered by a toolbar button when the
// grammar has one; its edits go to the sidecar beside it), drawn as SVG
// from the language server's `grm/layout` (the merged streets, parcels and
// layers), or in 3D (layout-3d.ts: the buildings on the parcels, three.js). The layers are listed and toggled; a street is dragged
// (simple selection), or a street continuation, a soft selection around the
// pointer, or a drawn region; the selected street is protected, cut to a new
// layer, or given an anchored assignment. Every operator goes through the
// server (`grm/layoutEdit`): VS Code applies it as a workspace edit (its
// undo reverts it), `grmc view`'s server writes the sidecar; the view then
// asks for the merged layout again and redraws it. A move the server rejects
// (it would make streets cross) is shown with its code and nothing changes.
//
// The pure parts (the view's fit, hit tests, regions, tags, the operators'
// JSON, the answer's decoding) are exported for the unit tests
// (editors/test/layout-view.test.ts).

import { City3D, cityCaption, decodeLayoutCity } from './layout-3d.js';

export type Pt = [number, number];

export interface LayoutStreet {
  id: string;
  layer: number | null;
  layerId: string | null;
  points: Pt[];
  cls: string;
  width: number;
  protected: boolean;
}

export interface LayoutParcel {
  id: string;
  layer: number | null;
  ring: Pt[];
  protected: boolean;
  tags: Record<string, unknown>;
}

export interface LayoutLayer {
  index: number;
  name: string;
  visible: boolean;
  merge: string;
  source: string;
  moves: number;
  streets: number;
  parcels: number;
}

export interface LayoutProblem {
  code: string;
  message: string;
}

export interface LayoutAnswer {
  version: number | null;
  /** A grammar's layout item (its name); null for a sidecar. */
  item: string | null;
  /** The sidecar the edits are written to (a grammar's may not exist yet). */
  sidecar: string | null;
  layers: LayoutLayer[];
  streets: LayoutStreet[];
  parcels: LayoutParcel[];
  problems: LayoutProblem[];
  invalid: string[];
  bounds: [number, number, number, number];
}

export interface LayoutEditAnswer {
  applied: boolean;
  written: boolean;
  rejected: LayoutProblem | null;
  failureReason: string | null;
  newLayer: number | null;
}

/** Whether a document is a layout sidecar (shown by this view, not grown). */
export function isLayoutUri(uri: string): boolean {
  return /[^/]\.layout\.json$/i.test(uri);
}

/** Whether a document is a grammar (which may have a `layout` item: the view is offered for it). */
export function isGrmUri(uri: string): boolean {
  return /[^/]\.grm$/i.test(uri);
}

function obj(v: unknown, what: string): Record<string, unknown> {
  if (typeof v !== 'object' || v === null || Array.isArray(v)) throw new Error(`${what}: not an object`);
  return v as Record<string, unknown>;
}

function num(v: unknown, what: string): number {
  if (typeof v !== 'number' || !Number.isFinite(v)) throw new Error(`${what}: not a number`);
  return v;
}

function str(v: unknown, what: string): string {
  if (typeof v !== 'string') throw new Error(`${what}: not a string`);
  return v;
}

function pts(v: unknown, what: string): Pt[] {
  if (!Array.isArray(v)) throw new Error(`${what}: not an array`);
  return v.map((p, i) => {
    if (!Array.isArray(p) || p.length !== 2) throw new Error(`${what}[${i}]: not a point`);
    return [num(p[0], what), num(p[1], what)];
  });
}

function layerIndex(v: unknown, what: string): number | null {
  return v === null || v === undefined ? null : num(v, what);
}

function problems(v: unknown, what: string): LayoutProblem[] {
  if (!Array.isArray(v)) return [];
  return v.map((p, i) => {
    const o = obj(p, `${what}[${i}]`);
    return { code: str(o.code, 'code'), message: str(o.message, 'message') };
  });
}

/** Read a `grm/layout` answer (throws on a malformed one). */
export function decodeLayout(raw: unknown): LayoutAnswer {
  const o = obj(raw, 'layout');
  const bb = Array.isArray(o.bounds) && o.bounds.length === 4 ? o.bounds.map((x) => num(x, 'bounds')) : [0, 0, 0, 0];
  const b: [number, number, number, number] = [bb[0], bb[1], bb[2], bb[3]];
  const list = (v: unknown, what: string) => {
    if (!Array.isArray(v)) throw new Error(`${what}: not an array`);
    return v;
  };
  return {
    version: typeof o.version === 'number' ? o.version : null,
    item: typeof o.item === 'string' ? o.item : null,
    sidecar: typeof o.sidecar === 'string' ? o.sidecar : null,
    layers: list(o.layers, 'layers').map((l, i) => {
      const x = obj(l, `layers[${i}]`);
      return {
        index: num(x.index, 'index'),
        name: str(x.name, 'name'),
        visible: x.visible === true,
        merge: str(x.merge, 'merge'),
        source: str(x.source, 'source'),
        moves: num(x.moves, 'moves'),
        streets: num(x.streets, 'streets'),
        parcels: num(x.parcels, 'parcels'),
      };
    }),
    streets: list(o.streets, 'streets').map((s, i) => {
      const x = obj(s, `streets[${i}]`);
      return {
        id: str(x.id, 'id'),
        layer: layerIndex(x.layer, 'layer'),
        layerId: typeof x.layerId === 'string' ? x.layerId : null,
        points: pts(x.points, 'points'),
        cls: str(x.class, 'class'),
        width: num(x.width, 'width'),
        protected: x.protected === true,
      };
    }),
    parcels: list(o.parcels, 'parcels').map((p, i) => {
      const x = obj(p, `parcels[${i}]`);
      return {
        id: str(x.id, 'id'),
        layer: layerIndex(x.layer, 'layer'),
        ring: pts(x.ring, 'ring'),
        protected: x.protected === true,
        tags: typeof x.tags === 'object' && x.tags !== null ? (x.tags as Record<string, unknown>) : {},
      };
    }),
    problems: problems(o.problems, 'problems'),
    invalid: Array.isArray(o.invalid) ? o.invalid.filter((x): x is string => typeof x === 'string') : [],
    bounds: b,
  };
}

/** Read a `grm/layoutEdit` answer. */
export function decodeLayoutEdit(raw: unknown): LayoutEditAnswer {
  const o = obj(raw, 'layoutEdit');
  const rej = o.rejected === undefined || o.rejected === null ? null : obj(o.rejected, 'rejected');
  return {
    applied: o.applied === true,
    written: o.written === true,
    rejected: rej ? { code: str(rej.code, 'code'), message: str(rej.message, 'message') } : null,
    failureReason: typeof o.failureReason === 'string' ? o.failureReason : null,
    newLayer: typeof o.newLayer === 'number' ? o.newLayer : null,
  };
}

/** World (metres, y up) to screen (pixels, y down): `s = (x * scale + ox, -y * scale + oy)`. */
export interface ViewFit {
  scale: number;
  ox: number;
  oy: number;
}

/** The fit showing `bounds` in a `w` x `h` pixel area with `margin` pixels around. */
export function fitView(bounds: [number, number, number, number], w: number, h: number, margin = 20): ViewFit {
  const [x0, y0, x1, y1] = bounds;
  const bw = Math.max(x1 - x0, 1e-6);
  const bh = Math.max(y1 - y0, 1e-6);
  const scale = Math.max(Math.min((w - 2 * margin) / bw, (h - 2 * margin) / bh), 1e-6);
  const cx = (x0 + x1) / 2;
  const cy = (y0 + y1) / 2;
  return { scale, ox: w / 2 - cx * scale, oy: h / 2 + cy * scale };
}

export function toScreen(v: ViewFit, p: Pt): Pt {
  return [p[0] * v.scale + v.ox, -p[1] * v.scale + v.oy];
}

export function toWorld(v: ViewFit, s: Pt): Pt {
  return [(s[0] - v.ox) / v.scale, -(s[1] - v.oy) / v.scale];
}

/** Distance from `p` to a polyline. */
export function distToPolyline(p: Pt, line: Pt[]): number {
  let best = Infinity;
  for (let i = 0; i + 1 < line.length; i++) {
    const [ax, ay] = line[i];
    const [bx, by] = line[i + 1];
    const dx = bx - ax;
    const dy = by - ay;
    const len2 = dx * dx + dy * dy;
    const t = len2 > 0 ? Math.max(0, Math.min(1, ((p[0] - ax) * dx + (p[1] - ay) * dy) / len2)) : 0;
    best = Math.min(best, Math.hypot(p[0] - (ax + t * dx), p[1] - (ay + t * dy)));
  }
  return best;
}

/** The street nearest `p` within `tol` (world units), preferring one a layer owns. */
export function hitStreet(streets: LayoutStreet[], p: Pt, tol: number): LayoutStreet | null {
  let best: LayoutStreet | null = null;
  let bestD = Infinity;
  for (const s of streets) {
    const d = distToPolyline(p, s.points) - s.width / 2;
    if (d <= tol && (d < bestD || (best && best.layer === null && s.layer !== null && d <= bestD + tol))) {
      best = s;
      bestD = d;
    }
  }
  return best;
}

/** The rectangle spanned by two corners, counter-clockwise. */
export function rectRing(a: Pt, b: Pt): Pt[] {
  const x0 = Math.min(a[0], b[0]);
  const x1 = Math.max(a[0], b[0]);
  const y0 = Math.min(a[1], b[1]);
  const y1 = Math.max(a[1], b[1]);
  return [
    [x0, y0],
    [x1, y0],
    [x1, y1],
    [x0, y1],
  ];
}

export function pointInRing(p: Pt, ring: Pt[]): boolean {
  let inside = false;
  for (let i = 0, j = ring.length - 1; i < ring.length; j = i++) {
    const [xi, yi] = ring[i];
    const [xj, yj] = ring[j];
    if (yi > p[1] !== yj > p[1] && p[0] < ((xj - xi) * (p[1] - yi)) / (yj - yi) + xi) inside = !inside;
  }
  return inside;
}

/** `height=30, style=brick, open=false` as tags (numbers and booleans read as such). */
export function parseTags(text: string): Record<string, number | boolean | string> {
  const out: Record<string, number | boolean | string> = {};
  for (const part of text.split(',')) {
    if (part.trim() === '') continue;
    const m = /^\s*([A-Za-z_][\w.-]*)\s*=\s*(.+?)\s*$/.exec(part);
    if (!m) throw new Error(`\`${part.trim()}\` is not name=value`);
    const v = m[2];
    out[m[1]] = v === 'true' ? true : v === 'false' ? false : v !== '' && Number.isFinite(Number(v)) ? Number(v) : v;
  }
  if (Object.keys(out).length === 0) throw new Error('no tags');
  return out;
}

/** What a drag moves. */
export type LayoutSelection =
  | { kind: 'street'; street: LayoutStreet }
  | { kind: 'continuation'; street: LayoutStreet; maxTurn: number }
  | { kind: 'soft'; centre: Pt; radius: number }
  | { kind: 'region'; ring: Pt[] };

/** The sidecar's selection for it (as a move's `select`). */
export function selectJson(s: LayoutSelection): unknown {
  switch (s.kind) {
    case 'street':
      return { ids: [s.street.layerId ?? s.street.id] };
    case 'continuation':
      return { continuation: { street: s.street.layerId ?? s.street.id, max_turn: s.maxTurn } };
    case 'soft':
      return { soft: { centre: s.centre, radius: s.radius } };
    case 'region':
      return { region: s.ring };
  }
}

/** The `grm/layoutEdit` operator moving a selection by `d` (metres). */
export function moveOp(s: LayoutSelection, d: Pt): unknown {
  return { move: { select: selectJson(s), translate: [round(d[0]), round(d[1])] } };
}

/** Drags are written in millimetres: the sidecar stays readable. */
function round(x: number): number {
  return Math.round(x * 1000) / 1000;
}

/** The streets a drag of `s` carries in the view while it moves (the server decides the rest). */
export function draggedStreets(s: LayoutSelection, streets: LayoutStreet[]): LayoutStreet[] {
  switch (s.kind) {
    case 'street':
    case 'continuation':
      return [s.street];
    case 'soft':
      return streets.filter((x) => x.points.some((p) => Math.hypot(p[0] - s.centre[0], p[1] - s.centre[1]) < s.radius));
    case 'region':
      return streets.filter((x) => x.points.every((p) => pointInRing(p, s.ring)));
  }
}

// ---------------------------------------------------------------- the view

export interface LayoutHost {
  request(method: 'layout' | 'layoutEdit' | 'layoutCity', params: unknown): Promise<unknown>;
}

export { cityCaption, decodeLayoutCity } from './layout-3d.js';
export type { LayoutCity } from './layout-3d.js';

const SVG = 'http://www.w3.org/2000/svg';

const STREET_COLOURS: Record<string, string> = { highway: '#f0c060', major: '#d8d8d8', minor: '#a8a8a8' };

function el<K extends keyof HTMLElementTagNameMap>(tag: K, text?: string): HTMLElementTagNameMap[K] {
  const e = document.createElement(tag);
  if (text !== undefined) e.textContent = text;
  return e;
}

function svg(tag: string, attrs: Record<string, string | number>): SVGElement {
  const e = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, String(v));
  return e;
}

function pointsAttr(v: ViewFit, ps: Pt[], d: Pt = [0, 0]): string {
  return ps.map((p) => toScreen(v, [p[0] + d[0], p[1] + d[1]]).map((x) => x.toFixed(1)).join(',')).join(' ');
}

/** The layout view: an overlay over the page while a layout sidecar is shown. */
export class LayoutView {
  readonly root: HTMLDivElement;
  private readonly plan: SVGSVGElement;
  private readonly layersList: HTMLDivElement;
  private readonly status: HTMLParagraphElement;
  private readonly problemsList: HTMLUListElement;
  private readonly mode: HTMLSelectElement;
  private readonly radius: HTMLInputElement;
  private readonly tags: HTMLInputElement;
  private readonly threeD: HTMLInputElement;
  private readonly city = new City3D();
  /** The toolbar's button that opens the view for a grammar with a `layout` item. */
  readonly openButton: HTMLButtonElement;
  private readonly closeButton: HTMLButtonElement;
  /** The grammar the open button offers (its probe answered with an item). */
  private offered = '';
  private uri = '';
  private answer: LayoutAnswer | null = null;
  private fit: ViewFit | null = null;
  private selection: LayoutSelection | null = null;
  /** The layer soft and region moves work on. */
  private activeLayer = 0;
  private drag: { start: Pt; now: Pt; drawing: boolean } | null = null;
  private busy = false;
  /** Times the plan was drawn (the browser test waits on it). */
  private draws = 0;

  constructor(private readonly host: LayoutHost) {
    this.root = el('div');
    this.root.id = 'layout-view';
    this.root.hidden = true;
    this.root.style.cssText = 'position:fixed;inset:0;z-index:20;display:flex;background:#1e1f22;color:#ddd;font:12px system-ui,sans-serif';
    this.plan = document.createElementNS(SVG, 'svg') as SVGSVGElement;
    this.plan.id = 'layout-plan';
    this.plan.style.cssText = 'flex:1;min-width:0;height:100%;touch-action:none;cursor:crosshair';
    this.city.canvas.style.display = 'none';
    this.openButton = el('button', 'Layout');
    this.openButton.id = 'layout-open';
    this.openButton.hidden = true;
    this.openButton.title = "The grammar's city layout: its layers, streets and parcels to drag, and the buildings in 3D";
    this.openButton.addEventListener('click', () => {
      if (this.offered) void this.show(this.offered);
    });
    this.closeButton = el('button', 'Back to the preview');
    this.closeButton.id = 'layout-close';
    this.closeButton.hidden = true;
    this.closeButton.addEventListener('click', () => this.hide());
    const side = el('div');
    side.id = 'layout-side';
    side.style.cssText = 'width:260px;overflow-y:auto;padding:8px;border-left:1px solid #3a3b40;background:#242528';
    side.append(this.closeButton, el('h3', 'Layers'));
    this.layersList = el('div');
    this.layersList.id = 'layout-layers';
    this.threeD = el('input');
    this.threeD.type = 'checkbox';
    this.threeD.id = 'layout-3d';
    const threeDRow = el('label', ' 3D: the buildings on the parcels');
    threeDRow.prepend(this.threeD);
    this.threeD.addEventListener('change', () => void this.showMode());
    side.append(this.layersList, threeDRow, el('h3', 'Select and drag'));
    this.mode = el('select');
    this.mode.id = 'layout-mode';
    for (const [v, label] of [
      ['street', 'Street'],
      ['continuation', 'Street continuation'],
      ['soft', 'Soft (radius)'],
      ['region', 'Region (draw a box)'],
    ]) {
      const o = el('option', label);
      o.value = v;
      this.mode.append(o);
    }
    this.mode.addEventListener('change', () => {
      this.selection = null;
      this.draw();
    });
    this.radius = el('input');
    this.radius.type = 'number';
    this.radius.id = 'layout-radius';
    this.radius.value = '80';
    this.radius.min = '1';
    const radiusRow = el('label', 'radius (m) ');
    radiusRow.append(this.radius);
    const protect = el('button', 'Protect');
    protect.id = 'layout-protect';
    protect.title = 'Protect the selected street: it survives regenerating its layer';
    protect.addEventListener('click', () => void this.onSelected('protect'));
    const cut = el('button', 'Cut to layer');
    cut.id = 'layout-cut';
    cut.title = 'Move the selected street to a new layer above its own';
    cut.addEventListener('click', () => void this.onSelected('cut'));
    this.tags = el('input');
    this.tags.id = 'layout-tags';
    this.tags.placeholder = 'height=30, style=brick';
    const assign = el('button', 'Assign');
    assign.id = 'layout-assign';
    assign.title = 'Give the parcels within the radius of the selected street these tags, anchored to it';
    assign.addEventListener('click', () => void this.onSelected('assign'));
    const row = (...xs: HTMLElement[]) => {
      const d = el('div');
      d.style.cssText = 'display:flex;gap:4px;align-items:center;margin:4px 0;flex-wrap:wrap';
      d.append(...xs);
      return d;
    };
    side.append(row(this.mode), row(radiusRow), row(protect, cut), row(this.tags, assign));
    this.status = el('p');
    this.status.id = 'layout-status';
    this.status.style.cssText = 'white-space:pre-wrap;color:#9aa';
    this.problemsList = el('ul');
    this.problemsList.id = 'layout-problems';
    this.problemsList.style.cssText = 'padding-left:16px;color:#e9a';
    side.append(this.status, el('h3', 'Problems'), this.problemsList);
    this.root.append(this.plan, this.city.canvas, side);
    this.plan.addEventListener('pointerdown', (e) => this.down(e));
    this.plan.addEventListener('pointermove', (e) => this.move(e));
    this.plan.addEventListener('pointerup', (e) => void this.up(e));
    new ResizeObserver(() => {
      this.fit = null;
      this.draw();
    }).observe(this.plan);
  }

  get shown(): boolean {
    return !this.root.hidden;
  }

  /** Show a layout sidecar or a grammar's layout item (VS Code: the active editor's; `grmc view`: its file). */
  show(uri: string): Promise<void> {
    if (uri !== this.uri) {
      this.uri = uri;
      this.answer = null;
      this.fit = null;
      this.selection = null;
      this.city.reframe();
    }
    this.root.hidden = false;
    // A grammar's view closes back to its preview; a sidecar has none.
    this.closeButton.hidden = !isGrmUri(uri);
    return this.reload();
  }

  hide(): void {
    this.root.hidden = true;
    this.uri = '';
  }

  /**
   * Another document is shown (not a sidecar): the view closes, and for a
   * grammar with a `layout` item the toolbar offers it (the server's probe
   * says, building nothing).
   */
  async offer(uri: string): Promise<void> {
    if (this.shown && this.uri !== uri) this.hide();
    this.offered = '';
    this.openButton.hidden = true;
    if (!isGrmUri(uri)) return;
    try {
      const a = decodeLayout(await this.host.request('layout', { uri, probe: true }));
      if (!a.item) return;
      this.offered = uri;
      this.openButton.textContent = `Layout ${a.item}`;
      this.openButton.hidden = false;
    } catch {
      // No layout item (or the grammar does not check): nothing to offer.
    }
  }

  /** The layout changed (the server's `layoutUpdated`: the sidecar, or the grammar of a shown item). */
  updated(params: unknown): void {
    const p = (params ?? {}) as { uri?: unknown };
    if (this.shown && p.uri === this.uri && !this.busy) void this.reload();
  }

  async reload(): Promise<void> {
    try {
      this.answer = decodeLayout(await this.host.request('layout', { uri: this.uri }));
    } catch (e) {
      this.setStatus(`layout: ${(e as Error).message}`);
      this.root.dataset.error = (e as Error).message;
      return;
    }
    delete this.root.dataset.error;
    this.activeLayer = Math.min(this.activeLayer, Math.max(0, this.answer.layers.length - 1));
    this.draw();
    this.listLayers();
    if (this.threeD.checked) await this.drawCity();
  }

  /** The plan (2D, where dragging happens) or the city's picture (3D). */
  private async showMode(): Promise<void> {
    const three = this.threeD.checked;
    this.plan.style.display = three ? 'none' : '';
    this.city.canvas.style.display = three ? 'block' : 'none';
    if (three) await this.drawCity();
    else {
      this.fit = null;
      this.draw();
    }
  }

  /** Ask the server to grow the city (only the parcels that changed) and draw its model in 3D. */
  private async drawCity(): Promise<void> {
    try {
      const c = decodeLayoutCity(await this.host.request('layoutCity', { uri: this.uri }));
      this.city.setModel(c.model);
      const d = this.city.canvas.dataset;
      d.buildings = String(c.buildings);
      d.reused = String(c.reused);
      d.edited = String(c.edited);
      this.setStatus(cityCaption(c));
      const answer = this.answer;
      if (answer) this.problemsList.replaceChildren(...[...answer.problems, ...c.problems.filter((p) => !answer.problems.some((q) => q.message === p.message))].map((p) => el('li', `${p.code}: ${p.message}`)));
    } catch (e) {
      this.setStatus(`3D: ${(e as Error).message}`);
    }
  }

  private setStatus(text: string): void {
    this.status.textContent = text;
  }

  private listLayers(): void {
    const a = this.answer;
    if (!a) return;
    this.layersList.replaceChildren();
    for (const l of [...a.layers].reverse()) {
      const line = el('div');
      line.className = 'layout-layer';
      line.dataset.layer = String(l.index);
      line.style.cssText = 'display:flex;gap:4px;align-items:center;margin:2px 0';
      const vis = el('input');
      vis.type = 'checkbox';
      vis.checked = l.visible;
      vis.title = 'Shown and merged';
      vis.className = 'layout-visible';
      vis.addEventListener('change', () => void this.edit(l.index, { visible: vis.checked }));
      const active = el('input');
      active.type = 'radio';
      active.name = 'layout-active';
      active.checked = l.index === this.activeLayer;
      active.title = 'The layer soft and region moves work on';
      active.addEventListener('change', () => (this.activeLayer = l.index));
      const name = el('span', `${l.name}`);
      const info = el('span', `${l.source}, ${l.merge}, ${l.streets} streets, ${l.moves} moves`);
      info.style.cssText = 'color:#888;font-size:11px';
      line.append(vis, active, name, info);
      this.layersList.append(line);
    }
    this.problemsList.replaceChildren(
      ...a.problems.map((p) => el('li', `${p.code}: ${p.message}`)),
      ...a.invalid.map((m) => el('li', m)),
    );
  }

  /** Draw the plan (the dragged streets moved by the drag so far). */
  draw(): void {
    const a = this.answer;
    if (!a || this.root.hidden) return;
    const r = this.plan.getBoundingClientRect();
    if (r.width === 0 || r.height === 0) return;
    if (!this.fit) this.fit = fitView(a.bounds, r.width, r.height);
    const v = this.fit;
    const g: SVGElement[] = [];
    for (const p of a.parcels) {
      const poly = svg('polygon', {
        points: pointsAttr(v, p.ring),
        fill: p.tags.building === false ? '#2f4a2f' : '#3b3f4a',
        stroke: p.protected ? '#7fd' : '#555b66',
        'stroke-width': p.protected ? 1.5 : 0.5,
        'data-parcel': p.id,
      });
      g.push(poly);
    }
    const sel = this.selection;
    const selectedId = sel && (sel.kind === 'street' || sel.kind === 'continuation') ? sel.street.id : null;
    for (const s of a.streets) {
      g.push(
        svg('polyline', {
          points: pointsAttr(v, s.points),
          fill: 'none',
          stroke: s.id === selectedId ? '#4af' : (STREET_COLOURS[s.cls] ?? '#aaa'),
          'stroke-width': Math.max(1.5, s.width * v.scale),
          'stroke-linecap': 'round',
          'stroke-dasharray': s.protected ? '6 3' : '',
          'data-street': s.id,
          'data-layer-id': s.layerId ?? '',
          'data-layer': s.layer === null ? '' : String(s.layer),
        }),
      );
    }
    if (sel?.kind === 'region') g.push(svg('polygon', { points: pointsAttr(v, sel.ring), fill: 'rgba(80,160,255,0.12)', stroke: '#4af', 'stroke-dasharray': '4 3' }));
    if (sel?.kind === 'soft') {
      const c = toScreen(v, sel.centre);
      g.push(svg('circle', { cx: c[0], cy: c[1], r: sel.radius * v.scale, fill: 'rgba(80,160,255,0.08)', stroke: '#4af' }));
    }
    const d = this.drag;
    if (d && sel && !d.drawing) {
      const dd: Pt = [d.now[0] - d.start[0], d.now[1] - d.start[1]];
      for (const s of draggedStreets(sel, a.streets)) {
        g.push(svg('polyline', { points: pointsAttr(v, s.points, dd), fill: 'none', stroke: '#4af', 'stroke-width': 2, opacity: 0.8, class: 'layout-ghost' }));
      }
    }
    if (d?.drawing) g.push(svg('polygon', { points: pointsAttr(v, rectRing(d.start, d.now)), fill: 'none', stroke: '#4af' }));
    this.plan.replaceChildren(...g);
    this.draws += 1;
    this.plan.dataset.draws = String(this.draws);
    this.plan.dataset.streets = String(a.streets.length);
    // The fit between metres and pixels (the browser test finds streets by it).
    this.plan.dataset.fit = JSON.stringify(v);
  }

  private at(e: PointerEvent): Pt {
    const r = this.plan.getBoundingClientRect();
    return toWorld(this.fit ?? { scale: 1, ox: 0, oy: 0 }, [e.clientX - r.left, e.clientY - r.top]);
  }

  private down(e: PointerEvent): void {
    const a = this.answer;
    if (!a || !this.fit || this.busy) return;
    const p = this.at(e);
    const mode = this.mode.value;
    const tol = 6 / this.fit.scale;
    if (mode === 'street' || mode === 'continuation') {
      const s = hitStreet(a.streets, p, tol);
      if (!s || s.layer === null) {
        this.selection = null;
        this.setStatus(s ? 'A street the merge made: drag the layer streets it comes from.' : '');
        this.draw();
        return;
      }
      this.selection = mode === 'street' ? { kind: 'street', street: s } : { kind: 'continuation', street: s, maxTurn: 30 };
      this.setStatus(`street ${s.layerId ?? s.id} of layer ${a.layers[s.layer]?.name ?? s.layer}`);
      this.drag = { start: p, now: p, drawing: false };
    } else if (mode === 'soft') {
      const radius = Number(this.radius.value);
      this.selection = { kind: 'soft', centre: p, radius: Number.isFinite(radius) && radius > 0 ? radius : 80 };
      this.drag = { start: p, now: p, drawing: false };
    } else {
      const sel = this.selection;
      const inside = sel?.kind === 'region' && pointInRing(p, sel.ring);
      this.drag = { start: p, now: p, drawing: !inside };
    }
    this.plan.setPointerCapture?.(e.pointerId);
    this.draw();
  }

  private move(e: PointerEvent): void {
    if (!this.drag) return;
    this.drag.now = this.at(e);
    this.draw();
  }

  private async up(e: PointerEvent): Promise<void> {
    const d = this.drag;
    if (!d || !this.fit) return;
    this.drag = null;
    d.now = this.at(e);
    const moved: Pt = [d.now[0] - d.start[0], d.now[1] - d.start[1]];
    const px = Math.hypot(moved[0], moved[1]) * this.fit.scale;
    if (d.drawing) {
      this.selection = px < 3 ? null : { kind: 'region', ring: rectRing(d.start, d.now) };
      this.draw();
      return;
    }
    const sel = this.selection;
    if (!sel || px < 3) {
      this.draw();
      return;
    }
    const layer = sel.kind === 'street' || sel.kind === 'continuation' ? (sel.street.layer ?? this.activeLayer) : this.activeLayer;
    await this.edit(layer, moveOp(sel, moved));
    // A moved region goes with what it moved.
    if (sel.kind === 'region') this.selection = { kind: 'region', ring: sel.ring.map((q) => [q[0] + moved[0], q[1] + moved[1]] as Pt) };
    if (sel.kind === 'soft') this.selection = null;
    this.draw();
  }

  private async onSelected(op: 'protect' | 'cut' | 'assign'): Promise<void> {
    const sel = this.selection;
    if (!sel || (sel.kind !== 'street' && sel.kind !== 'continuation') || sel.street.layer === null) {
      this.setStatus('Select a street first (Street mode, click it).');
      return;
    }
    const s = sel.street;
    const id = s.layerId ?? s.id;
    const layer = s.layer ?? 0;
    if (op === 'protect') {
      await this.edit(layer, { protect: { ids: [id], protected: !s.protected } });
    } else if (op === 'cut') {
      await this.edit(layer, { cut: { ids: [id] } });
      this.selection = null;
    } else {
      let tags;
      try {
        tags = parseTags(this.tags.value);
      } catch (e) {
        this.setStatus(`tags: ${(e as Error).message}`);
        return;
      }
      const mid = s.points[Math.floor(s.points.length / 2)];
      const radius = Number(this.radius.value);
      await this.edit(layer, { assign: { tags, kinds: ['parcel'], radius: Number.isFinite(radius) && radius > 0 ? radius : 80, falloff: 'linear', at: mid, anchor: id } });
    }
  }

  /** Send an operator; redraw from the server's merged layout. */
  private async edit(layer: number, op: unknown): Promise<void> {
    this.busy = true;
    try {
      const r = decodeLayoutEdit(await this.host.request('layoutEdit', { uri: this.uri, layer, op }));
      if (r.rejected) this.setStatus(`${r.rejected.code}: ${r.rejected.message}`);
      else if (!r.applied) this.setStatus(`not applied${r.failureReason ? `: ${r.failureReason}` : ''}`);
      else this.setStatus(r.newLayer !== null ? `cut to a new layer (${r.newLayer})` : 'applied');
    } catch (e) {
      this.setStatus((e as Error).message);
    } finally {
      this.busy = false;
    }
    await this.reload();
  }
}
