// The preview page: wires the transport, the editing state, the 3D scene and
// the side panel together. Runs unchanged in a VS Code webview and in a
// browser served by `grmc view`. Here: the host's notifications, the preview
// requests and the model shown; the page's parts are controllers of their
// own (input.ts, picking.ts, manip-controller.ts, curves-panel.ts,
// sliders.ts, playback.ts, gallery.ts, save-picture.ts), its debug info in
// debug-info.ts.

import { Coalescer, type Delivery, SharedRequest } from './coalesce.js';
import { CurvesPanel } from './curves-panel.js';
import { type DebugInfo, debugInfo } from './debug-info.js';
import { $ } from './dom.js';
import { EditPanel } from './edit-panel.js';
import { Gallery } from './gallery.js';
import { isSearchResult, showsUpdate } from './generation.js';
import { PointerInput } from './input.js';
import { LayoutView, isLayoutUri } from './layout-view.js';
import { ManipController } from './manip-controller.js';
import { type NotificationMethod, SERVER_CANCELLED, type ViewParams, usableCamera, viewAngles } from './messages.js';
import { Picking, modelSignature } from './picking.js';
import { Playback } from './playback.js';
import { type PreviewParams, type PreviewResult, decodePreview, decodePreviewUpdated, modeFromSymbols, paramsFromSymbols } from './protocol.js';
import { PictureButton } from './save-picture.js';
import { PreviewScene } from './scene.js';
import { Sliders } from './sliders.js';
import { PageState, ShownVersion } from './state.js';
import { TreePanel } from './tree-panel.js';
import { type RequestTiming, type Transport, TransportError, detectTransport, isSuperseded } from './transport.js';

/** A preview answer, the parameters asked (JSON) and where the time went on its way (ms). */
interface Fetched {
  result: PreviewResult;
  breakdown: Record<string, number>;
  params?: string;
}

/** An id for this page's live requests (`client`): random, so two pages on one document never share one. */
function clientId(): string {
  const c = (globalThis as { crypto?: { randomUUID?: () => string } }).crypto;
  return c?.randomUUID?.() ?? `${Date.now().toString(36)}-${Math.random().toString(36).slice(2)}`;
}

/** How long the camera must rest before the page tells the host its view (not on every frame of a drag). */
const VIEW_REST_MS = 200;

/**
 * The page: its state, scene and requests, the model shown, and the controllers of its parts (each in a module of
 * its own), which read what they need of it here.
 */
export class App {
  readonly state = new PageState();
  readonly scene: PreviewScene;
  readonly coalescer: Coalescer<null, Fetched>;
  /** The preview request on its way, shared by a request for the same parameters. */
  private readonly previewRequest = new SharedRequest<Fetched>();
  /** The last model shown. */
  private result: PreviewResult | null = null;
  private framed = false;
  /** The server lists the meta-parameters in its preview results. */
  private serverParams = false;
  /** The document version whose meta-parameters the sliders show. */
  private symbolsFor = '';
  readonly debug: DebugInfo;
  private viewTimer: ReturnType<typeof setTimeout> | undefined;
  /** The last view told to the host (as JSON): an unchanged view is not told again. */
  private viewSent = '';
  /** This page's live requests: its id and the number of the last one (the server never lets an older one win). */
  private readonly client = clientId();
  private order = 0;
  /** The document version shown: a model of an older one (an answer that took longer than an update) is not shown. */
  private readonly shownVersion = new ShownVersion();

  /** The derivation tree panel (read only while it is open). */
  readonly treePanel: TreePanel;
  /** The edit panel: persistent edits of the picked part (issue 27). */
  readonly editPanel: EditPanel;
  /** Pointer and keyboard input in the view. */
  readonly input = new PointerInput(this);
  /** A click's pick, the focused rule and its spread, the chosen tree node. */
  readonly picking = new Picking(this);
  /** Direct manipulation: the picked part's handles, drags, sketches and the sliders written back. */
  readonly manipulation = new ManipController(this);
  /** The guiding curves (sample mode). */
  readonly curves = new CurvesPanel(this);
  /** The meta-parameters' sliders. */
  readonly sliders = new Sliders(this);
  /** The generation scrubber and the replay of the search (sample mode). */
  readonly playback = new Playback(this);
  private readonly gallery = new Gallery(this);
  private readonly picture = new PictureButton(this);

