// The guiding curves of a sample system in the preview: loaded from and
// saved to the curves file, drawn, edited (deleted, renamed, undone, their
// points and parameters typed in), and their list with how much of each
// the model shown follows.

import type { V3 } from './bezier.js';
import { PARAM_KEYS, PARAM_RANGES, type ParamKey, checkParam, cloneSet, setProblem } from './curves.js';
import { coverageLabel, refinementsLine } from './coverage.js';
import { $, formatValue } from './dom.js';
import type { App } from './main.js';

export class CurvesPanel {
  /** The curves are drawn (and can be clicked and dragged). */
  showCurves = true;
  /** The document whose curves the page holds (empty: load them again). */
  curvesLoadedFor = '';

  constructor(private readonly app: App) {}

  /** Wire its part of the page (listeners on its buttons and fields). */
  wire(): void {
    $<HTMLInputElement>('show-curves').addEventListener('change', (e) => {
      this.showCurves = (e.target as HTMLInputElement).checked;
      this.refreshCurves();
    });
    $('curve-delete').addEventListener('click', () => this.deleteSelected());
    $('curve-undo').addEventListener('click', () => this.undoRedo(false));
    $('curve-redo').addEventListener('click', () => this.undoRedo(true));
    $<HTMLInputElement>('curve-name').addEventListener('change', (e) => {
      const sel = this.app.state.selected;
      if (sel === null) return;
      const input = e.target as HTMLInputElement;
      if (this.app.state.renameCurve(sel, input.value.trim())) this.curvesChanged(false);
      else input.value = this.app.state.curves?.curves[sel]?.name ?? '';
    });
  }

  async ensureCurves(): Promise<void> {
    if (this.curvesLoadedFor === this.app.state.uri) return;
    const r = (await this.app.transport.request('loadCurves', { uri: this.app.state.uri })) as { path?: unknown; text?: unknown };
    this.app.state.loadCurves(typeof r.path === 'string' ? r.path : '', typeof r.text === 'string' ? r.text : null);
    this.curvesLoadedFor = this.app.state.uri;
    this.refreshCurves();
  }

  deleteSelected(): void {
    const sel = this.app.state.selected;
    if (sel === null) return;
    this.app.state.deleteCurve(sel);
    this.curvesChanged(true);
  }

  /**
   * The curves changed: redraw, regrow; `save` ends the edit (one undo step)
   * and writes the curves file. `how`: a `move` of a drag (merged with the
   * next moves while a model is on its way), the `release` of a drag (no
   * new state: what still waits is sent at once), or any other `edit`
   * (sent at once).
   */
  curvesChanged(save: boolean, how: 'edit' | 'move' | 'release' = 'edit'): void {
    const editedAt = performance.now();
    if (save) this.app.state.finishEdit();
    this.refreshCurves();
    this.app.refreshPanel();
    if (how === 'release') this.app.released(editedAt, true);
    else this.app.regrow(editedAt, how === 'edit');
    if (save) void this.saveCurves();
  }

  undoRedo(redo: boolean): void {
    if (this.app.state.mode !== 'sample' || this.app.input.gesture.kind !== 'none') return;
    if (redo ? this.app.state.redo() : this.app.state.undo()) this.curvesChanged(true);
  }

  private async saveCurves(): Promise<void> {
    const out = this.app.state.curvesText();
    if ('error' in out) {
      this.app.setStatus(out.error, true);
      return;
    }
    try {
      await this.app.transport.request('saveCurves', { uri: this.app.state.uri, text: out.text });
      this.app.debug.saves++;
    } catch (e) {
      this.app.showError(`saving the curves: ${(e as Error).message}`);
    }
  }

