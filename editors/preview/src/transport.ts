// One small interface between the page and its host, two implementations:
// the VS Code webview (`acquireVsCodeApi().postMessage` and `message` events)
// and a browser talking to `grmc view` (HTTP POST JSON, long-polled events).
// Both hand the page a preview's buffers as bytes where the server sent
// them in a binary blob (protocol 3, src/blob.ts).

import { attachBlob, attachBlobToUpdate, blobRef } from './blob.js';
import {
  type HostToPage,
  type Method,
  type NotificationMethod,
  type PageNotificationMethod,
  type PageToHost,
  isCancelledCode,
  parseHostMessage,
} from './messages.js';

export type NotificationHandler = (method: NotificationMethod, params: unknown) => void;

/** What a host may tell about one request besides its answer. */
export interface RequestTiming {
  /** Milliseconds the server spent on it (`grmc view`'s `Server-Timing`). */
  serverMs?: number;
}

export interface Transport {
  readonly kind: 'vscode' | 'http';
  /** Ask the host; rejects with the host's error message. `timing` is filled where the host says more. */
  request(method: Method, params: unknown, timing?: RequestTiming): Promise<unknown>;
  /** Tell the host something it does not answer (dropped where the host has no use for it). */
  notify(method: PageNotificationMethod, params: unknown): void;
  /** Receive the host's notifications (one handler; a later call replaces it). */
  onNotification(handler: NotificationHandler): void;
  /** Start listening and tell the host the page is ready. */
  start(): void;
  /** Stop listening; pending requests are rejected. */
  dispose(): void;
}

/**
 * A request the host answered with an error (`code`: the language server's
 * JSON-RPC error code, where it gave one; `version`: the document version
 * whose text failed, where the server named it).
 */
export class TransportError extends Error {
  constructor(
    message: string,
    readonly code?: number,
    readonly version?: number,
  ) {
    super(message);
  }
}

/** The host dropped the request on purpose: a newer one superseded it (ServerCancelled) or it was cancelled (RequestCancelled). Not a failure to show. */
export function isSuperseded(e: unknown): boolean {
  return e instanceof TransportError && isCancelledCode(e.code);
}

/** A `previewUpdated`'s params with its blob in place; one whose blob is missing or wrong says why instead of its model. */
function updateWithBlob(params: unknown, blob: ArrayBuffer | undefined): unknown {
  try {
    return attachBlobToUpdate(params, blob);
  } catch (e) {
    return { ...(params as object), result: null, error: e instanceof Error ? e.message : String(e) };
  }
}

// ----------------------------------------------------------- VS Code webview

/** The part of `acquireVsCodeApi()` the transport uses. */
export interface PostTarget {
  postMessage(message: PageToHost): void;
}

/** Where host messages arrive (`window` in a webview). */
export interface MessageSource {
  addEventListener(type: 'message', listener: (ev: { data: unknown }) => void): void;
  removeEventListener(type: 'message', listener: (ev: { data: unknown }) => void): void;
}

export class VsCodeTransport implements Transport {
  readonly kind = 'vscode' as const;
  private nextId = 1;
  private pending = new Map<number, { resolve: (v: unknown) => void; reject: (e: Error) => void }>();
  private handler: NotificationHandler = () => {};
  private readonly listener = (ev: { data: unknown }) => this.receive(ev.data);

  constructor(
    private readonly api: PostTarget,
    private readonly source: MessageSource,
  ) {}

  start(): void {
    this.source.addEventListener('message', this.listener);
    this.api.postMessage({ type: 'ready' });
  }

  dispose(): void {
    this.source.removeEventListener('message', this.listener);
    for (const p of this.pending.values()) p.reject(new TransportError('the preview was closed'));
    this.pending.clear();
  }

  onNotification(handler: NotificationHandler): void {
    this.handler = handler;
  }