  /** The layout view, shown for a `NAME.layout.json` (issue 29). */
  private readonly layoutView: LayoutView;

  constructor(readonly transport: Transport) {
    this.layoutView = new LayoutView({ request: (m, p) => this.transport.request(m, p) });
    document.body.append(this.layoutView.root);
    $('toolbar').append(this.layoutView.openButton);
    this.scene = new PreviewScene($<HTMLCanvasElement>('view'));
    this.treePanel = new TreePanel(
      $('tree-view'),
      (params) => this.transport.request('tree', { textDocument: { uri: this.state.uri }, ...(params as object) }),
      (n) => this.picking.chooseTreeNode(n),
    );
    this.editPanel = new EditPanel($('edit-section'), { request: (m, p) => this.transport.request(m, p), uri: () => this.state.uri });
    $('tree-details').addEventListener('toggle', () => {
      if ($<HTMLDetailsElement>('tree-details').open) void this.treePanel.modelShown().catch(() => {});
    });
    this.coalescer = new Coalescer(
      () => null,
      () => this.fetchPreview(),
      (d) => this.show({ ...d, result: d.result.result }, d.result.breakdown, d.result.params ?? null),
      (e) => {
        // A replay's step failed: it stops there, the error shown as any other.
        this.playback.stopPlay();
        this.showError(String((e as Error).message ?? e), e instanceof TransportError ? (e.version ?? null) : null);
      },
      () => performance.now(),
      {
        // A newer request superseded it: its answer is not an error to show.
        isSuperseded,
        // Superseded by a request that is not this page's (another page on the same document); a replay's step
        // would wait for it for ever.
        supersededElsewhere: () => {
          this.playback.stopPlay();
          this.setStatus('another preview request for this document replaced this one');
        },
      },
    );
    this.debug = debugInfo(this);
    (globalThis as unknown as { __grm: DebugInfo }).__grm = this.debug;
    this.wireUi();
    this.transport.onNotification((m, p) => this.notified(m, p));
    this.scene.onViewChange = () => this.viewChanged();
    new ResizeObserver(() => this.scene.resize()).observe($('viewport'));
  }

  /** The last model shown. */
  get last(): PreviewResult | null {
    return this.result;
  }

  /** The host names the document to show with a `document` notification (VS Code: the active editor; `grmc view`: its file). */
  start(): void {
    this.transport.start();
  }

  // ------------------------------------------------------------- host

