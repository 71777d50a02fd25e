// Direct manipulation in the preview (issue 28): what a pick makes
// draggable (a shape's split planes, a bone's tip and its grips), the
// handles drawn and dragged, a release sent as a drag (or recorded as a
// sketch's pose), the sketch made into a slider, and the sliders' values
// written back to the grammar.

import type { V3 } from './bezier.js';
import { $ } from './dom.js';
import type { DebugInfo } from './debug-info.js';
import { BONE_GRIPS, type Gesture } from './gesture.js';
import type { App } from './main.js';
import {
  type PlaneHandle,
  SketchKeys,
  describeTarget,
  dragPlaneAt,
  manipSummary,
  paramsToWrite,
  planeCentre,
  handlePart,
  planeHandles,
  provenanceSummary,
  rayPlane,
  short,
  sliderNameProblem,
  tipDragNormal,
  boneGrips,
  draggedLength,
  rotatedTip,
} from './manip.js';
import {
  type ManipBase,
  type ManipPart,
  type ManipTarget,
  type PickParams,
  type PickResult,
  type PreviewResult,
  KEY,
  decodeManipResult,
  decodePick,
  decodeProvenance,
  findPick,
} from './protocol.js';
import { cutRect } from './scopes.js';

/** A drag sent: when it was released and the version of the model then on screen (a newer model is its regrown one). */
export type DragWait = { releasedAt: number; version: number; answeredAt: number | null; repick: boolean };

export class ManipController {
  /**
   * Direct manipulation: what the last pick can drag (a shape's path's split planes, a bone's tip), the pick
   * request that found it (asked again once a drag's model is shown) and the picked part's key.
   */
  private manip:
    | { kind: 'planes'; handles: PlaneHandle[]; key: string | null; pick: PickParams }
    | { kind: 'tip'; key: string; bone: number; base: V3; tip: V3; parentDir: V3 | null; pick: PickParams }
    | null = null;
  /** Sketch mode: a released drag records a pose (at the t of the number field) instead of rewriting the grammar. */
  private sketchMode = false;
  private readonly sketch = new SketchKeys();
  /** The last sketched pose, or a drag's drop while its answer is on the way, drawn where it was dropped: the plane (index into the handles) or the tip. */
  private posed: { plane: number; at: number } | { tip: V3 } | null = null;
  /** After a drag: the pick to make again once the regrown model is on screen, and the key it must find. */
  private pickAfterShown: { pick: PickParams; key: string } | null = null;
  /** What the page said of each part's provenance (by the part's JSON), for the model it was asked on (`pickedFor`). */
  private provenance = new Map<string, string>();
  private provenanceFor = '';
  /** A drag sent: when it was released and the version of the model then on screen (a newer model is its regrown one). */
  private dragWait: DragWait | null = null;

  constructor(private readonly app: App) {}

  /** Wire its part of the page (listeners on its buttons and fields). */
  wire(): void {
    // The sketch mode and its slider, and writing the sliders back (asked first).
    $<HTMLInputElement>('sketch-mode').addEventListener('change', (e) => this.setSketchMode((e.target as HTMLInputElement).checked));
    $('sketch-make').addEventListener('click', () => this.askSliderName());
    $('sketch-clear').addEventListener('click', () => {
      this.sketch.clear();
      this.posed = null;
      this.drawHandles();
      this.refreshSketch();
    });
    $('sketch-ok').addEventListener('click', () => void this.makeSlider());
    $('sketch-cancel').addEventListener('click', () => {
      $('sketch-form').hidden = true;
    });
    $<HTMLInputElement>('sketch-name').addEventListener('keydown', (e) => {
      if (e.key === 'Enter') void this.makeSlider();
      else if (e.key === 'Escape') $('sketch-form').hidden = true;
    });
    $('write-params').addEventListener('click', () => this.askWriteParams());
    $('write-ok').addEventListener('click', () => void this.writeParams());
    $('write-cancel').addEventListener('click', () => {
      $('write-confirm').hidden = true;
    });
    this.refreshSketch();
  }

