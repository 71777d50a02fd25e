// The extension's side of the preview page's messages (see
// preview/src/messages.ts): answers the page's requests by asking the
// language server (`grm/preview`, `grm/pick`, and direct manipulation's
// `grm/provenance`, `grm/drag`, `grm/sketch`, `grm/writeParams`, whose
// edits the server applies through `workspace/applyEdit`;
// docs/lsp-extensions.md) or the
// editor (read and save the curves file, reveal a rule, save a picture:
// `grm/picture`'s PNG, which a webview cannot download), forwards the
// server's `grm/previewUpdated` and the editor's cursor as notifications,
// and keeps the camera view the page last told (pictures are exported
// through its camera). Free of the `vscode` module: the editor and the
// server are passed in, so the message handling is unit-tested under node.

import { blobRef } from '../../preview/src/blob.js';
import { parseCurves } from '../../preview/src/curves.js';
import { type HostToPage, type Method, type NotificationMethod, type ResponseMessage, type ViewParams, parsePageMessage, parseViewParams } from '../../preview/src/messages.js';
import { pictureFileName } from '../../preview/src/picture.js';
import { base64ToBytes } from '../../preview/src/protocol.js';
import { defaultOutput } from './exportArgs.js';

export interface HostDeps {
  /** Ask the language server (method is the LSP method, e.g. `grm/preview`). */
  request(method: string, params: unknown): Promise<unknown>;
  /** Read a file (the curves file); null when it does not exist. */
  readFile(path: string): Promise<string | null>;
  /** Write a file (the curves file). */
  writeFile(path: string, text: string): Promise<void>;
  /**
   * Ask the user where to save a picture (starting at `suggested`: a path
   * beside the grammar, or a bare file name for a document that is not a
   * file) and write `png` there. The path written, or null if the user
   * cancelled.
   */
  savePicture(suggested: string, png: Uint8Array): Promise<string | null>;
  /** Show a place in the editor (0-based line and character). */
  reveal(uri: string, line: number, character: number): Promise<void>;
  /** The file path of a document URI, or null for a document that is not a file. */
  fsPath(uri: string): string | null;
  /** Send a message to the page. */
  post(message: HostToPage): void;
  /**
   * Protocol 3 (docs/lsp-extensions.md, "Binary buffers"): where the
   * server's blobs are read (src/blobFrames.ts). With it, and `enabled()`
   * (the server announced version 3), previews are asked with `binary` and
   * each answer's blob is posted to the page beside it; without, base64.
   */
  blobs?: { enabled(): boolean; take(id: number): ArrayBuffer | undefined };
}

/** `tree.grm` -> `tree.curves.json` beside it (docs/curves.md). */
export function curvesPathFor(grammarPath: string): string {
  return grammarPath.replace(/\.grm$/i, '') + '.curves.json';
}

export interface LastPreview {
  params: Record<string, unknown>;
  mode: string | undefined;
  /** The seed the page asked for; undefined: the file's own (`seed` setting). */
  seed: number | undefined;
  system: string | undefined;
  /** The generation of a scrubbed search shown (sample mode, `sample.generation`); undefined: the result. */
  generation?: number;
}

/** `{ generation }` when a preview result shows a generation of its search (`sample.generation`), else nothing. */
function generationShown(r: Record<string, unknown>): { generation?: number } {
  const g = isObject(r.sample) ? r.sample.generation : undefined;
  return typeof g === 'number' && Number.isInteger(g) && g >= 0 ? { generation: g } : {};
}

/** Two document URIs name the same file (clients and servers escape differently). */
export function sameUri(a: string, b: string): boolean {
  if (a === b) return true;
  try {
    return decodeURIComponent(a).toLowerCase() === decodeURIComponent(b).toLowerCase() && a.toLowerCase().startsWith('file:');
  } catch {
    return false;
  }
}

