// What the preview page exposes for tests and for the curious
// (window.__grm): its interface, and the object the page builds over its
// state, its scene and its controllers.

import type { V3 } from './bezier.js';
import type { Ray } from './manip.js';
import type { ViewParams } from './messages.js';
import type { ManipResult, Origin, PickResult } from './protocol.js';
import type { App } from './main.js';

/** What the page exposes for tests and for the curious (window.__grm). */
export interface DebugInfo {
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

/** The page's debug info, read live from `page` where it changes (getters and functions), set by the page elsewhere. */
export function debugInfo(page: App): DebugInfo {
  const coalescer = page.coalescer;
  const scene = page.scene;
  const player = page.playback.player;
  return {
    ready: false,
    get spreading() {
      return page.picking.spreading > 0;
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
    previewParams: () => page.state.previewParams(),
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
    toScreen: (p) => page.scene.toScreen(p),
    rayAt: (x, y) => page.scene.pointerRay(x, y),
    curvePoints: (i) => page.state.curves?.curves[i]?.points.map((p) => [...p] as V3) ?? null,
    selectedCurve: () => page.state.selected,
    bonesList: () => page.last?.model.bones.map((b) => ({ base: b.base, tip: b.tip, origin: b.origin })) ?? [],
    origins: () => page.last?.origins ?? [],
    chosen: null,
    focusBones: 0,
    spreadBones: 0,
    renderer: page.scene.rendererName,
    antialias: page.scene.antialias,
    get curveDraws() {
      return scene.curveDraws;
    },
    coverage: [],
    refinements: null,
    get gapTubes() {
      return scene.gapTubes;
    },
    programs: () => page.scene.programIds(),
    lastView: null,
    views: 0,
    pictures: 0,
    lastPicture: null,
    pictureError: null,
    handles: () => page.manipulation.handleList(),
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
}
