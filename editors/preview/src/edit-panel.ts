// The preview page's edit panel (issue 27, item 6): persistent edits of the
// picked part. The selection is the picked shape (or module), or one of the
// parts above it ("Up one level"), named by its exact locator, its key, or
// its semantic locator with some tags made wildcards ("Its row", "Its
// column", "All facades", or per tag: from the start, from the end, any).
// The operations are seed 002's (set/offset a parameter, force an
// alternative of its rule, pin, material, mesh, remove); the list shows the
// edits file's edits with their class as a colour, each deletable, and the
// retarget candidates the server computed for a broken one. Every change
// goes through the server (`grm/edit`, `grm/removeEdit`, `grm/retargetEdit`):
// VS Code applies it as a workspace edit (its undo reverts it), `grmc view`'s
// server writes the file; the live preview then regrows with it.
//
// The pure parts (locators, widening, alternatives, labels) are exported for
// the unit tests (editors/test/edit-panel.test.ts).

import {
  type EditAnswer,
  type EditEntry,
  type EditOp,
  type EditsInfo,
  type RetargetCandidate,
  type TargetKind,
  type TargetRef,
  decodeEditAnswer,
  isKey,
  targetParam,
} from './edits-protocol.js';
import type { Origin, PickResult } from './protocol.js';

// ---------------------------------------------------------------- pure logic

/** One tagged command on a shape's path: `floor = 3/5` (the 3rd of 5). */
export interface SemanticEntry {
  tag: string;
  index: number;
  count: number;
}

/** A shape's semantic locator as `grm/pick` writes it: `(house = 2/3, floor = 3/3) Window`. */
export interface SemanticLocator {
  entries: SemanticEntry[];
  label: string;
}

/** Read a semantic locator (null: not one). */
export function parseSemanticLocator(text: string): SemanticLocator | null {
  const m = /^\s*\(([^)]*)\)\s*(\S+)\s*$/.exec(text);
  if (!m) return null;
  const entries: SemanticEntry[] = [];
  if (m[1].trim() !== '') {
    for (const part of m[1].split(',')) {
      const e = /^\s*([^\s=,(){}]+)\s*=\s*(\d+)\s*\/\s*(\d+)\s*$/.exec(part);
      if (!e) return null;
      entries.push({ tag: e[1], index: Number(e[2]), count: Number(e[3]) });
    }
  }
  return { entries, label: m[2] };
}

/** How a tag of the selection is matched: its index from the start (`floor = 3`), from the end (`floor = end 1`), or any. */
export type TagMatch = 'start' | 'end' | 'any';

/** The semantic query (docs/edits.md, "Targets") selecting the parts that match `loc` in the tags not `any`. */
export function semanticQuery(loc: SemanticLocator, match: ReadonlyMap<string, TagMatch> = new Map()): string {
  const entries = loc.entries.flatMap((e, i) => {
    const how = match.get(entryKey(loc, i)) ?? 'start';
    if (how === 'any') return [];
    return [how === 'end' ? `${e.tag} = end ${e.count - e.index + 1}` : `${e.tag} = ${e.index}`];
  });
  return `(${entries.join(', ')}) ${loc.label}`;
}

/**
 * The key of entry `i` in a TagMatch map: its tag, with its place where the tag repeats on the path
 * (`floor#2`), so two commands of one tag are told apart.
 */
export function entryKey(loc: SemanticLocator, i: number): string {
  const tag = loc.entries[i].tag;
  const before = loc.entries.slice(0, i).filter((e) => e.tag === tag).length;
  return before === 0 ? tag : `${tag}#${before + 1}`;
}

/** The widenings the panel offers (Lipp's row, column, all facades): which tags each makes wildcards. */
export const WIDENINGS = {
  row: { label: 'Its row', tags: ['column'], title: 'every part of its floor: the column is any' },
  column: { label: 'Its column', tags: ['floor'], title: 'every part of its column: the floor is any' },
  facades: { label: 'All facades', tags: ['facade'], title: 'the same part on every facade: the facade is any' },
} as const;

export type Widening = keyof typeof WIDENINGS;

/** The selection widened: the widening's tags (each occurrence) set to `any`, the others as they were. Null: the locator has none of its tags. */
export function widen(loc: SemanticLocator, match: ReadonlyMap<string, TagMatch>, w: Widening): Map<string, TagMatch> | null {
  const tags: readonly string[] = WIDENINGS[w].tags;
  const out = new Map(match);
  let any = false;
  loc.entries.forEach((e, i) => {
    if (tags.includes(e.tag)) {
      out.set(entryKey(loc, i), 'any');
      any = true;
    }
  });
  return any ? out : null;
}