  request(method: Method, params: unknown): Promise<unknown> {
    const id = this.nextId++;
    return new Promise((resolve, reject) => {
      this.pending.set(id, { resolve, reject });
      this.api.postMessage({ type: 'request', id, method, params });
    });
  }

  notify(method: PageNotificationMethod, params: unknown): void {
    this.api.postMessage({ type: 'notify', method, params });
  }

  /** Number of requests still waiting for an answer (for tests). */
  get pendingCount(): number {
    return this.pending.size;
  }

  private receive(data: unknown): void {
    const msg: HostToPage | null = parseHostMessage(data);
    if (!msg) return;
    if (msg.type === 'notify') {
      // The host posts a preview's blob (protocol 3) beside its message.
      this.handler(msg.method, msg.method === 'previewUpdated' ? updateWithBlob(msg.params, msg.blob) : msg.params);
      return;
    }
    const p = this.pending.get(msg.id);
    if (!p) return;
    this.pending.delete(msg.id);
    if (msg.error !== undefined) p.reject(new TransportError(msg.error, msg.code, msg.version));
    else {
      try {
        p.resolve(attachBlob(msg.result, msg.blob));
      } catch (e) {
        p.reject(new TransportError(e instanceof Error ? e.message : String(e)));
      }
    }
  }
}

// ----------------------------------------------------------- HTTP (grmc view)

export type FetchFn = (url: string, init?: { method?: string; headers?: Record<string, string>; body?: string; signal?: AbortSignal }) => Promise<{
  ok: boolean;
  status: number;
  headers?: { get(name: string): string | null };
  json(): Promise<unknown>;
  text(): Promise<string>;
  /** The body as bytes (a preview's blob, protocol 3). */
  arrayBuffer?(): Promise<ArrayBuffer>;
}>;

/** The `app` metric of a `Server-Timing` header (`app;dur=12.5`), in milliseconds. */
export function serverTimingMs(header: string | null | undefined): number | undefined {
  if (!header) return undefined;
  for (const metric of header.split(',')) {
    const [name, ...params] = metric.split(';').map((x) => x.trim());
    if (name !== 'app') continue;
    for (const p of params) {
      const m = /^dur=([0-9.]+)$/.exec(p);
      if (m) return Number(m[1]);
    }
  }
  return undefined;
}

/**
 * `grmc view`: requests are `POST {base}/api/{method}` with the params as the
 * JSON body, answered `{ "result": ... }` or `{ "error": "...", "code": N }`
 * (`code`: the language server's error code, where it gave one); requests
 * are answered concurrently;
 * notifications come from long-polling `GET {base}/api/events?after=N`, which
 * answers `{ "seq": M, "events": [{ "method", "params" }] }` when something
 * happened after event N (or empty after a while).
 */
export class HttpTransport implements Transport {
  readonly kind = 'http' as const;
  private handler: NotificationHandler = () => {};
  private stopped = false;
  private seq = 0;
  private readonly abort = new AbortController();

  constructor(
    private readonly base: string,
    private readonly fetchFn: FetchFn,
    private readonly retryMs = 1000,
  ) {}

  start(): void {
    void this.poll();
  }

  dispose(): void {
    this.stopped = true;
    this.abort.abort();
  }

  onNotification(handler: NotificationHandler): void {
    this.handler = handler;
  }

  async request(method: Method, params: unknown, timing?: RequestTiming): Promise<unknown> {
    // The page reads protocol 3: a preview's (and a city's) buffers come as a blob, fetched apart (`withBlob`).
    const sent = (method === 'preview' || method === 'layoutCity') && params !== null && typeof params === 'object' ? { ...params, binary: true } : params;
    const res = await this.fetchFn(`${this.base}/api/${method}`, {
      method: 'POST',
      headers: { 'content-type': 'application/json' },
      body: JSON.stringify(sent ?? null),
      signal: this.abort.signal,
    });
    if (timing) timing.serverMs = serverTimingMs(res.headers?.get('server-timing'));
    let body: unknown;
    try {
      body = await res.json();
    } catch {
      throw new TransportError(`${method}: HTTP ${res.status}, not JSON`);
    }
    const obj = body as Record<string, unknown> | null;
    if (obj && typeof obj.error === 'string') {
      throw new TransportError(
        obj.error,
        typeof obj.code === 'number' ? obj.code : undefined,
        typeof obj.version === 'number' ? obj.version : undefined,
      );
    }
    if (!res.ok) throw new TransportError(`${method}: HTTP ${res.status}`);
    if (!obj || !('result' in obj)) throw new TransportError(`${method}: the answer has no result`);
    return this.withBlob(obj.result);
  }

