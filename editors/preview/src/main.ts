// The preview page: wires the transport, the editing state, the 3D scene and
// the side panel together. Runs unchanged in a VS Code webview and in a
// browser served by `grmc view`.

import type { V3 } from './bezier.js';
import { Coalescer, type Delivery, SharedRequest } from './coalesce.js';
import { PARAM_KEYS, PARAM_RANGES, type ParamKey, checkParam, cloneSet, setProblem } from './curves.js';
import { type PlayAt, SearchPlayer, isSearchResult, playButtonView, scrubberView, showsUpdate } from './generation.js';
import { type NotificationMethod, SERVER_CANCELLED, type ViewParams, usableCamera, viewAngles } from './messages.js';
import { coverageLabel, refinementsLine } from './coverage.js';
import {
  type PlaneHandle,
  type Ray,
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
import { pictureFileName, pictureParams } from './picture.js';
import {
  type ManipBase,
  type ManipPart,
  type ManipResult,
  type ManipTarget,
  type Origin,
  type PickParams,
  type PickResult,
  type ScopeBox,
  type PreviewParams,
  type PreviewResult,
  type SampleInfo,
  type SceneModel,
  KEY,
  decodeManipResult,
  decodePick,
  decodeProvenance,
  decodePicture,
  decodePreview,
  decodePreviewUpdated,
  findPick,
  modeFromSymbols,
  paramsFromSymbols,
} from './protocol.js';
import { TreePanel } from './tree-panel.js';
import { EditPanel } from './edit-panel.js';
import { LayoutView, isLayoutUri } from './layout-view.js';
import { PreviewScene, ThumbnailRenderer } from './scene.js';
import { cutRect, scopeLines } from './scopes.js';
import { PageState, ShownVersion } from './state.js';
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

/** What the page exposes for tests and for the curious (window.__grm). */
interface DebugInfo {
  ready: boolean;
  /** A preview request is in flight or waiting. */
  readonly busy: boolean;
  /** Preview requests in flight (at most 2: a stale one being superseded and the current one). */
  readonly inFlight: number;
  /** An edit waits for its preview request (a newer state than any in flight). */
  readonly pending: boolean;
  /** Models handed to the scene so far (counted when delivered, before their frame). */
  delivered: number;
  /** Preview requests sent while another was in flight (a final edit that did not wait for a stale answer). */
  readonly supersedes: number;
  /** Answers to a request a newer one had replaced: dropped, never shown. */
  readonly staleAnswers: number;
  /** Answers that were the host's "superseded" (or "cancelled") error: never shown as errors. */
  readonly supersededAnswers: number;
  /** `performance.now()` at the end of the frame that showed the last model. */
  lastShownAt: number | null;
  /** The sampler's objective of the model shown (sample mode). */
  objective: number | null;
  /** The generation whose model is shown (sample mode, 0-based; null: the search's result or a derived model). */
  generation: number | null;
  /** Generations the shown model's search ran (sample mode; null: a derived model). */
  generations: number | null;
  /** The Play button is replaying the search. */
  readonly playing: boolean;
  /**
   * The steps of the last replay, in order: the scrubber position asked for (0-based; the last one is the
   * result), when it was asked and when its model was on screen (`performance.now()`; null: not yet, or never).
   */
  playSteps: { position: number; askedAt: number; shownAt: number | null }[];
  /** The parameters of the page's next preview request (for tests that ask the server themselves). */
  previewParams: () => unknown;
  /**
   * The parameters (as JSON, without `client` and `order`) of the request whose answer is the model shown; null when
   * the model came from the server's `grm/previewUpdated` (the options of the page's last live request).
   */
  shownParams: string | null;
  /** Models not shown because one of a newer document version was shown already. */
  olderVersions: number;
  /** Current requests sent again because the page's own older request superseded them (the server orders them: 0). */
  readonly resends: number;
  /** Models shown so far. */
  regrows: number;
  /** Milliseconds from an edit to the end of the frame that shows its model, per edit. */
  latencies: number[];
  lastLatencyMs: number | null;
  /**
   * Where the last edit's time went (ms): `host` (request to answer; `server total` of it is the
   * server's own time where the host tells it, `server ...` its stages), `decode`, `scene` (meshes),
   * `render` (the wait for the next animation frame and three.js's draw calls in it), `present` (the
   * rest of that frame: the browser's commit, after which the pixels exist).
   */
  lastBreakdown: Record<string, number>;
  meshCount: number;
  triangles: number;
  bones: number;
  /** The codes of the shown model's warnings (W0013, W0014). */
  warnings: string[];
  mode: string;
  seed: number | null;
  curves: number;
  lastPick: PickResult | null;
  /** Shape mode: segments drawn for the picked shape's scopes (0 when the toggle is off or nothing is picked). */
  readonly scopeSegments: number;
  lastError: string | null;
  /**
   * What the status line says, of which answer: the model of `version` with its `seed` (set with the frame that
   * shows it), or an error (`version`: the document version whose text failed, where known). `mode`, `seed` and
   * `lastError` above follow an answer as it comes; the status line, with its model's frame, a moment later (and
   * never for a model an answer after it replaced). A test waits for this, not for those.
   */
  statusOf: { version: number | null; seed: number | null; error: string | null } | null;
  saves: number;
  /** Screen position of a world point (for tests that aim at things). */
  toScreen: (p: V3) => [number, number];
  /** The ray from the camera through a screen position (what a drag projects). */
  rayAt: (x: number, y: number) => Ray;
  /** Control points of curve i. */
  curvePoints: (i: number) => V3[] | null;
  selectedCurve: () => number | null;
  /** Bone endpoints and origins of the current model. */
  bonesList: () => { base: V3; tip: V3; origin: number | null }[];
  origins: () => Origin[];
  /** The node chosen in the derivation tree (the page's panel or the editor's view) and what of it is highlighted. */
  chosen: { key: string; triangles: number; bones: number } | null;
  /** The focused rule's spread over other seeds is being asked for (the server's tables are other seeds' meanwhile). */
  readonly spreading: boolean;
  /** Bones highlighted for the focused rule, and bones of its spread over other seeds. */
  focusBones: number;
  spreadBones: number;
  /** The WebGL renderer, and whether the view is multisampled (not on a software renderer). */
  renderer: string;
  antialias: boolean;
  /** Times the guiding curves were redrawn, and the shader programs held (ids). */
  readonly curveDraws: number;
  /** Per guiding curve, how much of it the model shown follows (sample mode; [] otherwise), and the tinted gaps drawn. */
  coverage: { name: string | null; fraction: number; unreached: boolean; gaps: number; note: string }[];
  refinements: number | null;
  readonly gapTubes: number;
  programs: () => number[];
  /** The last view the page told the host (where the camera looks from, and the camera, once it rested), and how many it told. */
  lastView: ViewParams | null;
  views: number;
  /** Pictures made with "Save picture", the last one (its file name, size, and where the host saved it), and why the last attempt failed. */
  pictures: number;
  lastPicture: { name: string; width: number; height: number; generation?: number; saved?: string | null } | null;
  pictureError: string | null;
  /**
   * Direct manipulation (issue 28): the handles drawn (a picked shape's split planes, a picked bone's tip), with
   * where each is on screen, for tests that drag them.
   */
  handles: () => { kind: 'plane' | 'tip'; label: string; command: string | null; edge: number | null; at: number | V3; screen: [number, number] }[];
  /** The direct-manipulation status line. */
  manipStatus: string;
  /** What the page last said of a dragged part's provenance. */
  provenance: string;
  /** Picks answered (the user's clicks, not the page's own pick after a drag). */
  picks: number;
  /** Drags sent, and the last drag's, sketch's and write's answers (null: none yet, or it failed: see lastError). */
  drags: number;
  lastDrag: ManipResult | null;
  lastDragRequest: unknown;
  lastSketch: ManipResult | null;
  lastSketchRequest: unknown;
  lastWrite: ManipResult | null;
  /** Per applied drag, milliseconds from the release to the end of the frame that shows the regrown model, and the part of it until the answer came. */
  dragLatencies: number[];
  dragAnswerMs: number[];
  /**
   * Per applied drag, where the time went (ms): `answer` (release to the drag's answer: the server's solve and the
   * file written), `model` (release to the regrown model received and decoded (`grm/previewUpdated`); it may come before
   * the answer), then the page's `decode`, `scene`, `render` and `present` of that model, as `lastBreakdown`.
   */
  dragBreakdowns: Record<string, number>[];
  /** The sketched poses waiting for "Make slider…". */
  sketchPoses: number;
}

/** What the pointer is doing in the view: drawing a curve, dragging a control point or a handle, or a click. */
type Gesture =
  | { kind: 'none' }
  | { kind: 'draw'; points: V3[]; centre: V3; startX: number; startY: number }
  | { kind: 'drag'; curve: number; handle: number; through: V3; moved: boolean }
  /** A split plane's handle (index into the handles) along its axis: grabbed at `at0` with the pointer's ray `ray0`. */
  | { kind: 'plane'; handle: number; at0: number; ray0: Ray; facing: V3; at: number; moved: boolean }
  /**
   * A bone's tip, in the plane through it with normal `normal`: moved by what the pointer moved in that plane since
   * the grab (where the grabbing ray met it, `grab`), so a grip pressed off its centre does not jump. `grip`: the tip
   * itself, or the grips beside it: `length` (along the bone; `length` is the new length) or `angle` (the bone
   * turned about its base in that plane, its length kept; `degrees` the turn).
   */
  | { kind: 'tip'; grip: BoneGrip; tip0: V3; normal: V3; grab: V3 | null; at: V3; length: number | null; degrees: number; moved: boolean }
  | { kind: 'click'; x: number; y: number; t: number };

/** A bone's grips, in the order they are drawn (their index in the scene's grips). */
const BONE_GRIPS = ['tip', 'length', 'angle'] as const;
type BoneGrip = (typeof BONE_GRIPS)[number];

/** How long the camera must rest before the page tells the host its view (not on every frame of a drag). */
const VIEW_REST_MS = 200;

const $ = <T extends HTMLElement>(id: string): T => {
  const el = document.getElementById(id);
  if (!el) throw new Error(`missing #${id}`);
  return el as T;
};

class App {
  private readonly state = new PageState();
  private readonly scene: PreviewScene;
  private readonly coalescer: Coalescer<null, Fetched>;
  /** The preview request on its way, shared by a request for the same parameters. */
  private readonly previewRequest = new SharedRequest<Fetched>();
  private last: PreviewResult | null = null;
  private framed = false;
  private tool: 'orbit' | 'draw' = 'orbit';
  private showCurves = true;
  /** Shape mode: draw the picked shape's ancestors' scopes and split planes. */
  private showScopes = false;
  /** The scopes of the last shape picked. */
  private pickedScopes: ScopeBox[] | null = null;
  /**
   * Direct manipulation: what the last pick can drag (a shape's path's split planes, a bone's tip), the pick
   * request that found it (asked again once a drag's model is shown) and the picked part's key.
   */
  private manip:
    | { kind: 'planes'; handles: PlaneHandle[]; key: string | null; pick: PickParams }
    | { kind: 'tip'; key: string; bone: number; base: V3; tip: V3; parentDir: V3 | null; pick: PickParams }
    | null = null;
  /** The model the pick (scopes, handles) was made on (`modelSignature`): another model drops them. */
  private pickedFor = '';
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
  private dragWait: { releasedAt: number; version: number; answeredAt: number | null; repick: boolean } | null = null;
  private paramSignature = '';
  private gesture: Gesture = { kind: 'none' };
  private thumbs: ThumbnailRenderer | null = null;
  private galleryStart = 0;
  private galleryToken = 0;
  private spreadToken = 0;
  private curvesLoadedFor = '';
  /** The server lists the meta-parameters in its preview results. */
  private serverParams = false;
  /** The document version whose meta-parameters the sliders show. */
  private symbolsFor = '';
  private readonly debug: DebugInfo;
  private viewTimer: ReturnType<typeof setTimeout> | undefined;
  /** The last view told to the host (as JSON): an unchanged view is not told again. */
  private viewSent = '';
  /** The Play button's replay of the search, and the wait before its next step. */
  private readonly player = new SearchPlayer();
  private playTimer: ReturnType<typeof setTimeout> | undefined;
  /** This page's live requests: its id and the number of the last one (the server never lets an older one win). */
  private readonly client = clientId();
  private order = 0;
  /** The document version shown: a model of an older one (an answer that took longer than an update) is not shown. */
  private readonly shownVersion = new ShownVersion();

  /** The derivation tree panel (read only while it is open). */
  private readonly treePanel: TreePanel;
  /** The edit panel: persistent edits of the picked part (issue 27). */
  private readonly editPanel: EditPanel;

  /** The layout view, shown for a `NAME.layout.json` (issue 29). */
  private readonly layoutView: LayoutView;

  constructor(private readonly transport: Transport) {
    this.layoutView = new LayoutView({ request: (m, p) => this.transport.request(m, p) });
    document.body.append(this.layoutView.root);
    $('toolbar').append(this.layoutView.openButton);
    this.scene = new PreviewScene($<HTMLCanvasElement>('view'));
    this.treePanel = new TreePanel(
      $('tree-view'),
      (params) => this.transport.request('tree', { textDocument: { uri: this.state.uri }, ...(params as object) }),
      (n) => this.chooseTreeNode(n),
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
        this.stopPlay();
        this.showError(String((e as Error).message ?? e), e instanceof TransportError ? (e.version ?? null) : null);
      },
      () => performance.now(),
      {
        // A newer request superseded it: its answer is not an error to show.
        isSuperseded,
        // Superseded by a request that is not this page's (another page on the same document); a replay's step
        // would wait for it for ever.
        supersededElsewhere: () => {
          this.stopPlay();
          this.setStatus('another preview request for this document replaced this one');
        },
      },
    );
    const coalescer = this.coalescer;
    const scene = this.scene;
    const player = this.player;
    const page = this;
    this.debug = {
      ready: false,
      get spreading() {
        return page.spreading > 0;
      },
      get busy() {
        return coalescer.busy;
      },
      get inFlight() {
        return coalescer.inFlightCount;
      },
      get pending() {
        return coalescer.pending;
      },
      delivered: 0,
      get supersedes() {
        return coalescer.supersedes;
      },
      get staleAnswers() {
        return coalescer.staleAnswers;
      },
      get supersededAnswers() {
        return coalescer.supersededAnswers;
      },
      get resends() {
        return coalescer.resends;
      },
      shownParams: null,
      olderVersions: 0,
      lastShownAt: null,
      objective: null,
      generation: null,
      generations: null,
      get playing() {
        return player.playing;
      },
      playSteps: [],
      previewParams: () => this.state.previewParams(),
      regrows: 0,
      latencies: [],
      lastLatencyMs: null,
      lastBreakdown: {},
      meshCount: 0,
      triangles: 0,
      bones: 0,
      warnings: [],
      mode: '',
      seed: null,
      curves: 0,
      lastPick: null,
      get scopeSegments() {
        return scene.scopeSegments;
      },
      lastError: null,
      statusOf: null,
      saves: 0,
      toScreen: (p) => this.scene.toScreen(p),
      rayAt: (x, y) => this.scene.pointerRay(x, y),
      curvePoints: (i) => this.state.curves?.curves[i]?.points.map((p) => [...p] as V3) ?? null,
      selectedCurve: () => this.state.selected,
      bonesList: () => this.last?.model.bones.map((b) => ({ base: b.base, tip: b.tip, origin: b.origin })) ?? [],
      origins: () => this.last?.origins ?? [],
      chosen: null,
      focusBones: 0,
      spreadBones: 0,
      renderer: this.scene.rendererName,
      antialias: this.scene.antialias,
      get curveDraws() {
        return scene.curveDraws;
      },
      coverage: [],
      refinements: null,
      get gapTubes() {
        return scene.gapTubes;
      },
      programs: () => this.scene.programIds(),
      lastView: null,
      views: 0,
      pictures: 0,
      lastPicture: null,
      pictureError: null,
      handles: () => this.handleList(),
      manipStatus: '',
      provenance: '',
      picks: 0,
      drags: 0,
      lastDrag: null,
      lastDragRequest: null,
      lastSketch: null,
      lastSketchRequest: null,
      lastWrite: null,
      dragLatencies: [],
      dragAnswerMs: [],
      dragBreakdowns: [],
      sketchPoses: 0,
    };
    (globalThis as unknown as { __grm: DebugInfo }).__grm = this.debug;
    this.wireUi();
    this.transport.onNotification((m, p) => this.notified(m, p));
    this.scene.onViewChange = () => this.viewChanged();
    new ResizeObserver(() => this.scene.resize()).observe($('viewport'));
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
        this.paramSignature = '';
        this.curvesLoadedFor = '';
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
      this.refreshScrubber();
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
      if (p.uri !== this.state.uri || this.state.mode !== 'sample' || this.gesture.kind !== 'none') return;
      // Edited by hand or by another tool: the file wins over the page's copy.
      this.curvesLoadedFor = '';
      this.regrow();
    } else if (method === 'cursor' && typeof p.line === 'number') {
      this.setFocus({ line: p.line, character: typeof p.character === 'number' ? p.character : 0 });
    } else if (method === 'treeNode' && p.uri === this.state.uri) {
      // A node chosen in the editor's derivation view: its parts highlighted here, and revealed in the page's panel.
      const key = typeof p.key === 'string' ? p.key : null;
      void this.highlightNode(key);
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

  /** Ask for the preview of the current state. The mode is the first system's (from the document's symbols); a sample system's curves are loaded first. */
  private showSkippedParams(names: string[]): void {
    $('params-skipped').textContent = names.length ? `No slider for ${names.join(', ')}: give it a range of numbers (param x = 1 in 0 .. 2).` : '';
  }

  /** Before a request from the state: the mode (from the document's symbols) is known and a sample system's curves are loaded. */
  private async prepareRequest(): Promise<void> {
    if (!this.symbolsFor.startsWith(`${this.state.uri}@`)) await this.loadSymbols('first');
    if (this.state.mode === 'sample') await this.ensureCurves();
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
  private ordered(params: PreviewParams, order = ++this.order): PreviewParams {
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
        await this.ensureCurves();
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
   * "Save picture": the model of the current state (the parameters of the
   * preview request, so the picture is what the view shows), drawn by the
   * server through the preview's camera (zoom, pan and perspective as
   * shown) in the canvas' shape, longer side 1024 pixels. In a browser the
   * page downloads the PNG; in VS Code the extension has asked where to save
   * it and saved it (a webview cannot download), and says where.
   */
  private async savePicture(): Promise<void> {
    const uri = this.state.uri;
    const button = $<HTMLButtonElement>('save-picture');
    if (!uri || button.disabled) return;
    button.disabled = true;
    this.debug.pictureError = null;
    this.setStatus('making the picture…');
    try {
      await this.prepareRequest();
      const v = this.scene.view();
      const params = pictureParams(this.state.previewParams(), viewAngles(...v.direction), v, v.camera);
      const r = decodePicture(await this.transport.request('picture', params));
      const name = pictureFileName(uri);
      // A scrubbed search: the picture is of the generation shown, and says so.
      const generation = params.generation;
      const at = generation !== undefined ? `, generation ${generation + 1}` : '';
      if (r.png) {
        download(r.png, name);
        this.setStatus(`picture ${name} (${r.width}×${r.height}, seed ${r.seed}${at}) downloaded`);
      } else {
        this.setStatus(r.saved ? `picture saved to ${r.saved} (${r.width}×${r.height}, seed ${r.seed}${at})` : 'picture not saved');
      }
      this.debug.pictures++;
      this.debug.lastPicture = { name, width: r.width, height: r.height, ...(generation !== undefined ? { generation } : {}), ...(r.png ? {} : { saved: r.saved }) };
    } catch (e) {
      // Refused (e.g. the program has errors): said in the status line; the model on screen stays as it is.
      const msg = String((e as Error).message ?? e);
      this.debug.pictureError = msg;
      this.setStatus(`no picture: ${msg.split('\n')[0]}`, true);
      $('status-text').title = msg;
    } finally {
      button.disabled = false;
    }
  }

  private async ensureCurves(): Promise<void> {
    if (this.curvesLoadedFor === this.state.uri) return;
    const r = (await this.transport.request('loadCurves', { uri: this.state.uri })) as { path?: unknown; text?: unknown };
    this.state.loadCurves(typeof r.path === 'string' ? r.path : '', typeof r.text === 'string' ? r.text : null);
    this.curvesLoadedFor = this.state.uri;
    this.refreshCurves();
  }

  /**
   * The state changed: grow its model. A `final` edit (a click, a typed
   * value, a release) is sent at once even while a request for an older
   * state is in flight; the moves of a drag (`final` false) wait for its
   * answer and are merged.
   */
  private regrow(editedAt = performance.now(), final = true): void {
    if (!this.state.uri) return;
    // After an edit of the seed, a meta-parameter or the curves the scrubber is back at the end: shown at once.
    this.refreshScrubber();
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
  private released(editedAt: number, regrowIfIdle: boolean): void {
    if (!this.state.uri) return;
    if (this.coalescer.busy) this.coalescer.flush();
    else if (regrowIfIdle) this.regrow(editedAt);
  }

  private show(d: Delivery<PreviewResult>, breakdown: Record<string, number> = {}, params: string | null = null): void {
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
    this.last = r;
    // The open tree panel follows the model shown.
    if ($<HTMLDetailsElement>('tree-details').open) void this.treePanel.modelShown().catch(() => {});
    this.state.absorb(r);
    this.editPanel.modelShown(r.mode, r.origins, r.edits);
    if (r.params.length > 0 || r.paramsWithoutRange.length > 0) {
      this.serverParams = true;
      this.showSkippedParams(r.paramsWithoutRange);
    }
    $('overlay-msg').textContent = this.state.curvesError ? `curves: ${this.state.curvesError}` : '';
    // A drag's regrown model: a model of a newer version than the one on screen when it was released.
    const dragDone = this.dragWait && r.uri === this.state.uri && r.version > this.dragWait.version ? this.dragWait : null;
    if (dragDone) this.dragWait = null;
    const tBuild = performance.now();
    // The curves' stretches no bone follows, tinted (sample mode).
    this.scene.setGaps((r.sample?.coverage ?? []).flatMap((c) => c.gapPoints));
    this.refreshCurveList();
    this.scene.setModel(r.model, !this.framed, () => {
      const rendered = performance.now();
      // The chosen tree node's parts, on the new model (its key stays; its triangles are asked again).
      if (this.chosenKey) void this.highlightNode(this.chosenKey);
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
        const again = this.pickAfterShown;
        this.pickAfterShown = null;
        if (again) void this.pickAgain(again.pick, again.key);
        if (dragDone) {
          this.debug.dragLatencies.push(now - dragDone.releasedAt);
          this.debug.dragAnswerMs.push((dragDone.answeredAt ?? now) - dragDone.releasedAt);
          this.debug.dragBreakdowns.push({
            answer: (dragDone.answeredAt ?? now) - dragDone.releasedAt,
            model: d.editedAt - dragDone.releasedAt,
            ...this.debug.lastBreakdown,
          });
        }
        this.debug.meshCount = this.scene.meshCount;
        if (this.shownVersion.latest(answer)) {
          this.setStatus(this.summary(r, ms), false, r.warnings.length > 0);
          $('status-text').title = r.warnings
            .map((w) => [`${w.code}: ${w.message}`, ...w.notes.map((n) => `note: ${n}`), ...(w.help ? [`help: ${w.help}`] : [])].join('\n'))
            .join('\n');
          this.debug.statusOf = { version: r.version, seed: r.seed, error: null };
        }
        // On screen now: a replay asks for its next step.
        this.playShown(r, now);
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
    if (sig !== this.pickedFor) {
      const again = dragDone?.repick ? this.manip?.pick : undefined;
      const key = this.manip?.kind === 'planes' ? this.manip.key : this.manip?.kind === 'tip' ? this.manip.key : null;
      this.pickedFor = sig;
      this.pickedScopes = null;
      this.manip = null;
      this.posed = null;
      this.drawHandles();
      // Once the regrown model is on screen: its frame does not wait for the pick.
      if (again && key) this.pickAfterShown = { pick: again, key };
    }
    this.drawScopes();
    this.debug.ready = true;
    this.debug.lastError = null;
    this.showFocus(r);
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
        this.refreshParams();
        this.showSkippedParams(skipped);
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

  private setStatus(text: string, error = false, warning = false): void {
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
  private showError(text: string, version: number | null = null): void {
    this.shownVersion.answer();
    this.debug.lastError = text;
    this.debug.ready = true;
    $('overlay-msg').textContent = text;
    this.setStatus(text.split('\n')[0], true);
    this.debug.statusOf = { version, seed: null, error: text.split('\n')[0] };
  }

  // ------------------------------------------------------------- UI

  private wireUi(): void {
    $('tool-orbit').addEventListener('click', () => this.setTool('orbit'));
    $('tool-draw').addEventListener('click', () => this.setTool('draw'));
    $<HTMLInputElement>('show-geometry').addEventListener('change', (e) => this.scene.setShowGeometry((e.target as HTMLInputElement).checked));
    $<HTMLInputElement>('show-skeleton').addEventListener('change', (e) => this.scene.setShowSkeleton((e.target as HTMLInputElement).checked));
    $<HTMLInputElement>('show-scopes').addEventListener('change', (e) => {
      this.showScopes = (e.target as HTMLInputElement).checked;
      this.drawScopes();
    });
    $<HTMLInputElement>('show-curves').addEventListener('change', (e) => {
      this.showCurves = (e.target as HTMLInputElement).checked;
      this.refreshCurves();
    });
    $<HTMLInputElement>('seed').addEventListener('change', (e) => {
      this.state.setSeed(Number((e.target as HTMLInputElement).value));
      this.regrow();
    });
    $('next-variation').addEventListener('click', () => this.nextVariation());
    const scrubber = $<HTMLInputElement>('generation');
    scrubber.addEventListener('input', () => {
      // Moved by hand: a replay stops, the scrubber is where it was put.
      this.stopPlay();
      this.state.setGeneration(Number(scrubber.value), this.shownSample()?.generations ?? 0);
      // A move of the scrubber: merged with the next ones while a model is on its way, as the sliders' are.
      this.regrow(performance.now(), false);
    });
    // Released: the last position does not wait for a stale model.
    scrubber.addEventListener('change', () => this.released(performance.now(), false));
    // Back to the end, the search's result.
    scrubber.addEventListener('dblclick', () => {
      this.stopPlay();
      if (this.state.generation === null) return;
      this.state.showResult();
      this.regrow();
    });
    $('generation-play').addEventListener('click', () => this.togglePlay());
    // Space on the slider (which does nothing with it) plays and pauses, as in a video player.
    scrubber.addEventListener('keydown', (e) => {
      if (e.key !== ' ' || e.ctrlKey || e.metaKey || e.altKey) return;
      e.preventDefault();
      // Held down: one toggle, not one per repeat.
      if (!e.repeat) this.togglePlay();
    });
    $('frame').addEventListener('click', () => {
      if (this.last?.model.bounds) this.scene.frame(this.last.model.bounds);
    });
    const picture = $<HTMLButtonElement>('save-picture');
    // Where the PNG goes differs: a browser downloads it, VS Code asks where to save it.
    picture.title =
      this.transport.kind === 'vscode'
        ? 'Save a PNG of the model as the view shows it (longer side 1024 px); asks where to save it'
        : 'Download a PNG of the model as the view shows it (longer side 1024 px)';
    picture.addEventListener('click', () => void this.savePicture());
    $('gallery-open').addEventListener('click', () => this.openGallery(this.state.currentSeed ?? 0));
    $('gallery-more').addEventListener('click', () => this.openGallery(this.galleryStart + 9));
    $('gallery-close').addEventListener('click', () => this.closeGallery());
    $('curve-delete').addEventListener('click', () => this.deleteSelected());
    $('curve-undo').addEventListener('click', () => this.undoRedo(false));
    $('curve-redo').addEventListener('click', () => this.undoRedo(true));
    $<HTMLInputElement>('curve-name').addEventListener('change', (e) => {
      const sel = this.state.selected;
      if (sel === null) return;
      const input = e.target as HTMLInputElement;
      if (this.state.renameCurve(sel, input.value.trim())) this.curvesChanged(false);
      else input.value = this.state.curves?.curves[sel]?.name ?? '';
    });
    $<HTMLSelectElement>('rule-select').addEventListener('change', (e) => {
      const v = (e.target as HTMLSelectElement).value;
      const o = v === '' ? undefined : this.last?.origins[Number(v)];
      this.setFocus(o ? o.range.start : null);
    });
    // Direct manipulation: the sketch mode and its slider, and writing the sliders back (asked first).
    $<HTMLInputElement>('sketch-mode').addEventListener('change', (e) => this.setSketchMode((e.target as HTMLInputElement).checked));
    $('sketch-make').addEventListener('click', () => this.askSliderName());
    $('sketch-clear').addEventListener('click', () => {
      this.sketch.clear();
      this.posed = null;
      this.drawHandles();
      this.refreshSketch();
    });
    $('sketch-ok').addEventListener('click', () => void this.makeSlider());
    // Focus and context (shape mode): the picked shape a few levels down, the rest as proxies.
    $<HTMLInputElement>('context-on').addEventListener('change', () => this.setContext());
    $<HTMLInputElement>('context-depth').addEventListener('change', () => this.setContext());
    $<HTMLSelectElement>('context-node').addEventListener('change', () => this.setContext());
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
    const vp = $('viewport');
    // Capture phase: decide before OrbitControls (registered on the canvas) sees the press.
    vp.addEventListener('pointerdown', (e) => this.pointerDown(e), { capture: true });
    window.addEventListener('pointermove', (e) => this.pointerMove(e));
    window.addEventListener('pointerup', (e) => this.pointerUp(e));
    window.addEventListener('keydown', (e) => this.key(e));
  }

  private setTool(t: 'orbit' | 'draw'): void {
    this.tool = t;
    $('tool-orbit').classList.toggle('active', t === 'orbit');
    $('tool-draw').classList.toggle('active', t === 'draw');
    $('viewport').classList.toggle('drawing', t === 'draw');
  }

  private nextVariation(): void {
    this.state.nextVariation();
    $<HTMLInputElement>('seed').value = String(this.state.seed);
    this.regrow();
  }

  private key(e: KeyboardEvent): void {
    const target = e.target as HTMLElement | null;
    if (target && (target.tagName === 'INPUT' || target.tagName === 'SELECT' || target.tagName === 'TEXTAREA')) return;
    if ((e.ctrlKey || e.metaKey) && (e.key === 'z' || e.key === 'Z' || e.key === 'y')) {
      e.preventDefault();
      this.undoRedo(e.key === 'y' || e.shiftKey);
      return;
    }
    if (e.key === 'd' || e.key === 'D') this.setTool(this.tool === 'draw' ? 'orbit' : 'draw');
    else if (e.key === 'o' || e.key === 'O') this.setTool('orbit');
    else if (e.key === 'n' || e.key === 'N') this.nextVariation();
    else if (e.key === 'f' || e.key === 'F') {
      if (this.last?.model.bounds) this.scene.frame(this.last.model.bounds);
    } else if (e.key === 'Delete' || e.key === 'Backspace') this.deleteSelected();
    else if (e.key === 'Escape') {
      // The handles go with the selection.
      this.manip = null;
      this.posed = null;
      this.drawHandles();
      this.state.selected = null;
      this.refreshCurves();
      this.refreshPanel();
    }
  }

  // ------------------------------------------------------------- pointer

  private pointerDown(e: PointerEvent): void {
    if (e.button !== 0) return;
    if (this.grabHandle(e)) return;
    const handle = this.showCurves ? this.scene.handleAt(e.clientX, e.clientY) : null;
    const sel = this.state.selected;
    if (handle !== null && sel !== null && this.state.curves) {
      this.gesture = { kind: 'drag', curve: sel, handle, through: [...this.state.curves.curves[sel].points[handle]] as V3, moved: false };
      this.scene.controls.enabled = false;
      e.stopPropagation();
      return;
    }
    if (this.tool === 'draw' || e.shiftKey) {
      if (this.state.mode !== 'sample') {
        this.setStatus('curves guide sample systems (mode = sample); this system is derived', true);
        return;
      }
      const centre = this.scene.centre();
      const p = this.scene.planePoint(e.clientX, e.clientY, centre);
      this.gesture = { kind: 'draw', points: p ? [p] : [], centre, startX: e.clientX, startY: e.clientY };
      this.scene.controls.enabled = false;
      e.stopPropagation();
      return;
    }
    this.gesture = { kind: 'click', x: e.clientX, y: e.clientY, t: performance.now() };
  }

  private pointerMove(e: PointerEvent): void {
    const g = this.gesture;
    if (g.kind === 'plane' || g.kind === 'tip') {
      this.moveHandle(e);
    } else if (g.kind === 'draw') {
      const p = this.scene.planePoint(e.clientX, e.clientY, g.centre);
      if (p) {
        g.points.push(p);
        this.scene.setStroke(g.points);
      }
    } else if (g.kind === 'drag') {
      const p = this.scene.planePoint(e.clientX, e.clientY, g.through);
      if (p) {
        g.moved = true;
        this.state.moveControlPoint(g.curve, g.handle, p);
        this.curvesChanged(false, 'move');
      }
    }
  }

  private pointerUp(e: PointerEvent): void {
    const g = this.gesture;
    this.gesture = { kind: 'none' };
    this.scene.controls.enabled = true;
    if (g.kind === 'plane' || g.kind === 'tip') {
      this.releaseHandle(g);
    } else if (g.kind === 'draw') {
      this.scene.setStroke([]);
      const longEnough = Math.hypot(e.clientX - g.startX, e.clientY - g.startY) > 8 || g.points.length > 4;
      if (longEnough && this.state.addStroke(g.points) !== null) this.curvesChanged(true);
    } else if (g.kind === 'drag') {
      if (g.moved) this.curvesChanged(true, 'release');
    } else if (g.kind === 'click') {
      if (Math.hypot(e.clientX - g.x, e.clientY - g.y) < 5 && performance.now() - g.t < 600) this.click(e.clientX, e.clientY);
    }
  }

  private click(x: number, y: number): void {
    const curve = this.showCurves ? this.scene.curveAt(x, y) : null;
    if (curve !== null) {
      this.state.selected = curve;
      this.refreshCurves();
      this.refreshPanel();
      return;
    }
    if (this.state.selected !== null) {
      this.state.selected = null;
      this.refreshCurves();
      this.refreshPanel();
    }
    void this.pick(x, y);
  }

  private async pick(x: number, y: number): Promise<void> {
    const model = this.last?.model;
    if (!model) return;
    const params: PickParams = { textDocument: { uri: this.state.uri } };
    const hit = this.scene.pickPart(x, y);
    if (hit) {
      params.part = hit.part;
      params.triangle = hit.triangle;
    } else {
      const bone = this.scene.pickBone(x, y);
      if (bone === null) return;
      params.bone = bone;
    }
    try {
      const r = decodePick(await this.transport.request('pick', params));
      this.debug.lastPick = r;
      this.debug.picks++;
      if (r?.key && $<HTMLDetailsElement>('tree-details').open) void this.treePanel.reveal(r.key).catch(() => {});
      this.pickedFor = this.last ? modelSignature(this.last) : '';
      this.setManip(r, params);
      this.editPanel.picked(r);
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
      this.showError(`pick: ${(e as Error).message}`);
    }
  }

  /** Shape mode: the picked shape's path's scopes, when the toggle is on. */
  private drawScopes(): void {
    this.scene.setScopes(this.showScopes && this.pickedScopes ? scopeLines(this.pickedScopes) : null);
  }

  /** Highlight what the production at `pos` grows (null: none), with its spread over other seeds. */
  private setFocus(pos: { line: number; character: number } | null): void {
    // The cursor moves on every keystroke: regrow only when it enters another production.
    const before = this.originAt(this.state.focus);
    const after = this.originAt(pos);
    this.state.focus = pos && after !== null ? { line: pos.line, character: pos.character } : null;
    if (after !== before) this.regrow();
  }

  /** The production (index into the last result's origins) whose source range holds `pos`. */
  private originAt(pos: { line: number; character: number } | null): number | null {
    if (!pos || !this.last) return null;
    const le = (a: { line: number; character: number }, b: { line: number; character: number }) =>
      a.line < b.line || (a.line === b.line && a.character <= b.character);
    const i = this.last.origins.findIndex((o) => o.symbol !== 'axiom' && le(o.range.start, pos) && le(pos, o.range.end));
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

  private showFocus(r: PreviewResult): void {
    const token = ++this.spreadToken;
    const info = $('rule-info');
    if (!r.focus) {
      this.scene.setHighlight([], []);
      this.debug.focusBones = 0;
      this.debug.spreadBones = 0;
      const sel = $<HTMLSelectElement>('rule-select');
      if (!this.state.focus) sel.value = '';
      return;
    }
    const f = r.focus;
    const bones = this.focusedBones(r.model, f.origin);
    this.debug.focusBones = bones.length;
    this.scene.setHighlight(bones, []);
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
    this.spreading++;
    try {
      await this.loadSpreadSeeds(token, r, current);
    } finally {
      this.spreading--;
      // The server's tables are this model's again: the tree panel and the chosen node's parts read anew.
      if (this.spreading === 0) {
        if ($<HTMLDetailsElement>('tree-details').open) void this.treePanel.modelShown().catch(() => {});
        if (this.chosenKey) void this.highlightNode(this.chosenKey);
      }
    }
  }

  /** Requests in flight for the focus spread (their models are not the one shown). */
  private spreading = 0;

  private async loadSpreadSeeds(token: number, r: PreviewResult, current: number[]): Promise<void> {
    const seeds = 4;
    const segs: [V3, V3][] = [];
    const base = this.state.previewParams();
    for (let k = 1; k <= seeds; k++) {
      // Started while the focused model is being delivered: stop only for a newer edit.
      if (token !== this.spreadToken || this.coalescer.pending) return;
      try {
        const o = decodePreview(await this.transport.request('preview', { ...base, seed: (r.seed + k) >>> 0, live: false }));
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
      if (this.coalescer.busy) return;
      const again = decodePreview(await this.transport.request('preview', this.ordered(base)));
      // A change of the edits file (an edit made in the panel) regrows the same version with other edits: news too.
      const newEdits = JSON.stringify(again.edits) !== JSON.stringify(this.last?.edits ?? null);
      if ((again.version !== r.version || newEdits) && token === this.spreadToken && !this.coalescer.busy) {
        this.show({ result: again, editedAt: performance.now(), final: true });
        return;
      }
    } catch {
      // The next edit or request registers the live preview again.
    }
    if (token !== this.spreadToken) return;
    this.debug.spreadBones = segs.length;
    this.scene.setHighlight(current, segs);
  }

  // ------------------------------------------------------------- direct manipulation

  /** What a pick makes draggable: a shape's path's split planes (shape mode), a bone's tip (derive mode). */
  private setManip(r: PickResult | null, pick: PickParams, quiet = false): void {
    this.manip = null;
    this.posed = null;
    const model = this.last?.model;
    if (r?.shape) {
      const handles = planeHandles(r.shape.scopes);
      this.manip = { kind: 'planes', handles, key: r.key, pick };
      const what = handles.length
        ? `${handles.length} split plane${handles.length === 1 ? '' : 's'} to drag: release one to rewrite the grammar's numbers`
        : r.shape.scopes.some((s) => s.command && s.axis !== null)
          ? 'the server names no split planes to drag (no key and planes in its scopes)'
          : 'no split or repeat above this shape: nothing to drag';
      if (!quiet) this.setManipStatus(what);
    } else if (r && model && this.state.mode === 'derive' && r.key && KEY.test(r.key)) {
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
      const r = decodePick(await this.transport.request('pick', pick));
      if (!r || r.key !== key || this.manip) return;
      this.debug.lastPick = r;
      if (r.shape) this.pickedScopes = r.shape.scopes;
      // The drag's answer stays in the status line.
      this.setManip(r, pick, true);
      this.drawScopes();
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
      this.scene.setHandles(null);
      return;
    }
    const g = this.gesture;
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
    this.scene.setHandles({ grips, lines, activeLines });
  }

  /** The key of the node chosen in the derivation tree (its parts highlighted), null: none. */
  private chosenKey: string | null = null;

  /**
   * Highlight the parts a tree node's subtree drew (`grm/tree`'s `drawn`): its triangles tinted, its bones as lines.
   * A key the model shown lacks (or no key) clears the highlight.
   */
  private async highlightNode(key: string | null): Promise<void> {
    this.chosenKey = key;
    // The focus spread's requests replace the server's tree with other seeds' for a while: asked again at its end.
    if (key && this.spreading > 0) return;
    const version = this.last?.version;
    let drawn: { triangles: number[]; bones: number[] } = { triangles: [], bones: [] };
    if (key) {
      try {
        const a = (await this.transport.request('tree', { textDocument: { uri: this.state.uri }, key, drawn: true })) as {
          version?: number;
          drawn?: { triangles?: unknown; bones?: unknown };
        } | null;
        const nums = (v: unknown): number[] => (Array.isArray(v) ? v.filter((x): x is number => typeof x === 'number') : []);
        if (a?.drawn) drawn = { triangles: nums(a.drawn.triangles), bones: nums(a.drawn.bones) };
        // Chosen again, or another model shown meanwhile (its answer is that model's): the later call draws.
        if (key !== this.chosenKey || version !== this.last?.version || (a && a.version !== version)) return;
      } catch {
        // No tree for this preview (or it is being regrown): nothing highlighted.
      }
    }
    if (key !== this.chosenKey) return;
    const lit = this.scene.setChosen(drawn.triangles, drawn.bones);
    this.debug.chosen = key ? { key, ...lit } : null;
  }

  /** A node chosen in the tree panel: its parts highlighted, its rule said in the panel and shown in the editor (where the host has one). */
  private chooseTreeNode(n: { label: string; key: string; uri?: string; range?: { start: { line: number; character: number } } }): void {
    void this.highlightNode(n.key);
    const info = $('rule-info');
    info.textContent = n.range ? `${n.label}: made by the rule at line ${n.range.start.line + 1}` : n.label;
    info.title = `key ${n.key}`;
    if (n.uri && n.range && this.transport.kind === 'vscode') {
      void this.transport.request('reveal', { uri: n.uri, line: n.range.start.line, character: n.range.start.character }).catch(() => {});
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
    const before = JSON.stringify(this.state.context);
    this.state.context = next;
    if (JSON.stringify(next) !== before) this.regrow();
  }

  /** The handles with their screen positions (window.__grm.handles, for tests). */
  private handleList(): ReturnType<DebugInfo['handles']> {
    const m = this.manip;
    if (!m) return [];
    if (m.kind === 'planes') {
      return m.handles.map((h) => ({ kind: 'plane' as const, label: h.label, command: h.command, edge: h.edge, at: h.at, screen: this.scene.toScreen(planeCentre(h)) }));
    }
    const tip = { kind: 'tip' as const, label: 'tip', command: null, edge: null, at: [...m.tip] as V3, screen: this.scene.toScreen(m.tip) };
    const side = this.boneSideGrips(m, m.tip);
    if (!side) return [tip];
    return [tip, ...(['length', 'angle'] as const).map((label) => ({ kind: 'tip' as const, label, command: null, edge: null, at: side[label], screen: this.scene.toScreen(side[label]) }))];
  }

  /** A picked bone's length and angle grips for its tip at `at` (in the plane a drag of it moves in). */
  private boneSideGrips(m: { base: V3; parentDir: V3 | null }, at: V3): { length: V3; angle: V3 } | null {
    const g = this.gesture;
    const normal = g.kind === 'tip' ? g.normal : tipDragNormal(m.base, at, m.parentDir, this.scene.viewDirection());
    return boneGrips(m.base, at, normal);
  }

  /** A press on a handle's grip starts its drag (true); the orbit controls stay still until the release. */
  private grabHandle(e: PointerEvent): boolean {
    const m = this.manip;
    if (!m) return false;
    const i = this.scene.gripAt(e.clientX, e.clientY);
    if (i === null) return false;
    if (m.kind === 'planes') {
      const h = m.handles[i];
      if (!h) return false;
      // A sketched pose is dragged on from where it was dropped.
      const at0 = this.posed && 'plane' in this.posed && this.posed.plane === i ? this.posed.at : h.at;
      this.gesture = { kind: 'plane', handle: i, at0, ray0: this.scene.pointerRay(e.clientX, e.clientY), facing: this.scene.viewDirection(), at: at0, moved: false };
    } else {
      const tip0 = this.posed && 'tip' in this.posed ? this.posed.tip : m.tip;
      const normal = tipDragNormal(m.base, tip0, m.parentDir, this.scene.viewDirection());
      const grip = BONE_GRIPS[i] ?? 'tip';
      const grab = rayPlane(this.scene.pointerRay(e.clientX, e.clientY), normal, tip0);
      this.gesture = { kind: 'tip', grip, tip0, normal, grab, at: tip0, length: null, degrees: 0, moved: false };
    }
    this.scene.controls.enabled = false;
    e.stopPropagation();
    e.preventDefault();
    const what = this.manipTarget(this.gesture);
    if (what) void this.showProvenance(what.part);
    return true;
  }

  /** While a handle is dragged: which source numbers place its part (`grm/provenance`, asked once per part and model). */
  private async showProvenance(part: ManipPart): Promise<void> {
    if (this.provenanceFor !== this.pickedFor) {
      this.provenance.clear();
      this.provenanceFor = this.pickedFor;
    }
    const key = JSON.stringify(part);
    let text = this.provenance.get(key);
    if (text === undefined) {
      try {
        text = provenanceSummary(decodeProvenance(await this.transport.request('provenance', { ...this.manipBase(), part })));
      } catch {
        // Not a failure of the drag: the release asks the server anyway.
        return;
      }
      if (this.provenanceFor === this.pickedFor) this.provenance.set(key, text);
    }
    this.debug.provenance = text;
    // Only while this part's drag goes on: the release's answer is what the line says then.
    const g = this.gesture;
    const now = this.manipTarget(g);
    if (now && JSON.stringify(now.part) === key) this.setManipStatus(text);
  }

  /** A move of a handle's drag: the plane along its axis, the tip in the view plane through it. */
  private moveHandle(e: PointerEvent): void {
    const g = this.gesture;
    const m = this.manip;
    const ray = this.scene.pointerRay(e.clientX, e.clientY);
    if (g.kind === 'plane' && m?.kind === 'planes') {
      const h = m.handles[g.handle];
      const at = h ? dragPlaneAt(h, g.at0, g.ray0, ray, g.facing) : null;
      if (at === null || !h) return;
      g.at = at;
      g.moved = true;
      this.setStatus(`${h.label} plane ${h.edge}: ${short(h.at)} → ${short(at)}`);
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
        this.setStatus(`length ${short(l0)} → ${short(len)}`);
      } else if (g.grip === 'angle') {
        const r = g.grab ? rotatedTip(m.base, g.tip0, g.normal, g.grab, p) : null;
        if (!r) return;
        g.at = r.tip;
        g.degrees = r.degrees;
        this.setStatus(`turned ${short(r.degrees)}° → tip (${g.at.map(short).join(', ')})`);
      } else {
        g.at = g.grab ? [g.tip0[0] + p[0] - g.grab[0], g.tip0[1] + p[1] - g.grab[1], g.tip0[2] + p[2] - g.grab[2]] : p;
        this.setStatus(`tip → (${g.at.map(short).join(', ')})`);
      }
      g.moved = true;
    } else {
      return;
    }
    this.drawHandles();
  }

  /** The release of a handle's drag: a pose for the sketch (sketch mode), else a drag sent to the server. */
  private releaseHandle(g: Gesture): void {
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
    const p = this.state.previewParams();
    const base: ManipBase = { textDocument: { uri: this.state.uri } };
    const system = this.last?.system || this.state.system;
    if (system) base.system = system;
    const seed = this.last?.seed ?? p.seed;
    if (seed !== undefined) base.seed = seed;
    if (p.params) base.params = p.params;
    return base;
  }

  private async sendDrag(part: ManipPart, target: ManipTarget, releasedAt: number): Promise<void> {
    const version = this.last?.version;
    const params = { ...this.manipBase(), ...(version !== undefined ? { version } : {}), part, target };
    this.debug.drags++;
    this.debug.lastDragRequest = params;
    this.debug.lastDrag = null;
    // The model regrown from the edit may come before the answer (the file is written before the answer is sent).
    const wait = version !== undefined ? { releasedAt, version, answeredAt: null as number | null, repick: true } : null;
    this.dragWait = wait;
    this.setManipStatus(`solving for the ${describeTarget(target)}…`);
    try {
      const r = decodeManipResult(await this.transport.request('drag', params), 'drag');
      if (wait) wait.answeredAt = performance.now();
      this.debug.lastDrag = r;
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
      this.debug.lastDrag = null;
      if (!this.sketchMode) this.posed = null;
      this.drawHandles();
      this.setManipStatus('');
      this.showError(`drag: ${(e as Error).message}`);
    }
  }

  private setManipStatus(text: string, error = false): void {
    this.debug.manipStatus = text;
    const el = $('manip-status');
    el.textContent = text;
    el.classList.toggle('error', error);
    if (text) this.setStatus(text, error);
  }

  /** The sketch panel: its poses, and whether a slider can be made (a pose at t = 1). */
  private refreshSketch(): void {
    $('sketch-panel').hidden = !this.sketchMode;
    this.debug.sketchPoses = this.sketch.size;
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
    this.debug.lastSketchRequest = params;
    this.debug.lastSketch = null;
    $('sketch-form').hidden = true;
    this.setManipStatus(`fitting slider ${name}…`);
    try {
      const r = decodeManipResult(await this.transport.request('sketch', params), 'sketch');
      this.debug.lastSketch = r;
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
      this.showError(`sketch: ${(e as Error).message}`);
    }
  }

  /** "Write slider values": what would be written, asked in the page first (never silently). */
  private askWriteParams(): void {
    const { params, prompt } = paramsToWrite(this.state.paramInfo, (n) => this.state.paramValue(n));
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
    const { params } = paramsToWrite(this.state.paramInfo, (n) => this.state.paramValue(n));
    if (Object.keys(params).length === 0) return;
    const base = this.manipBase();
    this.debug.lastWrite = null;
    try {
      const r = decodeManipResult(await this.transport.request('writeParams', { textDocument: base.textDocument, ...(base.system ? { system: base.system } : {}), params }), 'writeParams');
      this.debug.lastWrite = r;
      const s = manipSummary(r, 'slider values written');
      this.setManipStatus(s.text, s.error);
    } catch (e) {
      this.showError(`writeParams: ${(e as Error).message}`);
    }
  }

  // ------------------------------------------------------------- curves

  private deleteSelected(): void {
    const sel = this.state.selected;
    if (sel === null) return;
    this.state.deleteCurve(sel);
    this.curvesChanged(true);
  }

  /**
   * The curves changed: redraw, regrow; `save` ends the edit (one undo step)
   * and writes the curves file. `how`: a `move` of a drag (merged with the
   * next moves while a model is on its way), the `release` of a drag (no
   * new state: what still waits is sent at once), or any other `edit`
   * (sent at once).
   */
  private curvesChanged(save: boolean, how: 'edit' | 'move' | 'release' = 'edit'): void {
    const editedAt = performance.now();
    if (save) this.state.finishEdit();
    this.refreshCurves();
    this.refreshPanel();
    if (how === 'release') this.released(editedAt, true);
    else this.regrow(editedAt, how === 'edit');
    if (save) void this.saveCurves();
  }

  private undoRedo(redo: boolean): void {
    if (this.state.mode !== 'sample' || this.gesture.kind !== 'none') return;
    if (redo ? this.state.redo() : this.state.undo()) this.curvesChanged(true);
  }

  private async saveCurves(): Promise<void> {
    const out = this.state.curvesText();
    if ('error' in out) {
      this.setStatus(out.error, true);
      return;
    }
    try {
      await this.transport.request('saveCurves', { uri: this.state.uri, text: out.text });
      this.debug.saves++;
    } catch (e) {
      this.showError(`saving the curves: ${(e as Error).message}`);
    }
  }

  private refreshCurves(): void {
    this.scene.setCurves(this.showCurves ? this.state.beziers() : [], this.showCurves ? this.state.selected : null);
    this.debug.curves = this.state.curves?.curves.length ?? 0;
  }

  // ------------------------------------------------------------- side panel

  private refreshPanel(): void {
    $<HTMLInputElement>('seed').value = String(this.state.currentSeed ?? 0);
    this.refreshScrubber();
    this.refreshParams();
    this.refreshCurves();
    this.refreshCurveList();
    this.refreshRules();
  }

  /** The last search's sample info (its number of generations), if the last model is a sample system's. */
  private shownSample(): SampleInfo | null {
    return this.last?.mode === 'sample' ? this.last.sample : null;
  }

  /** The generation scrubber: hidden in derive mode; its range is the last search's generations, its position the state's. */
  private refreshScrubber(): void {
    // Anything that moved the scrubber (a new search puts it back at the end) ends a replay.
    if (this.player.playing && !this.player.stillAt(this.playAt())) this.stopPlay();
    const v = scrubberView(this.state.mode, this.shownSample(), this.state.generation);
    $('generation-section').hidden = v.hidden;
    const slider = $<HTMLInputElement>('generation');
    // The range first: a value past the old maximum would be clamped.
    slider.max = String(v.max);
    slider.value = String(v.value);
    slider.disabled = v.disabled;
    slider.title = v.title;
    $('generation-value').textContent = v.label;
    this.refreshPlayButton();
  }

  private refreshPlayButton(): void {
    const v = playButtonView(scrubberView(this.state.mode, this.shownSample(), this.state.generation), this.player.playing);
    const button = $<HTMLButtonElement>('generation-play');
    button.textContent = v.label;
    button.title = v.title;
    button.disabled = v.disabled;
  }

  // ------------------------------------------------------------- replay

  /** Where the scrubber is, for the replay. */
  private playAt(): PlayAt {
    return { generation: this.state.generation, key: this.state.searchKey };
  }

  /** Play: replay the search from the scrubber's position (from the first generation at the end); Pause: stop where it is. */
  private togglePlay(): void {
    if (this.player.playing) {
      this.stopPlay();
      return;
    }
    if (this.state.mode !== 'sample' || !this.state.uri) return;
    const n = this.shownSample()?.generations ?? 0;
    const first = this.player.play(this.playAt(), n, performance.now());
    if (first === null) return;
    this.debug.playSteps = [];
    this.playStep(first, n);
  }

  /** Ask for the model of scrubber position `position` of a search of `generations` (the player has marked it asked). */
  private playStep(position: number, generations: number): void {
    this.state.setGeneration(position, generations);
    this.debug.playSteps.push({ position, askedAt: performance.now(), shownAt: null });
    // A final edit, sent at once: after the first step the last one's model is on screen, so nothing of this
    // page's is on its way; for the first, one on its way is for an older state.
    this.regrow();
  }

  /** A model is on screen (at `now`): during a replay, the next step after its wait, or the end. */
  private playShown(r: PreviewResult, now: number): void {
    if (!this.player.playing) return;
    const model = r.sample && !isSearchResult(r.sample) ? r.sample.generation : null;
    const a = this.player.shown(model, this.playAt(), now);
    if (a.kind === 'wait') return;
    if (a.kind === 'next' || a.kind === 'done') {
      const step = this.debug.playSteps.at(-1);
      if (step) step.shownAt = now;
    }
    if (a.kind === 'next') {
      clearTimeout(this.playTimer);
      this.playTimer = setTimeout(() => {
        const position = this.player.advance(this.playAt(), performance.now());
        if (position === null) this.stopPlay();
        else this.playStep(position, this.player.generations);
      }, a.delayMs);
    } else {
      this.stopPlay();
    }
  }

  /** The replay ends (Pause, the end, a failure, the page moved): the scrubber stays at the generation shown or asked for. */
  private stopPlay(): void {
    clearTimeout(this.playTimer);
    this.playTimer = undefined;
    this.player.stop();
    this.refreshPlayButton();
  }

  private refreshParams(): void {
    const info = this.state.paramInfo;
    const sig = JSON.stringify(info.map((p) => [p.name, p.min, p.max]));
    const box = $('params');
    if (sig !== this.paramSignature) {
      this.paramSignature = sig;
      box.replaceChildren();
      if (info.length === 0) {
        box.innerHTML = '<p class="hint">The grammar declares no <code>param</code>.</p>';
      }
      for (const p of info) {
        const row = document.createElement('div');
        row.className = 'param';
        const head = document.createElement('div');
        head.className = 'name';
        const name = document.createElement('span');
        name.textContent = p.name;
        const val = document.createElement('span');
        val.className = 'value';
        head.append(name, val);
        const slider = document.createElement('input');
        slider.type = 'range';
        slider.min = String(p.min);
        slider.max = String(p.max);
        slider.step = String((p.max - p.min) / 200 || 1);
        slider.dataset.param = p.name;
        slider.addEventListener('input', () => {
          this.state.setParam(p.name, Number(slider.value));
          val.textContent = formatValue(Number(slider.value));
          // A move of the slider: merged with the next ones while a model is on its way.
          this.regrow(performance.now(), false);
        });
        // Released: the last value does not wait for a stale model.
        slider.addEventListener('change', () => this.released(performance.now(), false));
        slider.addEventListener('dblclick', () => {
          this.state.setParam(p.name, p.default);
          this.refreshParams();
          this.regrow();
        });
        row.append(head, slider);
        box.append(row);
      }
    }
    $('write-params').hidden = info.length === 0;
    for (const slider of box.querySelectorAll<HTMLInputElement>('input[type=range]')) {
      const v = this.state.paramValue(slider.dataset.param ?? '');
      if (v !== undefined && document.activeElement !== slider) slider.value = String(v);
      const label = slider.parentElement?.querySelector('.value');
      if (label && v !== undefined) label.textContent = formatValue(v);
    }
  }

  private refreshCurveList(): void {
    $<HTMLButtonElement>('curve-undo').disabled = !this.state.canUndo;
    $<HTMLButtonElement>('curve-redo').disabled = !this.state.canRedo;
    const list = $('curve-list');
    list.replaceChildren();
    const set = this.state.curves;
    $('curves-section').hidden = this.state.mode !== 'sample' && !set;
    set?.curves.forEach((c, i) => {
      const el = document.createElement('div');
      el.className = 'curve' + (i === this.state.selected ? ' selected' : '');
      el.textContent = c.name ?? `curve ${i}`;
      // How much of it the model shown follows (the last result's, when it was grown with these curves).
      const cov = this.last?.sample?.coverage;
      const cv = cov && cov.length === set.curves.length ? cov[i] : undefined;
      if (cv) {
        const tag = document.createElement('span');
        tag.className = 'coverage' + (cv.unreached ? ' unreached' : '');
        tag.textContent = coverageLabel(cv);
        tag.title = cv.note;
        el.append(' ', tag);
      }
      el.addEventListener('click', () => {
        this.state.selected = i;
        this.refreshCurves();
        this.refreshPanel();
      });
      list.append(el);
    });
    // Beside the coverage: the refinement rounds the search ran for it.
    const refined = set?.curves.length ? refinementsLine(this.last?.sample) : null;
    if (refined) list.append(refined);
    const sel = this.state.selected;
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
            const q = [...(this.state.curves?.curves[sel]?.points[k] ?? p)] as V3;
            q[axis] = v;
            this.state.moveControlPoint(sel, k, q);
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
    const c = this.state.curves?.curves[curve];
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
      const set = this.state.curves;
      if (!problem && set?.curves[curve]) {
        const next = cloneSet(set);
        (next.curves[curve].params as unknown as Record<string, unknown>)[key] = value;
        problem = setProblem(next);
      }
      row.classList.toggle('invalid', problem !== null);
      row.title = problem ?? '';
      if (problem) return;
      this.state.setCurveParam(curve, key, value as never);
      this.curvesChanged(true);
    });
    row.append(input);
    return row;
  }

  private refreshRules(): void {
    const sel = $<HTMLSelectElement>('rule-select');
    const origins = this.last?.origins ?? [];
    // Where the editor's cursor cannot drive the highlight (a browser), a list picks the rule.
    sel.hidden = this.transport.kind === 'vscode' || origins.length === 0;
    const sig = origins.map((o) => `${o.range.start.line}:${o.symbol}`).join(',');
    if (sel.dataset.sig === sig) return;
    sel.dataset.sig = sig;
    sel.replaceChildren(new Option('highlight a rule…', ''));
    origins.forEach((o, i) => {
      if (o.symbol !== 'axiom') sel.append(new Option(`line ${o.range.start.line + 1}: ${o.symbol}`, String(i)));
    });
    if (this.state.focus && this.last?.focus) sel.value = String(this.last.focus.origin);
  }

  // ------------------------------------------------------------- gallery

  private async openGallery(start: number): Promise<void> {
    const token = ++this.galleryToken;
    this.galleryStart = start;
    $('gallery').hidden = false;
    $('gallery-range').textContent = `seeds ${start} to ${start + 8}`;
    const grid = $('gallery-grid');
    grid.replaceChildren();
    this.thumbs ??= new ThumbnailRenderer(160);
    const cam = this.scene.camera.position.clone().sub(this.scene.controls.target);
    for (let i = 0; i < 9; i++) {
      const seed = start + i;
      const fig = document.createElement('figure');
      fig.className = seed === this.state.currentSeed ? 'current' : '';
      fig.dataset.seed = String(seed);
      const img = document.createElement('img');
      img.alt = `seed ${seed}`;
      const cap = document.createElement('figcaption');
      cap.textContent = `seed ${seed}…`;
      fig.append(img, cap);
      fig.addEventListener('click', () => {
        this.state.setSeed(seed);
        this.closeGallery();
        this.regrow();
      });
      grid.append(fig);
    }
    for (let i = 0; i < 9; i++) {
      if (token !== this.galleryToken) return;
      const seed = start + i;
      const fig = grid.children[i] as HTMLElement;
      const cap = fig.querySelector('figcaption') as HTMLElement;
      try {
        // Other seeds are other searches: their results, not the scrubbed generation.
        const r = decodePreview(await this.transport.request('preview', { ...this.state.previewParams(), seed, focus: undefined, generation: undefined, live: false }));
        if (token !== this.galleryToken) return;
        (fig.querySelector('img') as HTMLImageElement).src = this.thumbs.render(r.model, [cam.x, cam.y, cam.z]);
        cap.textContent = `seed ${seed}`;
      } catch (e) {
        cap.textContent = `seed ${seed}: ${(e as Error).message}`;
      }
    }
    // The server's live preview follows the last request: make it the current state again.
    this.regrow();
  }

  private closeGallery(): void {
    this.galleryToken++;
    $('gallery').hidden = true;
  }
}

/** What makes one model another: its document version, system, seed and meta-parameter values (not a rule's highlight). */
function modelSignature(r: PreviewResult): string {
  return JSON.stringify([r.uri, r.version, r.system, r.seed, r.params.map((p) => [p.name, p.value])]);
}

/** Download bytes as a file: a click on a link to a blob with `download` set (browsers; not in a VS Code webview). */
function download(bytes: Uint8Array, name: string): void {
  // A copy into a fresh ArrayBuffer: Blob takes no view of a buffer that could be shared.
  const url = URL.createObjectURL(new Blob([new Uint8Array(bytes)], { type: 'image/png' }));
  const a = document.createElement('a');
  a.href = url;
  a.download = name;
  a.hidden = true;
  document.body.append(a);
  a.click();
  a.remove();
  // Revoked later, not at once: the browser reads the blob after the click returns.
  setTimeout(() => URL.revokeObjectURL(url), 60_000);
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

function formatValue(x: number): string {
  if (!Number.isFinite(x)) return String(x);
  return Number.isInteger(x) ? String(x) : String(Number(x.toFixed(4)));
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