/** A level of the selection: a shape (or module) on the picked part's path. */
export interface Level {
  label: string;
  key: string | null;
  exact: string | null;
  semantic: SemanticLocator | null;
  /** The rule that rewrote it (an index into the preview's origins), when known. */
  production: number | null;
}

/**
 * The levels a pick offers, from the part itself (first) up to the axiom: in shape mode the shapes of its path
 * (commands and inserts are no level: an edit names shapes), each with its locators; in derive mode the modules of
 * its ancestry, by key.
 */
export function levelsOf(r: PickResult): Level[] {
  const out: Level[] = [];
  if (r.shape) {
    const scopes = r.shape.scopes;
    // The ancestry has a step per node of the path (shapes, commands, inserts), as the scopes do.
    const production = new Map<string, number | null>();
    for (const a of r.ancestry) production.set(a.key, a.production ?? null);
    for (let i = scopes.length - 1; i >= 0; i--) {
      const s = scopes[i];
      if (s.command || s.label === 'insert') continue;
      const last = i === scopes.length - 1;
      const exact = s.exact ?? (last ? r.shape.exact : null);
      const semantic = parseSemanticLocator(s.semantic ?? (last ? r.shape.semantic : '') ?? '');
      out.push({ label: s.label, key: s.key, exact, semantic, production: s.key ? (production.get(s.key) ?? null) : null });
    }
    return out;
  }
  for (let i = r.ancestry.length - 1; i >= 0; i--) {
    const a = r.ancestry[i];
    // The root (the axiom) is no module: nothing to edit.
    if (a.symbol === null) continue;
    out.push({ label: a.symbol, key: a.key, exact: null, semantic: null, production: a.production ?? null });
  }
  return out;
}

/** The alternatives of a symbol's rule: its productions in source order (force k is the k-th, from 1). */
export function alternativesOf(origins: readonly Origin[], symbol: string): { k: number; origin: number; line: number }[] {
  const out: { k: number; origin: number; line: number }[] = [];
  origins.forEach((o, i) => {
    if (o.symbol === symbol) out.push({ k: out.length + 1, origin: i, line: o.range.start.line + 1 });
  });
  return out;
}

/** The selection's target, or null where the chosen kind does not name this level (why in `problem`). */
export function targetOf(level: Level, kind: TargetKind, match: ReadonlyMap<string, TagMatch>): { target: TargetRef } | { problem: string } {
  if (kind === 'exact') return level.exact ? { target: { kind, text: level.exact } } : { problem: 'no exact locator for this part (derive mode names parts by key)' };
  if (kind === 'key') return level.key && isKey(level.key) ? { target: { kind, text: level.key } } : { problem: 'the server sent no key for this part' };
  if (!level.semantic) return { problem: 'no semantic locator for this part (semantic targets name parts of buildings)' };
  return { target: { kind, text: semanticQuery(level.semantic, match) } };
}

/** The colour of an edit's class in the list (valid green, the broken ones warm, stale grey). */
export const CLASS_COLOURS: Record<string, string> = {
  valid: '#3fb950',
  structurally_invalid: '#d29922',
  semantically_invalid: '#f85149',
  ambiguous: '#a371f7',
  stale: '#8b949e',
};

/** A class in words. */
export function classLabel(cls: string): string {
  return cls.replace(/_/g, ' ');
}

/** How an entry of the list reads: `#3 material glass on (floor = 2) Window`. */
export function entryText(e: EditEntry): string {
  return `#${e.id} ${e.op} on ${e.target.text}`;
}

/** A retarget candidate in words: its target, why, and how many parts it names. */
export function candidateText(c: RetargetCandidate): string {
  const why = c.reason.replace(/_/g, ' ');
  return `${c.target.text} (${why}; ${c.parts.length} part${c.parts.length === 1 ? '' : 's'})`;
}

/** An operation in words, as the server writes them (`material glass`, `force alternative 2`). */
export function opText(op: EditOp): string {
  switch (op.op) {
    case 'set':
      return `set ${op.name} = ${op.value}`;
    case 'offset':
      return `offset ${op.name} by ${op.by}`;
    case 'force':
      return `force alternative ${op.alternative}`;
    case 'pin':
      return `pin ${op.key}`;
    case 'material':
      return `material ${op.name}`;
    case 'mesh':
      return `mesh ${op.name}`;
    case 'remove':
      return 'remove';
  }
}