  /** A preview answer with the bytes of its blob (`GET /api/blob/ID`) in place of its ranges; others as they are. */
  private async withBlob(result: unknown): Promise<unknown> {
    const ref = blobRef(result);
    if (!ref) return result;
    const res = await this.fetchFn(`${this.base}/api/blob/${ref.id}`, { signal: this.abort.signal });
    if (!res.ok || !res.arrayBuffer) throw new TransportError(`blob ${ref.id}: HTTP ${res.status}`);
    try {
      return attachBlob(result, await res.arrayBuffer());
    } catch (e) {
      throw new TransportError(e instanceof Error ? e.message : String(e));
    }
  }

  /** A `previewUpdated`'s params with its result's blob fetched and in place (or why it could not be, instead of the model). */
  private async updateWithBlob(params: unknown): Promise<unknown> {
    const p = params as { result?: unknown } | null;
    if (!p || !blobRef(p.result)) return params;
    try {
      return { ...p, result: await this.withBlob(p.result) };
    } catch (e) {
      return { ...p, result: null, error: e instanceof Error ? e.message : String(e) };
    }
  }

  /** `grmc view` exports nothing, so what the page tells it (the camera's view) has no use there and is not sent. */
  notify(_method: PageNotificationMethod, _params: unknown): void {}

  private async poll(): Promise<void> {
    while (!this.stopped) {
      try {
        const res = await this.fetchFn(`${this.base}/api/events?after=${this.seq}`, { signal: this.abort.signal });
        if (!res.ok) throw new TransportError(`events: HTTP ${res.status}`);
        const body = (await res.json()) as { seq?: unknown; events?: unknown };
        if (typeof body.seq === 'number') this.seq = body.seq;
        if (Array.isArray(body.events)) {
          for (const e of body.events) {
            const msg = parseHostMessage({ type: 'notify', ...(e as object) });
            if (msg && msg.type === 'notify') this.handler(msg.method, msg.method === 'previewUpdated' ? await this.updateWithBlob(msg.params) : msg.params);
          }
        }
      } catch {
        if (this.stopped) return;
        await new Promise((r) => setTimeout(r, this.retryMs));
      }
    }
  }
}

/** The transport for where the page runs: a VS Code webview if `acquireVsCodeApi` exists, else HTTP to its own origin. */
export function detectTransport(g: {
  acquireVsCodeApi?: () => PostTarget;
  location?: { origin: string };
  fetch?: FetchFn;
  addEventListener?: MessageSource['addEventListener'];
  removeEventListener?: MessageSource['removeEventListener'];
}): Transport {
  if (typeof g.acquireVsCodeApi === 'function') {
    const api = g.acquireVsCodeApi();
    const add = g.addEventListener;
    const remove = g.removeEventListener;
    if (!add || !remove) throw new TransportError('a webview without message events');
    return new VsCodeTransport(api, {
      addEventListener: (type, l) => add.call(g, type, l),
      removeEventListener: (type, l) => remove.call(g, type, l),
    });
  }
  if (!g.fetch || !g.location) throw new TransportError('no host: neither a VS Code webview nor a page served over HTTP');
  // fetch must be called with the window as `this`.
  const f = g.fetch.bind(g);
  return new HttpTransport(g.location.origin, f);
}
