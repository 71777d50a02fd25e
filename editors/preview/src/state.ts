// The page's editing state, without any DOM or three.js: what the next
// preview request says, the curves being edited, the meta-parameter values.
// Unit-tested under node.

import { type Bezier, type V3, fitCubicBezier } from './bezier.js';
import { type Curve, type CurveParams, type CurveSet, DEFAULT_PARAMS, cloneSet, freshName, parseCurves, serializeCurves } from './curves.js';
import { GenerationScrub, searchKey } from './generation.js';
import type { Mode, ParamInfo, Position, PreviewParams, PreviewResult } from './protocol.js';

export class PageState {
  uri = '';
  /**
   * The seed the user picked in the page (the seed field, Next variation, a
   * gallery thumbnail); null: the grammar's own (its `seed` setting), which
   * the requests then leave to the file, so an edit of it is followed.
   */
  seed: number | null = null;
  /** The seed of the model shown (the file's, or the one picked). */
  shownSeed: number | null = null;
  /** Meta-parameter overrides the user set (name -> value). */
  params: Record<string, number> = {};
  /** The meta-parameters the grammar declares (when the server lists them). */
  paramInfo: ParamInfo[] = [];
  /** The curves being edited; null until loaded (sample systems only). */
  curves: CurveSet | null = null;
  /** Where the curves file is. */
  curvesPath: string | null = null;
  selected: number | null = null;
  mode: Mode = 'derive';
  system = '';
  curvesError: string | null = null;
  /** The production whose growth is highlighted (a position in it). */
  focus: Position | null = null;
  /** Focus and context (shape and derive mode): the chosen node's key, the levels drawn below it; null: the whole model. */
  context: { key: string; depth: number } | null = null;
  /** Curve sets before each finished edit (undo), and those undone (redo). */
  private undoStack: CurveSet[] = [];
  private redoStack: CurveSet[] = [];
  /** The set when the current edit (a drag, a stroke) began. */
  private editBase: CurveSet | null = null;
  /** Sample mode: the generation scrubber's position in the current search. */
  private readonly scrub = new GenerationScrub();

  /**
   * The parameters of the next preview request (live: the server regrows it
   * after edits), with the generation the scrubber shows (sample mode; none:
   * the search's result).
   */
  previewParams(): PreviewParams {
    const p = this.searchParams();
    const g = this.generationOf(p);
    if (g !== null) p.generation = g;
    return p;
  }

  /** The preview parameters without the generation. */
  private searchParams(): PreviewParams {
    const p: PreviewParams = { textDocument: { uri: this.uri }, mode: this.mode, live: true };
    if (this.seed !== null) p.seed = this.seed;
    if (Object.keys(this.params).length > 0) p.params = { ...this.params };
    if (this.mode === 'sample' && this.curves && this.curves.curves.length > 0) p.curves = JSON.parse(serializeCurves(this.curves));
    if (this.focus) p.focus = { ...this.focus };
    if (this.context && this.mode !== 'sample') p.context = { ...this.context };
    return p;
  }

  /** The scrubber's generation for the search `p` asks for: none in derive mode, and none once anything that decides the search changed. */
  private generationOf(p: PreviewParams): number | null {
    // Asked in derive mode too: the mode is part of the search, so a change of it puts the scrubber back at the end.
    const g = this.scrub.current(searchKey(p));
    return this.mode === 'sample' ? g : null;
  }

  /**
   * The generation the scrubber shows (0-based; null: the search's result).
   * Back to null for good once the seed, a meta-parameter, the curves, the
   * mode or the document changed (a new search).
   */
  get generation(): number | null {
    return this.generationOf(this.searchParams());
  }

  /** What decides the search the next request runs (`searchKey`): a replay of it stops when this changes. */
  get searchKey(): string {
    return searchKey(this.searchParams());
  }

  /** Move the scrubber to `position` (0-based) of a search of `generations` generations; the last one is the result. */
  setGeneration(position: number, generations: number): void {
    if (this.mode !== 'sample') return;
    this.scrub.set(position, generations, searchKey(this.searchParams()));
  }

  /** The scrubber back to the end: the document was edited, so the same parameters run a new search, whose result is shown. */
  showResult(): void {
    this.scrub.reset();
  }