/** The materials and meshes the document declares (its symbols: a material is an Object, a mesh a File whose detail is not a grammar). */
export function assetsFromSymbols(symbols: unknown): { materials: string[]; meshes: string[] } {
  const materials: string[] = [];
  const meshes: string[] = [];
  if (!Array.isArray(symbols)) return { materials, meshes };
  for (const s of symbols as { name?: unknown; kind?: unknown; detail?: unknown }[]) {
    if (typeof s?.name !== 'string') continue;
    if (s.kind === 19) materials.push(s.name);
    else if (s.kind === 1 && typeof s.detail === 'string' && !s.detail.endsWith('.grm')) meshes.push(s.name);
  }
  return { materials, meshes };
}

/** A number for an operation's field (finite), or null. */
export function fieldNumber(text: string): number | null {
  if (text.trim() === '') return null;
  const x = Number(text);
  return Number.isFinite(x) ? x : null;
}

// ---------------------------------------------------------------- the panel

export interface EditPanelHost {
  /** Send a request to the host (`edit`, `removeEdit`, `retargetEdit`). */
  request(method: 'edit' | 'removeEdit' | 'retargetEdit', params: unknown): Promise<unknown>;
  /** The grammar shown. */
  uri(): string;
}

/** What the page exposes of the panel for tests (window.__grm.edits). */
export interface EditPanelDebug {
  /** The selection's label, its level (0 the picked part) and target. */
  selection: { label: string; level: number; target: TargetRef | null } | null;
  /** The list as the last preview classified it. */
  list: { id: number; op: string; target: string; class: string; replayed: boolean; candidates: number }[];
  /** Edits this page added (ids, oldest first) that it has not removed. */
  added: number[];
  /** Requests answered, and the last answer or error. */
  answers: number;
  lastAnswer: EditAnswer | null;
  lastError: string | null;
}

const el = <K extends keyof HTMLElementTagNameMap>(tag: K, props: Partial<HTMLElementTagNameMap[K]> = {}, ...kids: (Node | string)[]): HTMLElementTagNameMap[K] => {
  const e = Object.assign(document.createElement(tag), props);
  e.append(...kids);
  return e;
};

export class EditPanel {
  private levels: Level[] = [];
  private level = 0;
  private kind: TargetKind = 'exact';
  private match = new Map<string, TagMatch>();
  private origins: Origin[] = [];
  private mode = '';
  private edits: EditsInfo | null = null;
  private materials: string[] = [];
  /** What the artist typed in the operations' fields (by field id): a
   * model or the symbols arriving redraw the fields, and must not wipe it. */
  private drafts = new Map<string, string>();
  private meshes: string[] = [];
  readonly debug: EditPanelDebug = { selection: null, list: [], added: [], answers: 0, lastAnswer: null, lastError: null };

  private readonly head = el('p', { className: 'hint', id: 'edit-selection' });
  private readonly nav = el('div', { className: 'row edit-nav' });
  private readonly kinds = el('div', { className: 'row edit-kinds' });
  private readonly tags = el('div', { className: 'edit-tags' });
  private readonly targetLine = el('p', { className: 'edit-target', id: 'edit-target' });
  private readonly ops = el('div', { className: 'edit-ops' });
  private readonly listHead = el('h4', {}, 'Edits');
  private readonly list = el('ul', { className: 'edit-list', id: 'edit-list' });
  private readonly status = el('p', { className: 'hint', id: 'edit-status' });
  private readonly undo = el('button', { id: 'edit-undo', disabled: true, title: 'Remove the last edit this page made (in VS Code, the editor\'s Undo does too)' }, 'Undo edit');

  constructor(
    private readonly section: HTMLElement,
    private readonly host: EditPanelHost,
  ) {
    section.replaceChildren(
      el('h3', {}, 'Edit part'),
      this.head,
      this.nav,
      this.kinds,
      this.tags,
      this.targetLine,
      this.ops,
      this.listHead,
      this.list,
      el('div', { className: 'row' }, this.undo),
      this.status,
    );
    this.undo.addEventListener('click', () => void this.undoLast());
    // For tests and the curious, beside window.__grm.
    (globalThis as unknown as { __grmEdits: EditPanelDebug }).__grmEdits = this.debug;
    this.render();
  }

  /** The document changed: no selection, no list. */
  setDocument(): void {
    this.levels = [];
    this.edits = null;
    this.debug.added = [];
    this.drafts.clear();
    this.render();
  }

