// Messages between the preview page and its host (the VS Code extension over
// `postMessage`, or `grmc view` over HTTP). Shared by both sides: the
// extension imports this file too.

/** What the page asks of its host. */
export type Method =
  /** Grow the model: `PreviewParams` -> `PreviewResult` (LSP `grm/preview`). */
  | 'preview'
  /** Which rule made a part: `PickParams` -> `PickResult | null` (LSP `grm/pick`). */
  | 'pick'
  /**
   * A PNG of the model: `PictureParams` -> the `grm/picture` result, whose
   * `png` (base64) the page downloads. A VS Code webview cannot download:
   * there the extension asks where to save the PNG, writes it, and answers
   * the result with `saved` (the path, null if the user cancelled) in place
   * of `png`.
   */
  | 'picture'
  /** The document's symbols (LSP `textDocument/documentSymbol`): `{ uri }` -> `DocumentSymbol[]`; the page reads the meta-parameters from them. */
  | 'symbols'
  /** Read the grammar's curves file: `{ uri }` -> `{ path, text }` (`text` null: no file yet). */
  | 'loadCurves'
  /** Write the grammar's curves file: `{ uri, text }` -> `{ path }`. */
  | 'saveCurves'
  /** Show a rule in the editor: `{ uri, line, character }` -> `{}`. */
  | 'reveal'
  /** Direct manipulation (issue 28): the source numbers that place a part, `ProvenanceParams` (LSP `grm/provenance`). */
  | 'provenance'
  /** Move a part by rewriting the grammar's numbers: `DragParams` -> `ManipResult` (LSP `grm/drag`; the server applies the edit). */
  | 'drag'
  /** A new slider from sketched poses: `SketchParams` -> `ManipResult` (LSP `grm/sketch`). */
  | 'sketch'
  /** Write slider values back as the `param` defaults, after the page asked the user: `WriteParamsParams` -> `ManipResult` (LSP `grm/writeParams`). */
  | 'writeParams'
  /** The derivation tree of the last preview, a level at a time: `TreeParams` -> a tree answer (LSP `grm/tree`). */
  | 'tree'
  /** Add a persistent edit to the edits file (issue 27): `EditParams` -> `EditAnswer` (LSP `grm/edit`; VS Code applies it, one undo step; `grmc view`'s server writes the file). */
  | 'edit'
  /** Remove a persistent edit by id: `RemoveEditParams` -> `EditAnswer` (LSP `grm/removeEdit`). */
  | 'removeEdit'
  /** Give an edit another target, keeping its id: `RetargetEditParams` -> `EditAnswer` (LSP `grm/retargetEdit`). */
  | 'retargetEdit'
  /** The merged city layout of a `NAME.layout.json` (issue 29): `{ uri }` -> `LayoutResult` (LSP `grm/layout`). */
  | 'layout'
  /** An operator on a layout layer (move, protect, cut, assign, visible): `LayoutEditParams` -> `LayoutEditResult` (LSP `grm/layoutEdit`; VS Code applies it, `grmc view`'s server writes the file). */
  | 'layoutEdit'
  /** The city with a building on every parcel, as a picture (the layout view's 3D mode): `{ uri, width, height }` -> `{ png, buildings, reused, ... }` (LSP `grm/layoutCity`). */
  | 'layoutCity';

export const METHODS: readonly Method[] = ['preview', 'pick', 'picture', 'symbols', 'loadCurves', 'saveCurves', 'reveal', 'provenance', 'drag', 'sketch', 'writeParams', 'tree', 'edit', 'removeEdit', 'retargetEdit', 'layout', 'layoutEdit', 'layoutCity'];

/** What the host tells the page without being asked. */
export type NotificationMethod =
  /** The document to show: `{ uri, title }`. Sent on open and when the editor changes. */
  | 'document'
  /** A new model after an edit (LSP `grm/previewUpdated`): `{ uri, version, result, error }`. */
  | 'previewUpdated'
  /** The cursor moved: `{ uri, line, character }` (for the rule highlight). */
  | 'cursor'
  /** The curves file was changed outside the page: `{ uri }`. The page reloads it. */
  | 'curvesChanged'
  /** A node chosen in the editor's derivation view: `{ uri, key }` (key null: none). The page highlights its parts. */
  | 'treeNode'
  /** The layout sidecar shown changed (LSP `grm/layoutUpdated`): `{ uri, version }`. The layout view asks for it again. */
  | 'layoutUpdated';

