// Picking and focus in the preview: a click's pick (the rule, the shape's
// scopes, focus and context's choices), the focused production's
// highlight with its spread over other seeds, the rule list, and the
// derivation tree's chosen node highlighted.

import type { V3 } from './bezier.js';
import { $ } from './dom.js';
import type { App } from './main.js';
import { type PickParams, type PreviewResult, type ScopeBox, type SceneModel, decodePick, decodePreview } from './protocol.js';
import { scopeLines } from './scopes.js';

/** What makes one model another: its document version, system, seed and meta-parameter values (not a rule's highlight). */
export function modelSignature(r: PreviewResult): string {
  return JSON.stringify([r.uri, r.version, r.system, r.seed, r.params.map((p) => [p.name, p.value])]);
}

export class Picking {
  /** Shape mode: draw the picked shape's ancestors' scopes and split planes. */
  private showScopes = false;
  /** The scopes of the last shape picked. */
  pickedScopes: ScopeBox[] | null = null;
  /** The model the pick (scopes, handles) was made on (`modelSignature`): another model drops them. */
  pickedFor = '';
  private spreadToken = 0;
  /** Requests in flight for the focus spread (their models are not the one shown). */
  private spreads = 0;

  constructor(private readonly app: App) {}

  /** Requests in flight for the focus spread. */
  get spreading(): number {
    return this.spreads;
  }

  /** Wire its part of the page (listeners on its buttons and fields). */
  wire(): void {
    $<HTMLInputElement>('show-scopes').addEventListener('change', (e) => {
      this.showScopes = (e.target as HTMLInputElement).checked;
      this.drawScopes();
    });
    $<HTMLSelectElement>('rule-select').addEventListener('change', (e) => {
      const v = (e.target as HTMLSelectElement).value;
      const o = v === '' ? undefined : this.app.last?.origins[Number(v)];
      this.setFocus(o ? o.range.start : null);
    });
    // Focus and context (shape mode): the picked shape a few levels down, the rest as proxies.
    $<HTMLInputElement>('context-on').addEventListener('change', () => this.setContext());
    $<HTMLInputElement>('context-depth').addEventListener('change', () => this.setContext());
    $<HTMLSelectElement>('context-node').addEventListener('change', () => this.setContext());
  }

  async pick(x: number, y: number): Promise<void> {
    const model = this.app.last?.model;
    if (!model) return;
    const params: PickParams = { textDocument: { uri: this.app.state.uri } };
    const hit = this.app.scene.pickPart(x, y);
    if (hit) {
      params.part = hit.part;
      params.triangle = hit.triangle;
    } else {
      const bone = this.app.scene.pickBone(x, y);
      if (bone === null) return;
      params.bone = bone;
    }
    try {
      const r = decodePick(await this.app.transport.request('pick', params));
      this.app.debug.lastPick = r;
      this.app.debug.picks++;
      if (r?.key && $<HTMLDetailsElement>('tree-details').open) void this.app.treePanel.reveal(r.key).catch(() => {});
      this.pickedFor = this.app.last ? modelSignature(this.app.last) : '';
      this.app.manipulation.setManip(r, params);
      this.app.editPanel.picked(r);
      const info = $('rule-info');
      if (r && r.shape) {
        // Shape mode: the shape, where it was made, its locators; its path's scopes.
        info.textContent = `${r.symbol} ${r.shape.semantic.replace(/ \S+$/, '')}: made by ${r.shape.madeBy} (line ${r.range.start.line + 1})`;
        info.title = `${r.shape.exact}\nkey ${r.key ?? '?'}`;
        this.pickedScopes = r.shape.scopes;
        this.contextChoices(r.shape.scopes.flatMap((s) => (!s.command && s.key !== null ? [{ key: s.key, label: s.label }] : [])));
        // Focused already: the newly picked shape's parent becomes the focus (a proxy picked opens it).
        if ($<HTMLInputElement>('context-on').checked) this.setContext();
        this.drawScopes();
      } else if (r) {
        info.textContent = `${r.symbol} (line ${r.range.start.line + 1})`;
        // Focus and context in derive mode: the picked module or one it descends from.
        this.contextChoices(r.ancestry.map((a) => ({ key: a.key, label: a.symbol ?? 'axiom' })));
        if ($<HTMLInputElement>('context-on').checked) this.setContext();
        this.setFocus(r.range.start);
      } else {
        info.textContent = 'No known rule made that part.';
      }
    } catch (e) {
      this.app.showError(`pick: ${(e as Error).message}`);
    }
  }

  /** Shape mode: the picked shape's path's scopes, when the toggle is on. */
  drawScopes(): void {
    this.app.scene.setScopes(this.showScopes && this.pickedScopes ? scopeLines(this.pickedScopes) : null);
  }