  private notified(method: NotificationMethod, params: unknown): void {
    const p = (params ?? {}) as Record<string, unknown>;
    // The host's side changed: a request for the page's (same) state is sent anew, not shared with one on its way.
    if (method !== 'cursor') this.previewRequest.forget();
    if (method === 'document' && typeof p.uri === 'string' && isLayoutUri(p.uri)) {
      if (typeof p.title === 'string') document.title = `grm layout: ${p.title}`;
      void this.layoutView.show(p.uri);
      return;
    }
    if (method === 'layoutUpdated') {
      this.layoutView.updated(params);
      return;
    }
    if (method === 'document' && typeof p.uri === 'string') {
      // A grammar with a `layout` item: the toolbar offers its layout view.
      void this.layoutView.offer(p.uri);
      // Another document, or the same one after the host's server restarted: any version is news.
      this.shownVersion.reset();
      if (p.uri !== this.state.uri) {
        this.state.setDocument(p.uri);
        this.treePanel.setDocument(p.uri);
        this.editPanel.setDocument();
        this.framed = false;
        this.sliders.paramSignature = '';
        this.curves.curvesLoadedFor = '';
        this.symbolsFor = '';
        // The host keeps a view per shown document: tell it for this one (and again once its model is framed).
        this.viewChanged();
      }
      if (typeof p.title === 'string') document.title = `grm preview: ${p.title}`;
      this.regrow();
    } else if (method === 'previewUpdated') {
      // The server regrew the live preview after an edit of the grammar.
      let u;
      try {
        u = decodePreviewUpdated(params);
      } catch (e) {
        this.showError(`previewUpdated: ${(e as Error).message}`);
        return;
      }
      if (u.uri !== this.state.uri) return;
      // The document was edited: the same parameters run a new search, whose result the scrubber shows.
      this.state.showResult();
      this.playback.refreshScrubber();
      // Only a model of the state the page shows (not of a gallery or spread request).
      if (u.result && this.state.seed !== null && u.result.seed !== this.state.seed) return;
      // A generation's model: the server regrew a scrubbed live request; the new search's result is asked for.
      if (u.result && !showsUpdate(u.result)) this.regrow();
      else if (u.result) this.show({ result: u.result, editedAt: performance.now(), final: true });
      else if (u.error && this.shownVersion.error(u.version)) {
        // The latest text has errors: an answer about an older text, still on its way, is not the state
        // (nor are the errors of a text older than the model shown).
        this.showError(u.error, u.version);
      }
    } else if (method === 'curvesChanged') {
      if (p.uri !== this.state.uri || this.state.mode !== 'sample' || this.input.gesture.kind !== 'none') return;
      // Edited by hand or by another tool: the file wins over the page's copy.
      this.curves.curvesLoadedFor = '';
      this.regrow();
    } else if (method === 'cursor' && typeof p.line === 'number') {
      this.picking.setFocus({ line: p.line, character: typeof p.character === 'number' ? p.character : 0 });
    } else if (method === 'treeNode' && p.uri === this.state.uri) {
      // A node chosen in the editor's derivation view: its parts highlighted here, and revealed in the page's panel.
      const key = typeof p.key === 'string' ? p.key : null;
      void this.picking.highlightNode(key);
      if (key && $<HTMLDetailsElement>('tree-details').open) void this.treePanel.reveal(key).catch(() => {});
    }
  }

  /** The camera moved or the canvas changed size: tell the host once the camera has rested. */
  private viewChanged(): void {
    clearTimeout(this.viewTimer);
    this.viewTimer = setTimeout(() => this.tellView(), VIEW_REST_MS);
  }

  /**
   * Tell the host where the camera looks from, the camera itself and the
   * canvas' size: the extension exports pictures through this camera (or
   * from its direction, where the camera is not usable).
   */
  private tellView(): void {
    const uri = this.state.uri;
    const v = this.scene.view();
    const angles = viewAngles(...v.direction);
    // A hidden panel's canvas has no size: the last view told stands.
    if (!uri || !angles || v.width <= 0 || v.height <= 0) return;
    const camera = usableCamera(v.camera);
    // A zoom or a pan changes the camera, not its direction: it is a new view too.
    const params: ViewParams = { uri, ...angles, width: v.width, height: v.height, ...(camera ? { camera } : {}) };
    const key = JSON.stringify(params);
    if (key === this.viewSent) return;
    this.viewSent = key;
    this.debug.lastView = params;
    this.debug.views++;
    this.transport.notify('view', params);
  }

  /** Before a request from the state: the mode (from the document's symbols) is known and a sample system's curves are loaded. */
  async prepareRequest(): Promise<void> {
    if (!this.symbolsFor.startsWith(`${this.state.uri}@`)) await this.loadSymbols('first');
    if (this.state.mode === 'sample') await this.curves.ensureCurves();
  }

  private async fetchPreview(): Promise<Fetched> {
    // Numbered when the coalescer sends it, before any wait: its order is the coalescer's.
    const order = ++this.order;
    await this.prepareRequest();
    const params = this.state.previewParams();
    const key = JSON.stringify(params);
    // The state of the request on its way (read when it went, after the edits of its task): its answer is this one's.
    const fetched = await this.previewRequest.run(key, () => this.requestPreview(params, order));
    return { ...fetched, params: key };
  }

  /** A live request carries this page's id and its number (`order`, default the next one); other requests go as they are. */
  ordered(params: PreviewParams, order = ++this.order): PreviewParams {
    return params.live ? { ...params, client: this.client, order } : params;
  }

