// The extension's side of the preview page's messages (see
// preview/src/messages.ts): answers the page's requests by asking the
// language server (`grm/preview`, `grm/pick`, `grm/spread`) or the editor
// (save the curves file, reveal a rule), and forwards editor events as
// notifications. Free of the `vscode` module: the editor and the server are
// passed in, so the message handling is unit-tested under node.

import { parseCurves } from '../../preview/src/curves.js';
import { type HostToPage, type Method, type NotificationMethod, parsePageMessage } from '../../preview/src/messages.js';

export interface HostDeps {
  /** Ask the language server (method is the LSP method, e.g. `grm/preview`). */
  request(method: string, params: unknown): Promise<unknown>;
  /** Write a file (the curves file). */
  writeFile(path: string, text: string): Promise<void>;
  /** Show a place in the editor (0-based line and character). */
  reveal(uri: string, line: number, character: number): Promise<void>;
  /** The file path of a document URI, or null for a document that is not a file. */
  fsPath(uri: string): string | null;
  /** Send a message to the page. */
  post(message: HostToPage): void;
}

/** The language server's method for each page method that goes to the server. */
export const SERVER_METHODS: Partial<Record<Method, string>> = {
  preview: 'grm/preview',
  pick: 'grm/pick',
  spread: 'grm/spread',
};

/** `tree.grm` -> `tree.curves.json` beside it (docs/curves.md). */
export function curvesPathFor(grammarPath: string): string {
  return grammarPath.replace(/\.grm$/i, '') + '.curves.json';
}

export interface LastPreview {
  params: Record<string, unknown>;
  mode: string | undefined;
  seed: number | undefined;
}

function isObject(v: unknown): v is Record<string, unknown> {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

export class PreviewHost {
  private ready = false;
  private queued: HostToPage[] = [];
  private documentUri: string | null = null;
  private readonly last = new Map<string, LastPreview>();

  constructor(private readonly deps: HostDeps) {}

  get isReady(): boolean {
    return this.ready;
  }

  get uri(): string | null {
    return this.documentUri;
  }

  /** The page's last preview of a document (for export: same seed and parameters). */
  lastPreview(uri: string): LastPreview | undefined {
    return this.last.get(uri);
  }

  /** Show another document in the page. */
  setDocument(uri: string, title: string): void {
    if (uri === this.documentUri) return;
    this.documentUri = uri;
    this.notify('document', { uri, title });
  }

  /** The shown document (or something it depends on) changed: the page asks for a new preview. */
  documentChanged(uri: string, version?: number): void {
    if (uri !== this.documentUri) return;
    this.notify('previewUpdated', version === undefined ? { uri } : { uri, version });
  }

  /** The cursor moved in the shown document. */
  cursor(uri: string, line: number, character: number): void {
    if (uri !== this.documentUri || !this.ready) return;
    this.notify('cursor', { uri, line, character });
  }

  private notify(method: NotificationMethod, params: unknown): void {
    const msg: HostToPage = { type: 'notify', method, params };
    if (!this.ready) {
      // Before `ready` only the latest document notification matters.
      if (method === 'document') this.queued = [msg];
      return;
    }
    this.deps.post(msg);
  }

  /** Handle one message from the page. Never throws: errors go back as the response's `error`. */
  async handle(raw: unknown): Promise<void> {
    const msg = parsePageMessage(raw);
    if (!msg) return;
    if (msg.type === 'ready') {
      this.ready = true;
      const q = this.queued;
      this.queued = [];
      for (const m of q) this.deps.post(m);
      return;
    }
    try {
      const result = await this.answer(msg.method, msg.params);
      this.deps.post({ type: 'response', id: msg.id, result });
    } catch (e) {
      this.deps.post({ type: 'response', id: msg.id, error: e instanceof Error ? e.message : String(e) });
    }
  }

  private checkUri(params: unknown): string {
    if (!isObject(params) || typeof params.uri !== 'string') throw new Error('the request names no document (uri)');
    if (params.uri !== this.documentUri) throw new Error(`the preview shows ${this.documentUri ?? 'no document'}, not ${params.uri}`);
    return params.uri;
  }

  private async answer(method: Method, params: unknown): Promise<unknown> {
    switch (method) {
      case 'preview': {
        const uri = this.checkUri(params);
        const result = await this.deps.request('grm/preview', params);
        if (isObject(result)) {
          const p = params as Record<string, unknown>;
          this.last.set(uri, {
            params: isObject(p.params) ? p.params : {},
            mode: typeof result.mode === 'string' ? result.mode : undefined,
            seed: typeof result.seed === 'number' ? result.seed : typeof p.seed === 'number' ? p.seed : undefined,
          });
        }
        return result;
      }
      case 'pick': {
        this.checkUri(params);
        const result = await this.deps.request('grm/pick', params);
        // Jump to the rule: the point of picking in an editor.
        if (isObject(result) && isObject(result.rule) && typeof result.rule.line === 'number') {
          const r = result.rule;
          const uri = typeof r.uri === 'string' ? r.uri : (params as { uri: string }).uri;
          await this.deps.reveal(uri, r.line as number, typeof r.character === 'number' ? r.character : 0);
        }
        return result;
      }
      case 'spread': {
        this.checkUri(params);
        return this.deps.request('grm/spread', params);
      }
      case 'saveCurves': {
        const uri = this.checkUri(params);
        const text = (params as { text?: unknown }).text;
        if (typeof text !== 'string') throw new Error('saveCurves: no text');
        // Never write a file the sampler would refuse.
        parseCurves(text);
        const file = this.deps.fsPath(uri);
        if (!file) throw new Error('the grammar is not a file on disk: save it first');
        const path = curvesPathFor(file);
        await this.deps.writeFile(path, text);
        return { path };
      }
      case 'reveal': {
        const uri = this.checkUri(params);
        const p = params as { line?: unknown; character?: unknown };
        if (typeof p.line !== 'number') throw new Error('reveal: no line');
        await this.deps.reveal(uri, p.line, typeof p.character === 'number' ? p.character : 0);
        return {};
      }
    }
  }
}