  /** What a pick makes draggable: a shape's path's split planes (shape mode), a bone's tip (derive mode). */
  setManip(r: PickResult | null, pick: PickParams, quiet = false): void {
    this.manip = null;
    this.posed = null;
    const model = this.app.last?.model;
    if (r?.shape) {
      const handles = planeHandles(r.shape.scopes);
      this.manip = { kind: 'planes', handles, key: r.key, pick };
      const what = handles.length
        ? `${handles.length} split plane${handles.length === 1 ? '' : 's'} to drag: release one to rewrite the grammar's numbers`
        : r.shape.scopes.some((s) => s.command && s.axis !== null)
          ? 'the server names no split planes to drag (no key and planes in its scopes)'
          : 'no split or repeat above this shape: nothing to drag';
      if (!quiet) this.setManipStatus(what);
    } else if (r && model && this.app.state.mode === 'derive' && r.key && KEY.test(r.key)) {
      let bone = pick.bone ?? null;
      if (bone === null && pick.part !== undefined && pick.triangle !== undefined) {
        const range = model.parts[pick.part] ? findPick(model.parts[pick.part], pick.triangle) : null;
        bone = range?.kind === 'bone' ? range.index : null;
      }
      const b = bone !== null ? model.bones[bone] : undefined;
      if (bone !== null && b) {
        const parent = b.parent != null ? model.bones[b.parent] : undefined;
        const parentDir: V3 | null = parent ? [parent.tip[0] - parent.base[0], parent.tip[1] - parent.base[1], parent.tip[2] - parent.base[2]] : null;
        this.manip = { kind: 'tip', key: r.key, bone, base: [...b.base] as V3, tip: [...b.tip] as V3, parentDir, pick };
        if (!quiet) this.setManipStatus(`bone ${r.symbol}: drag its tip (the dot) to rewrite the numbers that place it`);
      }
    }
    this.drawHandles();
  }

  /** After a drag's model is shown: the same part picked again (same request), its handles kept if it is still the same part. */
  private async pickAgain(pick: PickParams, key: string): Promise<void> {
    try {
      const r = decodePick(await this.app.transport.request('pick', pick));
      if (!r || r.key !== key || this.manip) return;
      this.app.debug.lastPick = r;
      if (r.shape) this.app.picking.pickedScopes = r.shape.scopes;
      // The drag's answer stays in the status line.
      this.setManip(r, pick, true);
      this.app.picking.drawScopes();
    } catch {
      // The handles stay away until the next pick.
    }
  }

  /** The part a drag moves, and where its handle is now (the drag's target), for the gesture in progress or the last pose. */
  private manipTarget(g: Gesture): { part: ManipPart; target: ManipTarget } | null {
    const m = this.manip;
    if (!m) return null;
    if (g.kind === 'plane' && m.kind === 'planes') {
      const h = m.handles[g.handle];
      return h ? handlePart(h, g.at) : null;
    }
    if (g.kind === 'tip' && m.kind === 'tip') {
      const part: ManipPart = { kind: 'bone', key: m.key };
      // The length grip asks for a length alone (the direction is free); the tip and angle grips for a tip.
      if (g.grip === 'length' && g.length !== null) return { part, target: { kind: 'length', length: g.length } };
      return { part, target: { kind: 'tip', at: g.at } };
    }
    return null;
  }