/** What the page tells the host without being asked (no answer comes back). */
export type PageNotificationMethod =
  /** Where the orbit camera is and looks from, once it rests: `ViewParams`. The extension exports pictures through that camera. */
  'view';

export const PAGE_NOTIFICATIONS: readonly PageNotificationMethod[] = ['view'];

/**
 * A perspective camera, as `grm/picture`'s `camera` and `grmc --camera X,Y,Z
 * --look-at X,Y,Z --fov DEGREES` take it: where it is, the point it looks at
 * (+y up) and its vertical field of view in degrees. Not fitted to the
 * model: a picture through it frames what the preview's camera frames.
 */
export interface CameraParams {
  position: [number, number, number];
  target: [number, number, number];
  fov: number;
}

/** The widest vertical field of view the server and grmc draw (degrees; more than 0, at most this). */
export const MAX_FOV = 179;

/** The `view` notification's params. */
export interface ViewParams {
  /** The document shown. */
  uri: string;
  /** The camera's direction from the point it orbits, in degrees: `grmc --view AZIMUTH,ELEVATION` (see `viewAngles`). */
  azimuth: number;
  elevation: number;
  /** The canvas' size in CSS pixels (its aspect ratio is the picture's). */
  width: number;
  height: number;
  /** The camera itself (with its distance, the point it orbits and its field of view): `grmc --camera`; absent where it is not usable. */
  camera?: CameraParams;
}

/**
 * The azimuth and elevation, in degrees, of a direction (camera position
 * minus the point it looks at), as `grmc --view` takes them: azimuth about
 * +y from +z towards +x, in [-180, 180]; elevation above the xz plane, in
 * [-90, 90]. Null for a zero or non-finite vector.
 */
export function viewAngles(x: number, y: number, z: number): { azimuth: number; elevation: number } | null {
  const len = Math.hypot(x, y, z);
  if (!(len > 0) || !Number.isFinite(len)) return null;
  const deg = 180 / Math.PI;
  // Straight up or down the azimuth is undefined; atan2(0, 0) = 0 says "from +z".
  return { azimuth: Math.atan2(x, z) * deg, elevation: Math.asin(Math.max(-1, Math.min(1, y / len))) * deg };
}

export interface RequestMessage {
  type: 'request';
  id: number;
  method: Method;
  params: unknown;
}

export interface ResponseMessage {
  type: 'response';
  id: number;
  result?: unknown;
  error?: string;
  /** With `error`: the language server's JSON-RPC error code, where it gave one. */
  code?: number;
  /**
   * With `error`: the document version whose text failed (a `grm/preview`'s
   * RequestFailed names it in its `data.version`): a failure of an older
   * text than the model on screen is not the state.
   */
  version?: number;
  /** Protocol 3: the blob the result's buffers are ranges of (src/blob.ts). */
  blob?: ArrayBuffer;
}

/** LSP's RequestCancelled: the client cancelled the request (`$/cancelRequest`). */
export const REQUEST_CANCELLED = -32800;
/** LSP 3.17's ServerCancelled: the server dropped the request, e.g. a `grm/preview` a newer one for the document superseded. */
export const SERVER_CANCELLED = -32802;

/** An error code that says no answer was built on purpose (not a failure to show). */
export function isCancelledCode(code: unknown): boolean {
  return code === SERVER_CANCELLED || code === REQUEST_CANCELLED;
}

export interface NotificationMessage {
  type: 'notify';
  method: NotificationMethod;
  params: unknown;
  /** Protocol 3: the blob of a `previewUpdated`'s result (src/blob.ts). */
  blob?: ArrayBuffer;
}

/** The page's first message: it is listening. */
export interface ReadyMessage {
  type: 'ready';
}