  /** Switch to another document: everything document-specific is reset. */
  setDocument(uri: string): void {
    if (uri === this.uri) return;
    this.uri = uri;
    this.seed = null;
    this.shownSeed = null;
    this.params = {};
    this.paramInfo = [];
    this.curves = null;
    this.curvesPath = null;
    this.selected = null;
    this.curvesError = null;
    this.mode = 'derive';
    this.focus = null;
    this.context = null;
    this.scrub.reset();
  }

  /** Take what a preview result says about the grammar (mode, system, seed, parameters). */
  absorb(r: PreviewResult): void {
    this.mode = r.mode;
    this.system = r.system;
    // Shown, not picked: the next request still follows the file's seed.
    this.shownSeed = r.seed;
    // A server that lists the meta-parameters in the result is taken at its word.
    if (r.params.length > 0 || r.paramsWithoutRange.length > 0) this.setParamInfo(r.params);
  }

  /** The curves file as read from disk (null text: there is none yet). */
  loadCurves(path: string, text: string | null): void {
    this.curvesPath = path;
    this.selected = null;
    this.undoStack = [];
    this.redoStack = [];
    this.editBase = null;
    if (text === null) {
      this.curves = { curves: [] };
      this.curvesError = null;
      return;
    }
    try {
      this.curves = parseCurves(text);
      this.curvesError = null;
    } catch (e) {
      this.curves = { curves: [] };
      this.curvesError = (e as Error).message;
    }
  }

  /** The meta-parameters the grammar declares (from its symbols). Overrides of parameters it no longer declares are dropped. */
  setParamInfo(params: ParamInfo[]): void {
    this.paramInfo = params;
    const names = new Set(params.map((p) => p.name));
    for (const k of Object.keys(this.params)) if (!names.has(k)) delete this.params[k];
  }

  paramValue(name: string): number | undefined {
    return this.params[name] ?? this.paramInfo.find((p) => p.name === name)?.value;
  }

  setParam(name: string, value: number): void {
    const info = this.paramInfo.find((p) => p.name === name);
    if (!info || !Number.isFinite(value)) return;
    this.params[name] = Math.min(info.max, Math.max(info.min, value));
  }

  /** The seed the page shows in its seed field: the one picked, else the shown model's. */
  get currentSeed(): number | null {
    return this.seed ?? this.shownSeed;
  }

  /** The seed after the one shown: picked from now on. */
  nextVariation(): void {
    this.seed = ((this.currentSeed ?? 0) + 1) >>> 0;
  }

  setSeed(seed: number): void {
    if (Number.isFinite(seed)) this.seed = Math.max(0, Math.floor(seed)) >>> 0;
  }

  /** Parameters for a new curve: the selected curve's, else the last curve's, else grm-guide's defaults. */
  templateParams(): CurveParams {
    const set = this.curves;
    const from = set && (set.curves[this.selected ?? -1] ?? set.curves[set.curves.length - 1]);
    const p = from ? from.params : DEFAULT_PARAMS;
    return { ...p, distance: [...p.distance] as [number, number, number] };
  }

  private editable(): CurveSet {
    // Edits never mutate a set in place, so the sets on the undo stack stay as they were.
    const before = this.curves ?? { curves: [] };
    this.editBase ??= before;
    this.curves = cloneSet(before);
    return this.curves;
  }

  /** An edit is finished (a drag released, a stroke drawn, a field changed): it becomes one undo step. */
  finishEdit(): void {
    if (!this.editBase) return;
    this.undoStack.push(this.editBase);
    if (this.undoStack.length > 100) this.undoStack.shift();
    this.redoStack = [];
    this.editBase = null;
  }

  get canUndo(): boolean {
    return this.undoStack.length > 0;
  }

  get canRedo(): boolean {
    return this.redoStack.length > 0;
  }

  /** Back to the curves before the last finished edit. Returns false if there is none. */
  undo(): boolean {
    this.finishEdit();
    const prev = this.undoStack.pop();
    if (!prev) return false;
    if (this.curves) this.redoStack.push(this.curves);
    this.curves = prev;
    this.selected = this.selected !== null && this.selected < prev.curves.length ? this.selected : null;
    return true;
  }

  redo(): boolean {
    const next = this.redoStack.pop();
    if (!next) return false;
    if (this.curves) this.undoStack.push(this.curves);
    this.curves = next;
    this.selected = this.selected !== null && this.selected < next.curves.length ? this.selected : null;
    return true;
  }