  /** The declared materials and meshes (from the document's symbols). */
  setSymbols(symbols: unknown): void {
    const a = assetsFromSymbols(symbols);
    this.materials = a.materials;
    this.meshes = a.meshes;
    this.renderOps();
  }

  /** A model is shown: its edits list and its rules (for the alternatives). */
  modelShown(mode: string, origins: Origin[], edits: EditsInfo | null): void {
    this.mode = mode;
    this.origins = origins;
    this.edits = edits;
    this.section.hidden = mode === 'sample' && !edits;
    this.renderList();
    this.renderOps();
  }

  /** A part was picked (null: nothing known made it). */
  picked(r: PickResult | null): void {
    this.levels = r ? levelsOf(r) : [];
    this.level = 0;
    this.match = new Map();
    this.kind = r?.shape ? 'exact' : 'key';
    this.render();
  }

  private get current(): Level | null {
    return this.levels[this.level] ?? null;
  }

  private target(): TargetRef | null {
    const l = this.current;
    if (!l) return null;
    const t = targetOf(l, this.kind, this.match);
    return 'target' in t ? t.target : null;
  }

  /** `field` with the value the artist last gave it (kept in `drafts`
   * across redraws), remembering each change. */
  private kept<T extends HTMLInputElement | HTMLSelectElement>(field: T): T {
    const v = this.drafts.get(field.id);
    if (v !== undefined) field.value = v;
    const keep = () => this.drafts.set(field.id, field.value);
    field.addEventListener('input', keep);
    field.addEventListener('change', keep);
    return field;
  }

  private render(): void {
    this.renderSelection();
    this.renderOps();
    this.renderList();
  }

  private renderSelection(): void {
    const l = this.current;
    this.nav.replaceChildren();
    this.kinds.replaceChildren();
    this.tags.replaceChildren();
    if (!l) {
      this.head.textContent = 'Click a part of the model to edit it; the edit is kept in the edits file beside the grammar and replayed at every regrowth.';
      this.targetLine.textContent = '';
      this.debug.selection = null;
      return;
    }
    this.head.textContent = `${l.label}${this.level > 0 ? ` (${this.level} level${this.level === 1 ? '' : 's'} above the picked part)` : ''}`;
    const up = el('button', { id: 'edit-up', disabled: this.level + 1 >= this.levels.length, title: 'Select the part this one was made from' }, 'Up one level');
    up.addEventListener('click', () => {
      this.level++;
      this.match = new Map();
      this.render();
    });
    const down = el('button', { id: 'edit-down', disabled: this.level === 0, title: 'Back towards the picked part' }, 'Down');
    down.addEventListener('click', () => {
      this.level--;
      this.match = new Map();
      this.render();
    });
    this.nav.append(up, down);
    const sem = l.semantic;
    if (sem) {
      for (const w of Object.keys(WIDENINGS) as Widening[]) {
        const m = widen(sem, this.match, w);
        if (!m) continue;
        const b = el('button', { id: `edit-widen-${w}`, title: WIDENINGS[w].title }, WIDENINGS[w].label);
        b.addEventListener('click', () => {
          this.match = m;
          this.kind = 'semantic';
          this.render();
        });
        this.nav.append(b);
      }
    }
    for (const k of ['exact', 'semantic', 'key'] as const) {
      const ok = 'target' in targetOf(l, k, this.match);
      const label = el('label', { className: 'check', title: k === 'exact' ? 'this part by its path from the axiom' : k === 'semantic' ? 'every part that matches its tags (wildcards widen it)' : 'this part by its identity key' });
      const input = el('input', { type: 'radio', name: 'edit-kind', value: k, checked: this.kind === k, disabled: !ok });
      input.addEventListener('change', () => {
        this.kind = k;
        this.render();
      });
      label.append(input, ` ${k === 'exact' ? 'this part' : k === 'semantic' ? 'by tags' : 'by key'}`);
      this.kinds.append(label);
    }
    if (sem && this.kind === 'semantic') {
      sem.entries.forEach((e, i) => {
        const key = entryKey(sem, i);
        const how = this.match.get(key) ?? 'start';
        const sel = el('select', { title: `how the ${e.tag} is matched` });
        sel.dataset.tag = key;
        const opts: [TagMatch, string][] = [
          ['start', `${e.tag} = ${e.index}`],
          ['end', `${e.tag} = end ${e.count - e.index + 1}`],
          ['any', `${e.tag}: any`],
        ];
        for (const [v, t] of opts) sel.append(el('option', { value: v, textContent: t, selected: v === how }));
        sel.addEventListener('change', () => {
          this.match.set(key, sel.value as TagMatch);
          this.render();
        });
        this.tags.append(sel);
      });
    }
    const t = targetOf(l, this.kind, this.match);
    this.targetLine.textContent = 'target' in t ? `target: ${t.target.text}` : t.problem;
    this.debug.selection = { label: l.label, level: this.level, target: 'target' in t ? t.target : null };
  }