export interface PageNotificationMessage {
  type: 'notify';
  method: PageNotificationMethod;
  params: unknown;
}

export type PageToHost = RequestMessage | ReadyMessage | PageNotificationMessage;
export type HostToPage = ResponseMessage | NotificationMessage;

function isObject(v: unknown): v is Record<string, unknown> {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

/** Validate a message from the page (the host must not trust its shape). */
export function parsePageMessage(v: unknown): PageToHost | null {
  if (!isObject(v)) return null;
  if (v.type === 'ready') return { type: 'ready' };
  if (v.type === 'notify') {
    if (typeof v.method !== 'string' || !(PAGE_NOTIFICATIONS as readonly string[]).includes(v.method)) return null;
    return { type: 'notify', method: v.method as PageNotificationMethod, params: v.params };
  }
  if (v.type !== 'request') return null;
  if (typeof v.id !== 'number' || !Number.isSafeInteger(v.id)) return null;
  if (typeof v.method !== 'string' || !(METHODS as readonly string[]).includes(v.method)) return null;
  return { type: 'request', id: v.id, method: v.method as Method, params: v.params };
}

function finite3(v: unknown): [number, number, number] | null {
  return Array.isArray(v) && v.length === 3 && v.every((x) => typeof x === 'number' && Number.isFinite(x)) ? [v[0], v[1], v[2]] : null;
}

/**
 * A copy of `v` if it is a camera the server and grmc draw through: finite
 * position and target that are different points (else the camera has no
 * direction), a field of view more than 0 and at most `MAX_FOV` degrees.
 * Null otherwise: the caller falls back to the view's angles.
 */
export function usableCamera(v: unknown): CameraParams | null {
  if (!isObject(v)) return null;
  const position = finite3(v.position);
  const target = finite3(v.target);
  const fov = v.fov;
  if (!position || !target || position.every((x, i) => x === target[i])) return null;
  if (typeof fov !== 'number' || !(fov > 0 && fov <= MAX_FOV)) return null;
  return { position, target, fov };
}

/**
 * Validate a `view` notification's params: finite angles and a canvas of
 * positive size. A camera that is not usable is dropped, not the view: the
 * export then takes the picture from the angles, as before cameras.
 */
export function parseViewParams(v: unknown): ViewParams | null {
  if (!isObject(v) || typeof v.uri !== 'string') return null;
  const { azimuth, elevation, width, height } = v;
  if (typeof azimuth !== 'number' || typeof elevation !== 'number' || !Number.isFinite(azimuth) || !Number.isFinite(elevation)) return null;
  if (typeof width !== 'number' || typeof height !== 'number' || !(width > 0 && height > 0 && Number.isFinite(width) && Number.isFinite(height))) return null;
  const camera = usableCamera(v.camera);
  return { uri: v.uri, azimuth, elevation, width, height, ...(camera ? { camera } : {}) };
}

/** Validate a message from the host. */
export function parseHostMessage(v: unknown): HostToPage | null {
  if (!isObject(v)) return null;
  if (v.type === 'response' && typeof v.id === 'number') {
    const out: ResponseMessage = { type: 'response', id: v.id };
    if ('result' in v) out.result = v.result;
    if (v.blob instanceof ArrayBuffer) out.blob = v.blob;
    if (typeof v.error === 'string') {
      out.error = v.error;
      if (typeof v.code === 'number' && Number.isSafeInteger(v.code)) out.code = v.code;
      if (typeof v.version === 'number' && Number.isSafeInteger(v.version)) out.version = v.version;
    }
    return out;
  }
  if (v.type === 'notify' && typeof v.method === 'string') {
    if (v.method === 'document' || v.method === 'previewUpdated' || v.method === 'cursor' || v.method === 'curvesChanged' || v.method === 'treeNode' || v.method === 'layoutUpdated') {
      return v.blob instanceof ArrayBuffer ? { type: 'notify', method: v.method, params: v.params, blob: v.blob } : { type: 'notify', method: v.method, params: v.params };
    }
  }
  return null;
}