  private async requestPreview(params: PreviewParams, order: number): Promise<Fetched> {
    const mark = this.shownVersion.mark();
    try {
      const t0 = performance.now();
      const timing: RequestTiming = {};
      const raw = await this.transport.request('preview', this.ordered(params, order), timing);
      const t1 = performance.now();
      const result = decodePreview(raw);
      const breakdown: Record<string, number> = { host: t1 - t0, decode: performance.now() - t1 };
      // The part of `host` the server itself spent (grmc view tells it).
      if (timing.serverMs !== undefined) breakdown['server total'] = timing.serverMs;
      return { result, breakdown };
    } catch (e) {
      const msg = (e as Error).message ?? '';
      if (this.state.mode === 'derive' && /is a shape system/.test(msg)) {
        this.state.mode = 'shape';
        return { result: decodePreview(await this.transport.request('preview', this.ordered(this.state.previewParams()))), breakdown: {} };
      }
      if (this.state.mode === 'derive' && /is a sample system/.test(msg)) {
        this.state.mode = 'sample';
        await this.curves.ensureCurves();
        return { result: decodePreview(await this.transport.request('preview', this.ordered(this.state.previewParams()))), breakdown: {} };
      }
      // The failure of an older text than the one on screen (a model or the errors of a newer text came while this
      // request was on its way) is not the state: dropped as superseded.
      if (!isSuperseded(e) && !this.shownVersion.failure(e instanceof TransportError ? e.version : undefined, mark)) {
        throw new TransportError(msg, SERVER_CANCELLED);
      }
      throw e;
    }
  }

  /**
   * The state changed: grow its model. A `final` edit (a click, a typed
   * value, a release) is sent at once even while a request for an older
   * state is in flight; the moves of a drag (`final` false) wait for its
   * answer and are merged.
   */
  regrow(editedAt = performance.now(), final = true): void {
    if (!this.state.uri) return;
    // After an edit of the seed, a meta-parameter or the curves the scrubber is back at the end: shown at once.
    this.playback.refreshScrubber();
    this.setStatus('growing…');
    this.coalescer.trigger(editedAt, final);
  }

  /**
   * A drag or a slider was released where its last move left it. Moves still
   * waiting for a stale answer are sent now; a request in flight for the
   * current state is the final one already. With nothing in flight the
   * release regrows (as it always did: the release's edit-to-screen time is
   * what the browser test measures).
   */
  released(editedAt: number, regrowIfIdle: boolean): void {
    if (!this.state.uri) return;
    if (this.coalescer.busy) this.coalescer.flush();
    else if (regrowIfIdle) this.regrow(editedAt);
  }