  private renderOps(): void {
    this.ops.replaceChildren();
    const l = this.current;
    if (!l || !this.target()) return;
    // Parameters: derive mode replays set/offset on a module's parameter (its name or its place from 1).
    if (this.mode === 'derive') {
      const name = this.kept(el('input', { type: 'text', id: 'edit-param-name', value: '1', size: 6, spellcheck: false, title: 'the parameter: its declared name, or its place from 1 (`.x` for one component of a vec3)' }));
      const how = this.kept(el('select', { id: 'edit-param-how' }, el('option', { value: 'offset', textContent: 'offset by' }), el('option', { value: 'set', textContent: 'set to' })));
      const num = this.kept(el('input', { type: 'number', id: 'edit-param-value', value: '0', step: '0.05' }));
      const slider = el('input', { type: 'range', id: 'edit-param-slider', min: '-5', max: '5', step: '0.05', value: num.value });
      slider.addEventListener('input', () => {
        num.value = slider.value;
        this.drafts.set(num.id, num.value);
      });
      num.addEventListener('input', () => (slider.value = num.value));
      const apply = el('button', { id: 'edit-param-apply' }, 'Apply');
      apply.addEventListener('click', () => {
        const x = fieldNumber(num.value);
        const n = name.value.trim();
        if (x === null || n === '') return this.say('a parameter and a number are needed', true);
        void this.add(how.value === 'set' ? { op: 'set', name: n, value: x } : { op: 'offset', name: n, by: x });
      });
      this.ops.append(el('div', { className: 'row edit-param' }, 'parameter ', name, how), el('div', { className: 'row' }, slider, num, apply));
    } else if (this.mode === 'shape') {
      this.ops.append(el('p', { className: 'hint' }, 'Shape mode folds the parameters into its rules: set and offset are not replayed there (use the sliders above).'));
    }
    // The alternatives of its rule.
    const alts = alternativesOf(this.origins, l.label);
    if (alts.length > 0) {
      const sel = el('select', { id: 'edit-alternative', title: 'the alternative its rule uses from now on' });
      for (const a of alts) {
        const chosen = l.production === a.origin;
        sel.append(el('option', { value: String(a.k), textContent: `alternative ${a.k} (line ${a.line})${chosen ? ' · now' : ''}`, selected: chosen }));
      }
      const force = el('button', { id: 'edit-force' }, 'Force');
      force.addEventListener('click', () => void this.add({ op: 'force', alternative: Number(sel.value) }));
      this.ops.append(el('div', { className: 'row' }, 'rule ', sel, force));
    }
    const pin = el('button', { id: 'edit-pin', disabled: !l.key || !isKey(l.key), title: 'keep its random draws (its key now) whatever changes above it' }, 'Pin');
    pin.addEventListener('click', () => l.key && void this.add({ op: 'pin', key: l.key }));
    const remove = el('button', { id: 'edit-remove', title: 'remove it and everything made from it' }, 'Remove');
    remove.addEventListener('click', () => void this.add({ op: 'remove' }));
    this.ops.append(el('div', { className: 'row' }, pin, remove));
    const named = (what: 'material' | 'mesh', names: string[]) => {
      const input = this.kept(el('input', { type: 'text', id: `edit-${what}`, size: 10, spellcheck: false, placeholder: names[0] ?? what }));
      const listId = `edit-${what}-names`;
      input.setAttribute('list', listId);
      const dl = el('datalist', { id: listId });
      for (const n of names) dl.append(el('option', { value: n }));
      const b = el('button', { id: `edit-${what}-apply` }, what === 'material' ? 'Set material' : 'Set mesh');
      b.addEventListener('click', () => {
        const n = input.value.trim() || names[0] || '';
        if (!n) return this.say(`name a ${what}`, true);
        void this.add({ op: what, name: n });
      });
      this.ops.append(el('div', { className: 'row' }, input, dl, b));
    };
    named('material', this.materials);
    named('mesh', this.meshes);
  }