  /** Draw the handles: the planes (the one dragged where the pointer has it, a sketched pose where it was dropped), a bone's tip. */
  private drawHandles(): void {
    const m = this.manip;
    if (!m) {
      this.app.scene.setHandles(null);
      return;
    }
    const g = this.app.input.gesture;
    const grips: { at: V3; active: boolean }[] = [];
    const lines: number[] = [];
    const activeLines: number[] = [];
    if (m.kind === 'planes') {
      m.handles.forEach((h, i) => {
        const dragged = g.kind === 'plane' && g.handle === i;
        const posed = this.posed && 'plane' in this.posed && this.posed.plane === i ? this.posed.at : null;
        const at = dragged ? g.at : (posed ?? h.at);
        const active = dragged || posed !== null;
        cutRect(h.scope, h.axis, at, active ? activeLines : lines);
        // Where it was, while it is away.
        if (active && at !== h.at) cutRect(h.scope, h.axis, h.at, lines);
        grips.push({ at: planeCentre(h, at), active });
        // The other poses sketched for it (each t's).
        if (this.sketch.part === JSON.stringify(handlePart(h, h.at).part)) {
          for (const k of this.sketch.keyframes()) {
            const t = k.target.kind === 'plane' ? k.target.at : k.target.kind === 'size' ? k.target.size : null;
            if (t !== null && t !== at) cutRect(h.scope, h.axis, t, activeLines);
          }
        }
      });
    } else {
      const posed = this.posed && 'tip' in this.posed ? this.posed.tip : null;
      const at = g.kind === 'tip' ? g.at : (posed ?? m.tip);
      const active = g.kind === 'tip' || posed !== null;
      (active ? activeLines : lines).push(...m.base, ...at);
      if (active) lines.push(...m.base, ...m.tip);
      if (this.sketch.part === JSON.stringify({ kind: 'bone', key: m.key })) {
        for (const k of this.sketch.keyframes()) {
          if (k.target.kind === 'tip' && k.target.at !== at) activeLines.push(...m.base, ...k.target.at);
          if (k.target.kind === 'length') {
            const d: V3 = [m.tip[0] - m.base[0], m.tip[1] - m.base[1], m.tip[2] - m.base[2]];
            const s = k.target.length / (Math.hypot(...d) || 1);
            activeLines.push(...m.base, ...m.base.map((b, i) => b + d[i]! * s));
          }
        }
      }
      grips.push({ at, active: g.kind === 'tip' ? g.grip === 'tip' : active });
      // The length and angle grips beside the tip, joined to it.
      const side = this.boneSideGrips(m, at);
      if (side) {
        for (const name of ['length', 'angle'] as const) {
          grips.push({ at: side[name], active: g.kind === 'tip' && g.grip === name });
          lines.push(...at, ...side[name]);
        }
      }
    }
    this.app.scene.setHandles({ grips, lines, activeLines });
  }
  /** The handles with their screen positions (window.__grm.handles, for tests). */
  handleList(): ReturnType<DebugInfo['handles']> {
    const m = this.manip;
    if (!m) return [];
    if (m.kind === 'planes') {
      return m.handles.map((h) => ({ kind: 'plane' as const, label: h.label, command: h.command, edge: h.edge, at: h.at, screen: this.app.scene.toScreen(planeCentre(h)) }));
    }
    const tip = { kind: 'tip' as const, label: 'tip', command: null, edge: null, at: [...m.tip] as V3, screen: this.app.scene.toScreen(m.tip) };
    const side = this.boneSideGrips(m, m.tip);
    if (!side) return [tip];
    return [tip, ...(['length', 'angle'] as const).map((label) => ({ kind: 'tip' as const, label, command: null, edge: null, at: side[label], screen: this.app.scene.toScreen(side[label]) }))];
  }

  /** A picked bone's length and angle grips for its tip at `at` (in the plane a drag of it moves in). */
  private boneSideGrips(m: { base: V3; parentDir: V3 | null }, at: V3): { length: V3; angle: V3 } | null {
    const g = this.app.input.gesture;
    const normal = g.kind === 'tip' ? g.normal : tipDragNormal(m.base, at, m.parentDir, this.app.scene.viewDirection());
    return boneGrips(m.base, at, normal);
  }

  /** A press on a handle's grip starts its drag (true); the orbit controls stay still until the release. */
  grabHandle(e: PointerEvent): boolean {
    const m = this.manip;
    if (!m) return false;
    const i = this.app.scene.gripAt(e.clientX, e.clientY);
    if (i === null) return false;
    if (m.kind === 'planes') {
      const h = m.handles[i];
      if (!h) return false;
      // A sketched pose is dragged on from where it was dropped.
      const at0 = this.posed && 'plane' in this.posed && this.posed.plane === i ? this.posed.at : h.at;
      this.app.input.gesture = { kind: 'plane', handle: i, at0, ray0: this.app.scene.pointerRay(e.clientX, e.clientY), facing: this.app.scene.viewDirection(), at: at0, moved: false };
    } else {
      const tip0 = this.posed && 'tip' in this.posed ? this.posed.tip : m.tip;
      const normal = tipDragNormal(m.base, tip0, m.parentDir, this.app.scene.viewDirection());
      const grip = BONE_GRIPS[i] ?? 'tip';
      const grab = rayPlane(this.app.scene.pointerRay(e.clientX, e.clientY), normal, tip0);
      this.app.input.gesture = { kind: 'tip', grip, tip0, normal, grab, at: tip0, length: null, degrees: 0, moved: false };
    }
    this.app.scene.controls.enabled = false;
    e.stopPropagation();
    e.preventDefault();
    const what = this.manipTarget(this.app.input.gesture);
    if (what) void this.showProvenance(what.part);
    return true;
  }