  /** Highlight what the production at `pos` grows (null: none), with its spread over other seeds. */
  setFocus(pos: { line: number; character: number } | null): void {
    // The cursor moves on every keystroke: regrow only when it enters another production.
    const before = this.originAt(this.app.state.focus);
    const after = this.originAt(pos);
    this.app.state.focus = pos && after !== null ? { line: pos.line, character: pos.character } : null;
    if (after !== before) this.app.regrow();
  }

  /** The production (index into the last result's origins) whose source range holds `pos`. */
  private originAt(pos: { line: number; character: number } | null): number | null {
    if (!pos || !this.app.last) return null;
    const le = (a: { line: number; character: number }, b: { line: number; character: number }) =>
      a.line < b.line || (a.line === b.line && a.character <= b.character);
    const i = this.app.last.origins.findIndex((o) => o.symbol !== 'axiom' && le(o.range.start, pos) && le(pos, o.range.end));
    return i < 0 ? null : i;
  }

  /** Bones grown by the focused production: from the parts' focus flags, and bones it made itself. */
  private focusedBones(model: SceneModel, origin: number): number[] {
    const set = new Set<number>();
    for (const p of model.parts) for (const pk of p.picks) if (pk.focus && pk.kind === 'bone') set.add(pk.index);
    model.bones.forEach((b, i) => {
      if (b.origin === origin) set.add(i);
    });
    return [...set].sort((a, b) => a - b);
  }

  showFocus(r: PreviewResult): void {
    const token = ++this.spreadToken;
    const info = $('rule-info');
    if (!r.focus) {
      this.app.scene.setHighlight([], []);
      this.app.debug.focusBones = 0;
      this.app.debug.spreadBones = 0;
      const sel = $<HTMLSelectElement>('rule-select');
      if (!this.app.state.focus) sel.value = '';
      return;
    }
    const f = r.focus;
    const bones = this.focusedBones(r.model, f.origin);
    this.app.debug.focusBones = bones.length;
    this.app.scene.setHighlight(bones, []);
    const o = r.origins[f.origin];
    const counts = f.spreadBones.length ? `; over ${f.spreadBones.length} seeds ${Math.min(...f.spreadBones)} to ${Math.max(...f.spreadBones)} bones` : '';
    info.textContent = `${o ? `${o.symbol} (line ${o.range.start.line + 1})` : 'rule'}: ${f.bones} bones, ${f.instances} parts here${counts}`;
    $<HTMLSelectElement>('rule-select').value = String(f.origin);
    void this.loadSpread(token, r, bones);
  }

  /**
   * Where the focused production can grow: its bones in the models of the
   * next few seeds, drawn faintly over the current model. The last request
   * is the current state again, so the server's live preview keeps it.
   */
  private async loadSpread(token: number, r: PreviewResult, current: number[]): Promise<void> {
    // Meanwhile the server's tables are the other seeds' models: a tree node's parts are asked once it is over.
    this.spreads++;
    try {
      await this.loadSpreadSeeds(token, r, current);
    } finally {
      this.spreads--;
      // The server's tables are this model's again: the tree panel and the chosen node's parts read anew.
      if (this.spreads === 0) {
        if ($<HTMLDetailsElement>('tree-details').open) void this.app.treePanel.modelShown().catch(() => {});
        if (this.chosenKey) void this.highlightNode(this.chosenKey);
      }
    }
  }


  private async loadSpreadSeeds(token: number, r: PreviewResult, current: number[]): Promise<void> {
    const seeds = 4;
    const segs: [V3, V3][] = [];
    const base = this.app.state.previewParams();
    for (let k = 1; k <= seeds; k++) {
      // Started while the focused model is being delivered: stop only for a newer edit.
      if (token !== this.spreadToken || this.app.coalescer.pending) return;
      try {
        const o = decodePreview(await this.app.transport.request('preview', { ...base, seed: (r.seed + k) >>> 0, live: false }));
        if (!o.focus) continue;
        for (const i of this.focusedBones(o.model, o.focus.origin)) segs.push([o.model.bones[i].base, o.model.bones[i].tip]);
      } catch {
        return;
      }
    }
    if (token !== this.spreadToken) return;
    try {
      // Live again; if the grammar was edited meanwhile (the server sent no
      // update while it was not live), this is the model to show. Not while
      // the page's own (live) request is on its way: it registers the live
      // preview itself, and this one would supersede it.
      if (this.app.coalescer.busy) return;
      const again = decodePreview(await this.app.transport.request('preview', this.app.ordered(base)));
      // A change of the edits file (an edit made in the panel) regrows the same version with other edits: news too.
      const newEdits = JSON.stringify(again.edits) !== JSON.stringify(this.app.last?.edits ?? null);
      if ((again.version !== r.version || newEdits) && token === this.spreadToken && !this.app.coalescer.busy) {
        this.app.show({ result: again, editedAt: performance.now(), final: true });
        return;
      }
    } catch {
      // The next edit or request registers the live preview again.
    }
    if (token !== this.spreadToken) return;
    this.app.debug.spreadBones = segs.length;
    this.app.scene.setHighlight(current, segs);
  }
  /** The key of the node chosen in the derivation tree (its parts highlighted), null: none. */
  chosenKey: string | null = null;