  show(d: Delivery<PreviewResult>, breakdown: Record<string, number> = {}, params: string | null = null): void {
    const r = d.result;
    // The answer of a request that began before an edit, after the update the edit brought: the older text's model.
    if (r.uri === this.state.uri && !this.shownVersion.model(r.version)) {
      this.debug.olderVersions++;
      return;
    }
    // Its status goes on screen with its frame, unless an answer after it (an error of a newer text) came first.
    const answer = this.shownVersion.answer();
    this.debug.shownParams = params;
    this.debug.delivered++;
    this.result = r;
    // The open tree panel follows the model shown.
    if ($<HTMLDetailsElement>('tree-details').open) void this.treePanel.modelShown().catch(() => {});
    this.state.absorb(r);
    this.editPanel.modelShown(r.mode, r.origins, r.edits);
    if (r.params.length > 0 || r.paramsWithoutRange.length > 0) {
      this.serverParams = true;
      this.sliders.showSkippedParams(r.paramsWithoutRange);
    }
    $('overlay-msg').textContent = this.state.curvesError ? `curves: ${this.state.curvesError}` : '';
    // A drag's regrown model: a model of a newer version than the one on screen when it was released.
    const dragDone = this.manipulation.takeDragDone(r);
    const tBuild = performance.now();
    // The curves' stretches no bone follows, tinted (sample mode).
    this.scene.setGaps((r.sample?.coverage ?? []).flatMap((c) => c.gapPoints));
    this.curves.refreshCurveList();
    this.scene.setModel(r.model, !this.framed, () => {
      const rendered = performance.now();
      // The chosen tree node's parts, on the new model (its key stays; its triangles are asked again).
      if (this.picking.chosenKey) void this.picking.highlightNode(this.picking.chosenKey);
      // The frame is done (and its pixels exist) when the task that ran
      // this animation frame ends: the browser commits the frame in it
      // (with software compositing, reading the WebGL canvas back).
      afterThisTask(() => {
        const now = performance.now();
        const ms = now - d.editedAt;
        const server = Object.fromEntries(Object.entries(r.timings).map(([k, v]) => [`server ${k}`, v]));
        this.debug.lastBreakdown = { ...breakdown, ...server, scene: built - tBuild, render: rendered - built, present: now - rendered };
        this.debug.regrows++;
        this.debug.lastShownAt = now;
        this.debug.objective = r.sample?.objective ?? null;
        this.debug.generation = r.sample && !isSearchResult(r.sample) ? r.sample.generation : null;
        this.debug.generations = r.sample?.generations ?? null;
        this.debug.coverage = (r.sample?.coverage ?? []).map((c) => ({ name: c.name, fraction: c.fraction, unreached: c.unreached, gaps: c.gaps.length, note: c.note }));
        this.debug.refinements = r.sample?.refinements ?? null;
        this.debug.lastLatencyMs = ms;
        this.debug.latencies.push(ms);
        // The part picked again after a drag; the drag's times.
        this.manipulation.shown(now, d.editedAt, dragDone);
        this.debug.meshCount = this.scene.meshCount;
        if (this.shownVersion.latest(answer)) {
          this.setStatus(this.summary(r, ms), false, r.warnings.length > 0);
          $('status-text').title = r.warnings
            .map((w) => [`${w.code}: ${w.message}`, ...w.notes.map((n) => `note: ${n}`), ...(w.help ? [`help: ${w.help}`] : [])].join('\n'))
            .join('\n');
          this.debug.statusOf = { version: r.version, seed: r.seed, error: null };
        }
        // On screen now: a replay asks for its next step.
        this.playback.playShown(r, now);
      });
    });
    const built = performance.now();
    this.framed = true;
    this.debug.triangles = r.model.triangles;
    this.debug.warnings = r.warnings.map((w) => w.code);
    this.debug.bones = r.model.bones.length;
    this.debug.mode = r.mode;
    this.debug.seed = r.seed;
    // The scopes toggle is shape mode's; a new model's shapes may have moved.
    $('scopes-toggle').hidden = r.mode !== 'shape';
    $('manip-section').hidden = r.mode === 'sample';
    // Another model (not the same one regrown, e.g. to highlight a rule): the picked shape's scopes and the
    // handles are the old model's. After a drag the same part is picked again, its handles where it now is.
    const sig = modelSignature(r);
    if (sig !== this.picking.pickedFor) {
      this.picking.pickedFor = sig;
      this.picking.pickedScopes = null;
      this.manipulation.modelChanged(dragDone);
    }
    this.picking.drawScopes();
    this.debug.ready = true;
    this.debug.lastError = null;
    this.picking.showFocus(r);
    this.refreshPanel();
    void this.loadSymbols(String(r.version)).then((modeChanged) => {
      if (modeChanged) this.regrow();
    });
  }

  /**
   * The sliders follow the grammar's `param` declarations and the mode its
   * first system's, both read from the document's symbols (once per
   * document version). Returns whether the mode changed.
   */
  private async loadSymbols(version: string): Promise<boolean> {
    const key = `${this.state.uri}@${version}`;
    if (this.symbolsFor === key) return false;
    this.symbolsFor = key;
    try {
      const symbols = await this.transport.request('symbols', { uri: this.state.uri });
      this.editPanel.setSymbols(symbols);
      // A server that lists the meta-parameters in its results is the better source.
      if (!this.serverParams) {
        const { params, skipped } = paramsFromSymbols(symbols);
        this.state.setParamInfo(params);
        this.sliders.refreshParams();
        this.sliders.showSkippedParams(skipped);
      }
      const mode = modeFromSymbols(symbols);
      if (mode && mode !== this.state.mode) {
        this.state.mode = mode;
        return true;
      }
    } catch (e) {
      this.symbolsFor = '';
      this.showError(`symbols: ${(e as Error).message}`);
    }
    return false;
  }