  /** While a handle is dragged: which source numbers place its part (`grm/provenance`, asked once per part and model). */
  private async showProvenance(part: ManipPart): Promise<void> {
    if (this.provenanceFor !== this.app.picking.pickedFor) {
      this.provenance.clear();
      this.provenanceFor = this.app.picking.pickedFor;
    }
    const key = JSON.stringify(part);
    let text = this.provenance.get(key);
    if (text === undefined) {
      try {
        text = provenanceSummary(decodeProvenance(await this.app.transport.request('provenance', { ...this.manipBase(), part })));
      } catch {
        // Not a failure of the drag: the release asks the server anyway.
        return;
      }
      if (this.provenanceFor === this.app.picking.pickedFor) this.provenance.set(key, text);
    }
    this.app.debug.provenance = text;
    // Only while this part's drag goes on: the release's answer is what the line says then.
    const g = this.app.input.gesture;
    const now = this.manipTarget(g);
    if (now && JSON.stringify(now.part) === key) this.setManipStatus(text);
  }

  /** A move of a handle's drag: the plane along its axis, the tip in the view plane through it. */
  moveHandle(e: PointerEvent): void {
    const g = this.app.input.gesture;
    const m = this.manip;
    const ray = this.app.scene.pointerRay(e.clientX, e.clientY);
    if (g.kind === 'plane' && m?.kind === 'planes') {
      const h = m.handles[g.handle];
      const at = h ? dragPlaneAt(h, g.at0, g.ray0, ray, g.facing) : null;
      if (at === null || !h) return;
      g.at = at;
      g.moved = true;
      this.app.setStatus(`${h.label} plane ${h.edge}: ${short(h.at)} → ${short(at)}`);
    } else if (g.kind === 'tip' && m?.kind === 'tip') {
      const p = rayPlane(ray, g.normal, g.tip0);
      if (!p) return;
      if (g.grip === 'length') {
        const len = g.grab ? draggedLength(m.base, g.tip0, g.grab, p) : null;
        if (len === null) return;
        const d: V3 = [g.tip0[0] - m.base[0], g.tip0[1] - m.base[1], g.tip0[2] - m.base[2]];
        const l0 = Math.hypot(...d);
        g.length = len;
        g.at = [0, 1, 2].map((k) => m.base[k]! + (d[k]! * len) / l0) as V3;
        this.app.setStatus(`length ${short(l0)} → ${short(len)}`);
      } else if (g.grip === 'angle') {
        const r = g.grab ? rotatedTip(m.base, g.tip0, g.normal, g.grab, p) : null;
        if (!r) return;
        g.at = r.tip;
        g.degrees = r.degrees;
        this.app.setStatus(`turned ${short(r.degrees)}° → tip (${g.at.map(short).join(', ')})`);
      } else {
        g.at = g.grab ? [g.tip0[0] + p[0] - g.grab[0], g.tip0[1] + p[1] - g.grab[1], g.tip0[2] + p[2] - g.grab[2]] : p;
        this.app.setStatus(`tip → (${g.at.map(short).join(', ')})`);
      }
      g.moved = true;
    } else {
      return;
    }
    this.drawHandles();
  }

  /** The release of a handle's drag: a pose for the sketch (sketch mode), else a drag sent to the server. */
  releaseHandle(g: Gesture): void {
    const releasedAt = performance.now();
    const what = this.manipTarget(g);
    if (!what || !(g.kind === 'plane' || g.kind === 'tip') || !g.moved) {
      this.drawHandles();
      return;
    }
    if (this.sketchMode) {
      const t = Number($<HTMLInputElement>('sketch-t').value);
      if (!this.sketch.set(JSON.stringify(what.part), t, what.target)) {
        this.setManipStatus('the pose\'s t must be more than 0 and at most 1 (t = 0 is the model as it is)', true);
        this.drawHandles();
        return;
      }
      this.posed = g.kind === 'plane' ? { plane: g.handle, at: g.at } : { tip: g.at };
      this.drawHandles();
      this.refreshSketch();
      this.setManipStatus(`pose at t = ${short(t)}: ${describeTarget(what.target)}${this.sketch.ready ? '; press Make slider…' : '; a pose at t = 1 is still needed'}`);
      return;
    }
    // The handle stays where it was dropped until the model regrows there (or goes back if nothing is written).
    this.posed = g.kind === 'plane' ? { plane: g.handle, at: g.at } : { tip: g.at };
    this.drawHandles();
    void this.sendDrag(what.part, what.target, releasedAt);
  }