  /**
   * Highlight the parts a tree node's subtree drew (`grm/tree`'s `drawn`): its triangles tinted, its bones as lines.
   * A key the model shown lacks (or no key) clears the highlight.
   */
  async highlightNode(key: string | null): Promise<void> {
    this.chosenKey = key;
    // The focus spread's requests replace the server's tree with other seeds' for a while: asked again at its end.
    if (key && this.spreads > 0) return;
    const version = this.app.last?.version;
    let drawn: { triangles: number[]; bones: number[] } = { triangles: [], bones: [] };
    if (key) {
      try {
        const a = (await this.app.transport.request('tree', { textDocument: { uri: this.app.state.uri }, key, drawn: true })) as {
          version?: number;
          drawn?: { triangles?: unknown; bones?: unknown };
        } | null;
        const nums = (v: unknown): number[] => (Array.isArray(v) ? v.filter((x): x is number => typeof x === 'number') : []);
        if (a?.drawn) drawn = { triangles: nums(a.drawn.triangles), bones: nums(a.drawn.bones) };
        // Chosen again, or another model shown meanwhile (its answer is that model's): the later call draws.
        if (key !== this.chosenKey || version !== this.app.last?.version || (a && a.version !== version)) return;
      } catch {
        // No tree for this preview (or it is being regrown): nothing highlighted.
      }
    }
    if (key !== this.chosenKey) return;
    const lit = this.app.scene.setChosen(drawn.triangles, drawn.bones);
    this.app.debug.chosen = key ? { key, ...lit } : null;
  }

  /** A node chosen in the tree panel: its parts highlighted, its rule said in the panel and shown in the editor (where the host has one). */
  chooseTreeNode(n: { label: string; key: string; uri?: string; range?: { start: { line: number; character: number } } }): void {
    void this.highlightNode(n.key);
    const info = $('rule-info');
    info.textContent = n.range ? `${n.label}: made by the rule at line ${n.range.start.line + 1}` : n.label;
    info.title = `key ${n.key}`;
    if (n.uri && n.range && this.app.transport.kind === 'vscode') {
      void this.app.transport.request('reveal', { uri: n.uri, line: n.range.start.line, character: n.range.start.character }).catch(() => {});
    }
  }

  /**
   * The nodes focus and context can center on, from the root down to the picked part: shape mode, the picked shape
   * and the shapes above it (its path's scopes, commands left out); derive mode, the picked module and the modules it
   * descends from (its ancestry). The picked part's parent is chosen (a picked part is drawn, so most often a leaf:
   * focusing on it alone hides nothing).
   */
  private contextChoices(nodes: { key: string; label: string }[]): void {
    const select = $<HTMLSelectElement>('context-node');
    select.replaceChildren(
      ...nodes.map((s, i) => {
        const o = document.createElement('option');
        o.value = s.key;
        o.textContent = `${'  '.repeat(i)}${s.label}`;
        return o;
      }),
    );
    select.selectedIndex = Math.max(0, nodes.length - 2);
    $('context-toggle').hidden = nodes.length === 0;
  }

  /**
   * Focus and context from the panel: on, the chosen shape (its key) drawn the chosen number of levels down and
   * the rest of the building as proxies; off, or nothing picked, the whole building. Regrows when it changed.
   */
  private setContext(): void {
    const on = $<HTMLInputElement>('context-on').checked;
    const depth = Math.max(0, Math.min(20, Math.round(Number($<HTMLInputElement>('context-depth').value) || 0)));
    const key = $<HTMLSelectElement>('context-node').value || null;
    const next = on && key ? { key, depth } : null;
    const before = JSON.stringify(this.app.state.context);
    this.app.state.context = next;
    if (JSON.stringify(next) !== before) this.app.regrow();
  }

  refreshRules(): void {
    const sel = $<HTMLSelectElement>('rule-select');
    const origins = this.app.last?.origins ?? [];
    // Where the editor's cursor cannot drive the highlight (a browser), a list picks the rule.
    sel.hidden = this.app.transport.kind === 'vscode' || origins.length === 0;
    const sig = origins.map((o) => `${o.range.start.line}:${o.symbol}`).join(',');
    if (sel.dataset.sig === sig) return;
    sel.dataset.sig = sig;
    sel.replaceChildren(new Option('highlight a rule…', ''));
    origins.forEach((o, i) => {
      if (o.symbol !== 'axiom') sel.append(new Option(`line ${o.range.start.line + 1}: ${o.symbol}`, String(i)));
    });
    if (this.app.state.focus && this.app.last?.focus) sel.value = String(this.app.last.focus.origin);
  }
}