  refreshCurves(): void {
    this.app.scene.setCurves(this.showCurves ? this.app.state.beziers() : [], this.showCurves ? this.app.state.selected : null);
    this.app.debug.curves = this.app.state.curves?.curves.length ?? 0;
  }
  refreshCurveList(): void {
    $<HTMLButtonElement>('curve-undo').disabled = !this.app.state.canUndo;
    $<HTMLButtonElement>('curve-redo').disabled = !this.app.state.canRedo;
    const list = $('curve-list');
    list.replaceChildren();
    const set = this.app.state.curves;
    $('curves-section').hidden = this.app.state.mode !== 'sample' && !set;
    set?.curves.forEach((c, i) => {
      const el = document.createElement('div');
      el.className = 'curve' + (i === this.app.state.selected ? ' selected' : '');
      el.textContent = c.name ?? `curve ${i}`;
      // How much of it the model shown follows (the last result's, when it was grown with these curves).
      const cov = this.app.last?.sample?.coverage;
      const cv = cov && cov.length === set.curves.length ? cov[i] : undefined;
      if (cv) {
        const tag = document.createElement('span');
        tag.className = 'coverage' + (cv.unreached ? ' unreached' : '');
        tag.textContent = coverageLabel(cv);
        tag.title = cv.note;
        el.append(' ', tag);
      }
      el.addEventListener('click', () => {
        this.app.state.selected = i;
        this.refreshCurves();
        this.app.refreshPanel();
      });
      list.append(el);
    });
    // Beside the coverage: the refinement rounds the search ran for it.
    const refined = set?.curves.length ? refinementsLine(this.app.last?.sample) : null;
    if (refined) list.append(refined);
    const sel = this.app.state.selected;
    const curve = sel !== null ? set?.curves[sel] : undefined;
    const panel = $('curve-panel');
    panel.hidden = !curve;
    if (!curve || sel === null) return;
    const name = $<HTMLInputElement>('curve-name');
    if (document.activeElement !== name) name.value = curve.name ?? '';
    const fields = $('curve-fields');
    if (!fields.contains(document.activeElement)) {
      fields.replaceChildren();
      for (const key of PARAM_KEYS) fields.append(this.paramField(sel, key));
    }
    const pts = $('curve-points');
    if (!pts.contains(document.activeElement)) {
      pts.replaceChildren();
      curve.points.forEach((p, k) => {
        const row = document.createElement('div');
        row.className = 'pt';
        const label = document.createElement('span');
        label.textContent = `P${k}`;
        row.append(label);
        p.forEach((x, axis) => {
          const input = document.createElement('input');
          input.type = 'number';
          input.step = '0.1';
          input.value = formatValue(x);
          input.addEventListener('change', () => {
            const v = Number(input.value);
            if (!Number.isFinite(v)) return;
            const q = [...(this.app.state.curves?.curves[sel]?.points[k] ?? p)] as V3;
            q[axis] = v;
            this.app.state.moveControlPoint(sel, k, q);
            this.curvesChanged(true);
          });
          row.append(input);
        });
        pts.append(row);
      });
    }
  }

  private paramField(curve: number, key: ParamKey): HTMLElement {
    const row = document.createElement('label');
    row.className = 'row';
    const c = this.app.state.curves?.curves[curve];
    const title = key === 'distance' ? 'distance m0 m1 m2' : PARAM_RANGES[key].label;
    row.append(document.createTextNode(title));
    const input = document.createElement('input');
    input.type = 'text';
    input.dataset.key = key;
    const v = c?.params[key];
    input.value = Array.isArray(v) ? v.map(formatValue).join(' ') : formatValue(v as number);
    input.addEventListener('change', () => {
      const raw = input.value.trim();
      const value = key === 'distance' ? raw.split(/[\s,]+/).map(Number) : Number(raw);
      // The value alone, then the set with it (grm-guide's limits: a tiny segment length on a long curve).
      let problem = checkParam(key, value);
      const set = this.app.state.curves;
      if (!problem && set?.curves[curve]) {
        const next = cloneSet(set);
        (next.curves[curve].params as unknown as Record<string, unknown>)[key] = value;
        problem = setProblem(next);
      }
      row.classList.toggle('invalid', problem !== null);
      row.title = problem ?? '';
      if (problem) return;
      this.app.state.setCurveParam(curve, key, value as never);
      this.curvesChanged(true);
    });
    row.append(input);
    return row;
  }
}