  /** What every manipulation request carries: the model on screen's document, system, seed and slider values. */
  private manipBase(): ManipBase {
    const p = this.app.state.previewParams();
    const base: ManipBase = { textDocument: { uri: this.app.state.uri } };
    const system = this.app.last?.system || this.app.state.system;
    if (system) base.system = system;
    const seed = this.app.last?.seed ?? p.seed;
    if (seed !== undefined) base.seed = seed;
    if (p.params) base.params = p.params;
    return base;
  }

  private async sendDrag(part: ManipPart, target: ManipTarget, releasedAt: number): Promise<void> {
    const version = this.app.last?.version;
    const params = { ...this.manipBase(), ...(version !== undefined ? { version } : {}), part, target };
    this.app.debug.drags++;
    this.app.debug.lastDragRequest = params;
    this.app.debug.lastDrag = null;
    // The model regrown from the edit may come before the answer (the file is written before the answer is sent).
    const wait = version !== undefined ? { releasedAt, version, answeredAt: null as number | null, repick: true } : null;
    this.dragWait = wait;
    this.setManipStatus(`solving for the ${describeTarget(target)}…`);
    try {
      const r = decodeManipResult(await this.app.transport.request('drag', params), 'drag');
      if (wait) wait.answeredAt = performance.now();
      this.app.debug.lastDrag = r;
      const s = manipSummary(r);
      this.setManipStatus(s.text, s.error);
      // Nothing written: no model to wait for; the handle goes back to where the part is.
      if (r.outcome === 'unreachable' || r.outcome === 'unchanged' || r.applied === false) {
        if (this.dragWait === wait) this.dragWait = null;
        if (!this.sketchMode) this.posed = null;
        this.drawHandles();
      }
    } catch (e) {
      if (this.dragWait === wait) this.dragWait = null;
      this.app.debug.lastDrag = null;
      if (!this.sketchMode) this.posed = null;
      this.drawHandles();
      this.setManipStatus('');
      this.app.showError(`drag: ${(e as Error).message}`);
    }
  }

  private setManipStatus(text: string, error = false): void {
    this.app.debug.manipStatus = text;
    const el = $('manip-status');
    el.textContent = text;
    el.classList.toggle('error', error);
    if (text) this.app.setStatus(text, error);
  }

  /** The sketch panel: its poses, and whether a slider can be made (a pose at t = 1). */
  private refreshSketch(): void {
    $('sketch-panel').hidden = !this.sketchMode;
    this.app.debug.sketchPoses = this.sketch.size;
    const keys = this.sketch.keyframes();
    $('sketch-poses').textContent = keys.length ? `poses: ${keys.map((k) => `t = ${short(k.t)} (${describeTarget(k.target)})`).join('; ')}` : 'Drag a handle to the pose the slider ends at (t = 1).';
    $<HTMLButtonElement>('sketch-make').disabled = !this.sketch.ready;
    if (!this.sketch.ready) $('sketch-form').hidden = true;
  }

  private setSketchMode(on: boolean): void {
    this.sketchMode = on;
    $<HTMLInputElement>('sketch-mode').checked = on;
    if (!on) {
      this.sketch.clear();
      this.posed = null;
      this.drawHandles();
    }
    this.refreshSketch();
  }

  /** "Make slider…" asks for the name in the page. */
  private askSliderName(): void {
    if (!this.sketch.ready) return;
    $('sketch-form').hidden = false;
    const name = $<HTMLInputElement>('sketch-name');
    name.focus();
    name.select();
  }