  private renderList(): void {
    const info = this.edits;
    const entries = info?.list ?? [];
    const file = info?.uri ? decodeURIComponent(info.uri.replace(/^.*\//, '')) : 'edits file';
    this.listHead.textContent = info?.found ? `Edits (${file})` : 'Edits (none yet)';
    this.list.replaceChildren();
    for (const e of entries) {
      const colour = CLASS_COLOURS[e.class] ?? '#8b949e';
      const li = el('li', { className: `edit-entry class-${e.class}` });
      li.dataset.id = String(e.id);
      li.style.borderLeftColor = colour;
      const dot = el('span', { className: 'edit-class', title: e.detail || classLabel(e.class) }, `● ${classLabel(e.class)}${e.replayed ? '' : ' (not applied)'}`);
      dot.style.color = colour;
      const del = el('button', { className: 'edit-delete', title: `Delete edit ${e.id}` }, 'Delete');
      del.addEventListener('click', () => void this.remove(e.id));
      li.append(el('div', { className: 'edit-text' }, entryText(e)), el('div', { className: 'row' }, dot, del));
      if (e.detail) li.append(el('div', { className: 'hint' }, e.detail));
      if (e.retarget.length > 0) {
        const sel = el('select', { className: 'edit-candidates', title: 'targets the server proposes, best first' });
        e.retarget.forEach((c, i) => sel.append(el('option', { value: String(i), textContent: candidateText(c) })));
        const go = el('button', { className: 'edit-retarget', title: 'Give the edit this target (it keeps its id)' }, 'Retarget');
        go.addEventListener('click', () => void this.retarget(e.id, e.retarget[Number(sel.value)]));
        li.append(el('div', { className: 'row' }, sel, go));
      }
      this.list.append(li);
    }
    if (info && info.problems > 0) this.list.append(el('li', { className: 'hint' }, `${info.problems} problem${info.problems === 1 ? '' : 's'} in the file: those edits are skipped (fix them there)`));
    this.debug.list = entries.map((e) => ({ id: e.id, op: e.op, target: e.target.text, class: e.class, replayed: e.replayed, candidates: e.retarget.length }));
    // Edits this page added that the file no longer has (undone in the editor, deleted here) leave the undo stack.
    if (info) {
      const ids = new Set(entries.map((e) => e.id));
      this.debug.added = this.debug.added.filter((id) => ids.has(id));
    }
    this.undo.disabled = this.debug.added.length === 0;
  }

  private say(text: string, error = false): void {
    this.status.textContent = text;
    this.status.classList.toggle('error', error);
    if (error) this.debug.lastError = text;
  }

  private async send(method: 'edit' | 'removeEdit' | 'retargetEdit', params: unknown, what: string): Promise<EditAnswer | null> {
    this.say(`${what}…`);
    try {
      const a = decodeEditAnswer(await this.host.request(method, params));
      this.debug.answers++;
      this.debug.lastAnswer = a;
      this.debug.lastError = null;
      if (!a.applied) {
        this.say(`${what}: not applied${a.failureReason ? `: ${a.failureReason}` : ''}`, true);
        return null;
      }
      this.say(`${what}: ${a.written ? 'written to' : 'applied in'} ${decodeURIComponent(a.uri.replace(/^.*\//, ''))}`);
      return a;
    } catch (e) {
      this.debug.answers++;
      this.say(`${what}: ${String((e as Error).message ?? e).split('\n')[0]}`, true);
      return null;
    }
  }

  private async add(op: EditOp): Promise<void> {
    const t = this.target();
    if (!t) return;
    const a = await this.send('edit', { uri: this.host.uri(), target: targetParam(t), op }, `edit: ${opText(op)} on ${t.text}`);
    if (a) {
      this.debug.added.push(a.id);
      this.undo.disabled = false;
    }
  }

  private async remove(id: number): Promise<void> {
    const a = await this.send('removeEdit', { uri: this.host.uri(), id }, `delete edit ${id}`);
    if (a) this.debug.added = this.debug.added.filter((x) => x !== id);
    this.undo.disabled = this.debug.added.length === 0;
  }

  private async retarget(id: number, c: RetargetCandidate | undefined): Promise<void> {
    if (!c) return;
    await this.send('retargetEdit', { uri: this.host.uri(), id, target: targetParam(c.target) }, `retarget edit ${id} to ${c.target.text}`);
  }

  private async undoLast(): Promise<void> {
    const id = this.debug.added[this.debug.added.length - 1];
    if (id !== undefined) await this.remove(id);
  }
}