function isObject(v: unknown): v is Record<string, unknown> {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

export class PreviewHost {
  private ready = false;
  private queued: HostToPage[] = [];
  private documentUri: string | null = null;
  private readonly last = new Map<string, LastPreview>();
  /** The page's camera view, told once the camera rests; of the shown document only. */
  private view: ViewParams | null = null;

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

  /** Where the page's camera looks from, if the page shows this document and has told it (for a picture from the same side). */
  lastView(uri: string): ViewParams | undefined {
    return this.view?.uri === uri ? this.view : undefined;
  }

  /** Show another document in the page. */
  setDocument(uri: string, title: string): void {
    if (uri === this.documentUri) return;
    this.documentUri = uri;
    // The page frames the new model and tells its view again.
    this.view = null;
    this.notify('document', { uri, title });
  }

  /** Ask the page to grow the shown document again (after a server restart: the new server knows no live preview). */
  refresh(): void {
    if (this.documentUri) this.notify('document', { uri: this.documentUri, title: this.documentUri.split('/').pop() ?? this.documentUri });
  }

  /** The server's `grm/previewUpdated` (a new model after an edit): passed on if it is about the shown document, with its blob (protocol 3). */
  previewUpdated(params: unknown): void {
    // Taken whatever becomes of the message: a blob no one takes is dropped.
    const blob = this.takeBlob(isObject(params) ? params.result : undefined);
    if (!isObject(params) || typeof params.uri !== 'string' || !this.documentUri || !sameUri(params.uri, this.documentUri)) return;
    this.notify('previewUpdated', { ...params, uri: this.documentUri }, blob);
  }

  /** The blob a preview answer names (protocol 3), taken from where the server's blobs are read. */
  private takeBlob(result: unknown): ArrayBuffer | undefined {
    const ref = blobRef(result);
    return ref ? this.deps.blobs?.take(ref.id) : undefined;
  }

  /** The server's `grm/layoutUpdated` (the shown layout sidecar changed): passed on if it is about the shown document. */
  layoutUpdated(params: unknown): void {
    if (!isObject(params) || typeof params.uri !== 'string' || !this.documentUri || !sameUri(params.uri, this.documentUri)) return;
    this.notify('layoutUpdated', { ...params, uri: this.documentUri });
  }

  /** A file was saved in the editor: if it is the shown grammar's curves file, the page reloads it. */
  fileSaved(path: string): void {
    const uri = this.documentUri;
    if (!uri || !this.ready) return;
    const grammar = this.deps.fsPath(uri);
    if (grammar && curvesPathFor(grammar) === path) this.notify('curvesChanged', { uri });
  }

  /** The cursor moved in the shown document. */
  cursor(uri: string, line: number, character: number): void {
    if (uri !== this.documentUri || !this.ready) return;
    this.notify('cursor', { uri, line, character });
  }

  /** A node chosen in the editor's derivation view (`key` null: none): the page highlights its parts, if it shows `uri`. */
  treeNode(uri: string, key: string | null): void {
    if (!this.documentUri || !sameUri(uri, this.documentUri) || !this.ready) return;
    this.notify('treeNode', { uri: this.documentUri, key });
  }

  private notify(method: NotificationMethod, params: unknown, blob?: ArrayBuffer): void {
    const msg: HostToPage = blob ? { type: 'notify', method, params, blob } : { type: 'notify', method, params };
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
    if (msg.type === 'notify') {
      if (msg.method === 'view') {
        // A view of a document the page no longer shows is stale.
        const view = parseViewParams(msg.params);
        if (view && view.uri === this.documentUri) this.view = view;
      }
      return;
    }
    try {
      const result = await this.answer(msg.method, msg.params);
      // A preview's buffers (protocol 3) go beside it as an ArrayBuffer, which the webview receives without a copy through JSON.
      const blob = msg.method === 'preview' || msg.method === 'layoutCity' ? this.takeBlob(result) : undefined;
      this.deps.post(blob ? { type: 'response', id: msg.id, result, blob } : { type: 'response', id: msg.id, result });
    } catch (e) {
      const error = e instanceof Error ? e.message : String(e);
      // The language client's ResponseError carries the server's JSON-RPC code (e.g. ServerCancelled for a superseded preview)
      // and its data: a failed preview's `version`, the document version whose text failed.
      const code = (e as { code?: unknown } | null)?.code;
      const data = (e as { data?: unknown } | null)?.data;
      const version = isObject(data) ? data.version : undefined;
      const out: ResponseMessage = { type: 'response', id: msg.id, error };
      if (typeof code === 'number' && Number.isSafeInteger(code)) out.code = code;
      if (typeof version === 'number' && Number.isSafeInteger(version)) out.version = version;
      this.deps.post(out);
    }
  }

  /** The document a request is about (`textDocument.uri` for server requests, `uri` for the others): only the shown one. */
  private checkUri(params: unknown): string {
    const uri = isObject(params) ? (isObject(params.textDocument) ? params.textDocument.uri : params.uri) : undefined;
    if (typeof uri !== 'string') throw new Error('the request names no document');
    if (uri !== this.documentUri) throw new Error(`the preview shows ${this.documentUri ?? 'no document'}, not ${uri}`);
    return uri;
  }

  private curvesFile(uri: string): string {
    const file = this.deps.fsPath(uri);
    if (!file) throw new Error('the grammar is not a file on disk: save it first');
    return curvesPathFor(file);
  }

  private async answer(method: Method, params: unknown): Promise<unknown> {
    switch (method) {
      case 'preview': {
        const uri = this.checkUri(params);
        const binary = this.deps.blobs?.enabled() === true && isObject(params);
        const result = await this.deps.request('grm/preview', binary ? { ...params, binary: true } : params);
        const p = params as Record<string, unknown>;
        const r = isObject(result) ? result : {};
        this.last.set(uri, {
          params: isObject(p.params) ? p.params : {},
          mode: typeof r.mode === 'string' ? r.mode : typeof p.mode === 'string' ? p.mode : undefined,
          // The seed the page picked; none: the grammar's own `seed` setting, which the export leaves to the file
          // (the page follows it: an edit of it must not leave the export at the old seed).
          seed: typeof p.seed === 'number' ? p.seed : undefined,
          system: typeof r.system === 'string' ? r.system : undefined,
          ...generationShown(r),
        });
        return result;
      }
      case 'pick': {
        this.checkUri(params);
        const result = await this.deps.request('grm/pick', params);
        // Jump to the rule: the point of picking in an editor.
        if (isObject(result) && typeof result.uri === 'string' && isObject(result.range) && isObject(result.range.start)) {
          const start = result.range.start;
          if (typeof start.line === 'number') {
            await this.deps.reveal(result.uri, start.line, typeof start.character === 'number' ? start.character : 0);
          }
        }
        return result;
      }
      case 'picture': {
        const uri = this.checkUri(params);
        // Drawn first: a program with errors is refused before the user is asked where to save.
        const result = await this.deps.request('grm/picture', params);
        if (!isObject(result) || typeof result.png !== 'string') throw new Error('grm/picture: the answer has no png');
        const { png, ...rest } = result;
        const file = this.deps.fsPath(uri);
        const saved = await this.deps.savePicture(file ? defaultOutput(file, 'png') : pictureFileName(uri), base64ToBytes(png));
        // The page needs only where it went: the PNG (up to megabytes of base64) does not travel back.
        return { ...rest, saved };
      }
      case 'symbols': {
        const uri = this.checkUri(params);
        return this.deps.request('textDocument/documentSymbol', { textDocument: { uri } });
      }
      case 'loadCurves': {
        const path = this.curvesFile(this.checkUri(params));
        return { path, text: await this.deps.readFile(path) };
      }
      case 'saveCurves': {
        const path = this.curvesFile(this.checkUri(params));
        const text = (params as { text?: unknown }).text;
        if (typeof text !== 'string') throw new Error('saveCurves: no text');
        // Never write a file the sampler would refuse.
        parseCurves(text);
        await this.deps.writeFile(path, text);
        return { path };
      }
      case 'tree': {
        this.checkUri(params);
        return this.deps.request('grm/tree', params);
      }
      case 'layout':
      case 'layoutEdit': {
        // A city layout's view (issue 29): the server applies an operator as a workspace edit (one undo step).
        this.checkUri(params);
        return this.deps.request(`grm/${method}`, params);
      }
      case 'layoutCity': {
        // The city's model: its buffers as a blob (protocol 3) where the server sends blobs.
        this.checkUri(params);
        const binary = this.deps.blobs?.enabled() === true && isObject(params);
        return this.deps.request('grm/layoutCity', binary ? { ...params, binary: true } : params);
      }
      case 'edit':
      case 'removeEdit':
      case 'retargetEdit':
      case 'provenance':
      case 'drag':
      case 'sketch':
      case 'writeParams': {
        // Persistent edits (issue 27) and direct manipulation (issue 28): the server sends the edit to the editor itself
        // (workspace/applyEdit, one undo step); the live preview regrows from the edited text.
        this.checkUri(params);
        return this.deps.request(`grm/${method}`, params);
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