  /** Send the sketch: a new slider named as asked, through the poses (t = 1 and any in between). */
  private async makeSlider(): Promise<void> {
    const name = $<HTMLInputElement>('sketch-name').value.trim();
    const problem = sliderNameProblem(name);
    if (problem) {
      this.setManipStatus(problem, true);
      return;
    }
    const part = JSON.parse(this.sketch.part || 'null') as ManipPart | null;
    if (!part || !this.sketch.ready) return;
    const params = { ...this.manipBase(), part, name, keyframes: this.sketch.keyframes() };
    this.app.debug.lastSketchRequest = params;
    this.app.debug.lastSketch = null;
    $('sketch-form').hidden = true;
    this.setManipStatus(`fitting slider ${name}…`);
    try {
      const r = decodeManipResult(await this.app.transport.request('sketch', params), 'sketch');
      this.app.debug.lastSketch = r;
      const s = manipSummary(r, 'sketch');
      this.setManipStatus(s.text, s.error);
      if (r.outcome !== 'unreachable' && r.applied !== false) {
        this.sketch.clear();
        this.posed = null;
        this.drawHandles();
        this.refreshSketch();
      }
    } catch (e) {
      this.setManipStatus('');
      this.app.showError(`sketch: ${(e as Error).message}`);
    }
  }

  /** "Write slider values": what would be written, asked in the page first (never silently). */
  private askWriteParams(): void {
    const { params, prompt } = paramsToWrite(this.app.state.paramInfo, (n) => this.app.state.paramValue(n));
    if (Object.keys(params).length === 0) {
      this.setManipStatus('the sliders are at the grammar\'s defaults: nothing to write');
      $('write-confirm').hidden = true;
      return;
    }
    $('write-prompt').textContent = prompt;
    $('write-confirm').hidden = false;
  }

  private async writeParams(): Promise<void> {
    $('write-confirm').hidden = true;
    const { params } = paramsToWrite(this.app.state.paramInfo, (n) => this.app.state.paramValue(n));
    if (Object.keys(params).length === 0) return;
    const base = this.manipBase();
    this.app.debug.lastWrite = null;
    try {
      const r = decodeManipResult(await this.app.transport.request('writeParams', { textDocument: base.textDocument, ...(base.system ? { system: base.system } : {}), params }), 'writeParams');
      this.app.debug.lastWrite = r;
      const s = manipSummary(r, 'slider values written');
      this.setManipStatus(s.text, s.error);
    } catch (e) {
      this.app.showError(`writeParams: ${(e as Error).message}`);
    }
  }

  /** A model is shown: a drag's regrown model (a newer version than the one on screen at its release) ends the drag's wait. */
  takeDragDone(r: PreviewResult): DragWait | null {
    const dragDone = this.dragWait && r.uri === this.app.state.uri && r.version > this.dragWait.version ? this.dragWait : null;
    if (dragDone) this.dragWait = null;
    return dragDone;
  }

  /** Another model is shown: the handles were the old model's. After a drag the same part is picked again once it is on screen. */
  modelChanged(dragDone: DragWait | null): void {
    const again = dragDone?.repick ? this.manip?.pick : undefined;
    const key = this.manip?.kind === 'planes' ? this.manip.key : this.manip?.kind === 'tip' ? this.manip.key : null;
    this.drop();
    // Once the regrown model is on screen: its frame does not wait for the pick.
    if (again && key) this.pickAfterShown = { pick: again, key };
  }

  /** The model is on screen (at `now`; `editedAt`: when it came): the part picked again after a drag, the drag's times kept. */
  shown(now: number, editedAt: number, dragDone: DragWait | null): void {
    const again = this.pickAfterShown;
    this.pickAfterShown = null;
    if (again) void this.pickAgain(again.pick, again.key);
    if (dragDone) {
      const debug = this.app.debug;
      debug.dragLatencies.push(now - dragDone.releasedAt);
      debug.dragAnswerMs.push((dragDone.answeredAt ?? now) - dragDone.releasedAt);
      debug.dragBreakdowns.push({
        answer: (dragDone.answeredAt ?? now) - dragDone.releasedAt,
        model: editedAt - dragDone.releasedAt,
        ...debug.lastBreakdown,
      });
    }
  }

  /** The handles go (a new model, or the selection dropped). */
  drop(): void {
    this.manip = null;
    this.posed = null;
    this.drawHandles();
  }
}