  /** Fit a stroke (world points) to a curve and add it, selected. Returns its index or null. */
  addStroke(stroke: V3[]): number | null {
    const fit = fitCubicBezier(stroke);
    if (!fit) return null;
    const params = this.templateParams();
    const set = this.editable();
    set.curves.push({ name: freshName(set), points: fit, params });
    this.selected = set.curves.length - 1;
    return this.selected;
  }

  moveControlPoint(curve: number, k: number, p: V3): void {
    if (!this.curves?.curves[curve] || k < 0 || k > 3 || !p.every(Number.isFinite)) return;
    const set = this.editable();
    set.curves[curve].points[k] = [p[0], p[1], p[2]];
  }

  setCurveParam<K extends keyof CurveParams>(curve: number, key: K, value: CurveParams[K]): void {
    if (!this.curves?.curves[curve]) return;
    const set = this.editable();
    set.curves[curve].params[key] = value;
  }

  renameCurve(curve: number, name: string): boolean {
    if (!this.curves?.curves[curve]) return false;
    if (this.curves.curves.some((c, i) => i !== curve && c.name === name)) return false;
    const set = this.editable();
    if (name === '') delete set.curves[curve].name;
    else set.curves[curve].name = name;
    return true;
  }

  deleteCurve(curve: number): void {
    if (!this.curves?.curves[curve]) return;
    const set = this.editable();
    set.curves.splice(curve, 1);
    this.selected = null;
  }

  /** The curves as Béziers, for drawing. */
  beziers(): Bezier[] {
    return this.curves ? this.curves.curves.map((c: Curve) => c.points) : [];
  }

  /** The curves file text to save, or why it cannot be saved. */
  curvesText(): { text: string } | { error: string } {
    if (!this.curves || this.curves.curves.length === 0) return { error: 'a curves file needs at least one curve: not saved' };
    try {
      return { text: serializeCurves(this.curves) };
    } catch (e) {
      return { error: (e as Error).message };
    }
  }
}

/**
 * The document version of what the page shows. A live request that began
 * before an edit may answer after the server's update for the edit: its
 * model, of the older text, is never shown over the newer one, nor over the
 * newer text's errors.
 */
export class ShownVersion {
  private version = -1;
  /** Models shown so far (a request's failure knows from it whether one came after it went). */
  private models = 0;
  /** Answers (models and errors) put on screen so far. */
  private answers = 0;

  /** A model of `version` came: whether to show it (it is then the version shown). */
  model(version: number): boolean {
    if (version < this.version) return false;
    this.version = version;
    this.models++;
    return true;
  }

  /** A mark to give [`ShownVersion.shownSince`] when a request goes. */
  mark(): number {
    return this.models;
  }

  /**
   * Whether a model was shown since `mark`: then a request that went
   * before it and failed (its text had errors: `seed = 2` while `seed = 2;`
   * was typed) speaks of an older text than the one on screen. The
   * server's update reports the latest text's errors itself.
   */
  shownSince(mark: number): boolean {
    return this.models > mark;
  }

  /**
   * The server said the text of `version` has errors: whether to show them
   * (instead of a model). Errors of a version older than the one shown are
   * not the state: typing `seed = 2;` sends `seed = 2` (a missing `;`)
   * first, and on a busy machine its update can come after the model of
   * the finished text.
   */
  error(version: number): boolean {
    if (version < this.version) return false;
    this.version = version;
    return true;
  }

  /**
   * A request of the page failed: whether to show its failure. `version`
   * is the document version whose text failed, where the server named it
   * (`grm/preview`'s `data.version`): shown unless a newer version is on
   * screen (it is then the version shown). Without it, shown unless a
   * model came since `mark` (the request's text is then older than the
   * model's).
   */
  failure(version: number | undefined, mark: number): boolean {
    return version === undefined ? !this.shownSince(mark) : this.error(version);
  }

  /**
   * An answer (a model or an error) is being put on screen: its ticket. A
   * model's status line goes on screen with its frame, a moment later,
   * and only while [`ShownVersion.latest`] says no answer came after it:
   * the errors of a newer text, shown meanwhile, stay.
   */
  answer(): number {
    return ++this.answers;
  }

  /** Whether the answer of `ticket` is the last one put on screen. */
  latest(ticket: number): boolean {
    return ticket === this.answers;
  }

  /** Another document, or the same after the host's server restarted: any version is news. */
  reset(): void {
    this.version = -1;
  }
}
