// Messages between the preview page and its host (the VS Code extension over
// `postMessage`, or `grmc view` over HTTP). Shared by both sides: the
// extension imports this file too.

/** What the page asks of its host. */
export type Method =
  /** Grow the model: `PreviewParams` -> `PreviewResult` (LSP `grm/preview`). */
  | 'preview'
  /** Which rule made a part: `PickParams` -> `PickResult | null` (LSP `grm/pick`). */
  | 'pick'
  /** The document's symbols (LSP `textDocument/documentSymbol`): `{ uri }` -> `DocumentSymbol[]`; the page reads the meta-parameters from them. */
  | 'symbols'
  /** Read the grammar's curves file: `{ uri }` -> `{ path, text }` (`text` null: no file yet). */
  | 'loadCurves'
  /** Write the grammar's curves file: `{ uri, text }` -> `{ path }`. */
  | 'saveCurves'
  /** Show a rule in the editor: `{ uri, line, character }` -> `{}`. */
  | 'reveal';

export const METHODS: readonly Method[] = ['preview', 'pick', 'symbols', 'loadCurves', 'saveCurves', 'reveal'];

/** What the host tells the page without being asked. */
export type NotificationMethod =
  /** The document to show: `{ uri, title }`. Sent on open and when the editor changes. */
  | 'document'
  /** A new model after an edit (LSP `grm/previewUpdated`): `{ uri, version, result, error }`. */
  | 'previewUpdated'
  /** The cursor moved: `{ uri, line, character }` (for the rule highlight). */
  | 'cursor'
  /** The curves file was changed outside the page: `{ uri }`. The page reloads it. */
  | 'curvesChanged';

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
}

/** The page's first message: it is listening. */
export interface ReadyMessage {
  type: 'ready';
}

export type PageToHost = RequestMessage | ReadyMessage;
export type HostToPage = ResponseMessage | NotificationMessage;

function isObject(v: unknown): v is Record<string, unknown> {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

/** Validate a message from the page (the host must not trust its shape). */
export function parsePageMessage(v: unknown): PageToHost | null {
  if (!isObject(v)) return null;
  if (v.type === 'ready') return { type: 'ready' };
  if (v.type !== 'request') return null;
  if (typeof v.id !== 'number' || !Number.isSafeInteger(v.id)) return null;
  if (typeof v.method !== 'string' || !(METHODS as readonly string[]).includes(v.method)) return null;
  return { type: 'request', id: v.id, method: v.method as Method, params: v.params };
}

/** Validate a message from the host. */
export function parseHostMessage(v: unknown): HostToPage | null {
  if (!isObject(v)) return null;
  if (v.type === 'response' && typeof v.id === 'number') {
    const out: ResponseMessage = { type: 'response', id: v.id };
    if ('result' in v) out.result = v.result;
    if (typeof v.error === 'string') {
      out.error = v.error;
      if (typeof v.code === 'number' && Number.isSafeInteger(v.code)) out.code = v.code;
    }
    return out;
  }
  if (v.type === 'notify' && typeof v.method === 'string') {
    if (v.method === 'document' || v.method === 'previewUpdated' || v.method === 'cursor' || v.method === 'curvesChanged') {
      return { type: 'notify', method: v.method, params: v.params };
    }
  }
  return null;
}