  private summary(r: PreviewResult, ms: number | null): string {
    const m = r.model;
    const parts = [`${r.system || 'system'} (${r.mode})`, `seed ${r.seed}`];
    parts.push(`${m.triangles.toLocaleString()} triangles`, `${m.bones.length.toLocaleString()} bones`);
    // The server's `derive` time is the search in sample mode.
    const t = Object.entries(r.timings)
      .map(([k, v]) => `${k === 'derive' && r.mode === 'sample' ? 'sample' : k} ${v.toFixed(1)} ms`)
      .join(', ');
    if (t) parts.push(t);
    if (r.sample) {
      const s = r.sample;
      parts.push(
        isSearchResult(s) || s.generation === null
          ? `cost ${s.objective.toFixed(1)} after ${s.generations} generations${s.stoppedEarly ? ' (stopped by the time budget)' : ''}`
          : `generation ${s.generation + 1} of ${s.generations}: cost ${s.objective.toFixed(1)}`,
      );
    }
    if (ms !== null) parts.push(`on screen in ${ms.toFixed(0)} ms`);
    // The model's own warnings (why a preview is empty or lacks shapes); the help is in the tooltip.
    for (const w of r.warnings) parts.push(`⚠ ${w.code}: ${w.message}`);
    return parts.join(' · ');
  }

  setStatus(text: string, error = false, warning = false): void {
    $('status-text').textContent = text;
    if (error || !warning) $('status-text').title = '';
    $('status').classList.toggle('error', error);
    $('status').classList.toggle('warning', warning && !error);
  }

  /**
   * A failure keeps the last good model on screen (as the paper's editor does) and says why. `version`: the
   * document version whose text failed, where known. A model still on its way to the screen no longer puts its
   * status over it.
   */
  showError(text: string, version: number | null = null): void {
    this.shownVersion.answer();
    this.debug.lastError = text;
    this.debug.ready = true;
    $('overlay-msg').textContent = text;
    this.setStatus(text.split('\n')[0], true);
    this.debug.statusOf = { version, seed: null, error: text.split('\n')[0] };
  }

  // ------------------------------------------------------------- UI

  private wireUi(): void {
    $<HTMLInputElement>('show-geometry').addEventListener('change', (e) => this.scene.setShowGeometry((e.target as HTMLInputElement).checked));
    $<HTMLInputElement>('show-skeleton').addEventListener('change', (e) => this.scene.setShowSkeleton((e.target as HTMLInputElement).checked));
    $<HTMLInputElement>('seed').addEventListener('change', (e) => {
      this.state.setSeed(Number((e.target as HTMLInputElement).value));
      this.regrow();
    });
    $('next-variation').addEventListener('click', () => this.nextVariation());
    $('frame').addEventListener('click', () => {
      if (this.last?.model.bounds) this.scene.frame(this.last.model.bounds);
    });
    this.input.wire();
    this.picking.wire();
    this.curves.wire();
    this.playback.wire();
    this.picture.wire();
    this.gallery.wire();
    this.manipulation.wire();
  }

  nextVariation(): void {
    this.state.nextVariation();
    $<HTMLInputElement>('seed').value = String(this.state.seed);
    this.regrow();
  }

  // ------------------------------------------------------------- side panel

  refreshPanel(): void {
    $<HTMLInputElement>('seed').value = String(this.state.currentSeed ?? 0);
    this.playback.refreshScrubber();
    this.sliders.refreshParams();
    this.curves.refreshCurves();
    this.curves.refreshCurveList();
    this.picking.refreshRules();
  }
}

/** Run `f` in a task of its own, after the current one (a message, not a timer: timers may be clamped). */
function afterThisTask(f: () => void): void {
  const ch = new MessageChannel();
  ch.port1.onmessage = () => {
    ch.port1.close();
    f();
  };
  ch.port2.postMessage(null);
}

function main(): void {
  let transport: Transport;
  try {
    transport = detectTransport(globalThis as never);
  } catch (e) {
    document.body.textContent = (e as Error).message;
    return;
  }
  const app = new App(transport);
  app.start();
}

main();
