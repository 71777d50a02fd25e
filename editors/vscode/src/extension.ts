// The grm extension: starts `grmc lsp` as the language server, shows the
// preview page in a webview beside the editor, exports models and pictures
// (one, or every frame of the growth or search) with `grmc`.

import { type ChildProcess, execFile, spawn } from 'node:child_process';
import { randomBytes } from 'node:crypto';
import { accessSync, constants, readFileSync, statSync } from 'node:fs';
import * as os from 'node:os';
import * as path from 'node:path';
import * as vscode from 'vscode';
import { LanguageClient, type LanguageClientOptions, type ServerOptions, type StreamInfo } from 'vscode-languageclient/node';
import { BlobFrames, BlobShelf } from './blobFrames.js';
import { defaultOutput, type ExportFormat, exportArgs, firstSystemMode, framesSummary, framesWritten, pictureSize } from './exportArgs.js';
import { DerivationTree, type TreeNode } from '../../preview/src/tree.js';
import { PreviewHost, curvesPathFor } from './host.js';
import { resolveServerPath } from './serverPath.js';
import { makeNonce, webviewHtml } from './webviewHtml.js';

let client: LanguageClient | undefined;
/** The running server's process, and where its blobs (preview protocol 3) are kept until the host takes them. */
let serverProcess: ChildProcess | undefined;
const blobs = new BlobShelf();
let serverPath: string | undefined;
let output: vscode.OutputChannel;
let preview: PreviewPanel | undefined;
let derivation: DerivationView | undefined;

/**
 * The "grm: Derivation" view (explorer): the previewed document's
 * derivation tree (`grm/tree`), a node's rule opened and its parts
 * highlighted in the preview on selection, and a part picked in the
 * preview revealed in it.
 */
class DerivationView implements vscode.TreeDataProvider<TreeNode> {
  readonly tree = new DerivationTree({
    request: async (method, params) => {
      if (!client) throw new Error('the grm language server is not running');
      return client.sendRequest(method, params);
    },
  });
  private readonly changed = new vscode.EventEmitter<TreeNode | undefined>();
  readonly onDidChangeTreeData = this.changed.event;
  readonly view: vscode.TreeView<TreeNode>;

  constructor(context: vscode.ExtensionContext) {
    this.view = vscode.window.createTreeView('grm.derivation', { treeDataProvider: this, showCollapseAll: true });
    context.subscriptions.push(this.view, this.changed);
    // A node chosen here (clicked, or Enter): the preview highlights the parts its subtree drew (on each new model
    // too: the page keeps the key), and the editor opens its rule.
    context.subscriptions.push(
      vscode.commands.registerCommand('grm.derivation.choose', async (n: TreeNode) => {
        const uri = this.tree.document;
        if (uri) preview?.host.treeNode(uri, n.key);
        if (n.uri && n.range) {
          const r = n.range;
          await vscode.commands.executeCommand('vscode.open', vscode.Uri.parse(n.uri), {
            selection: new vscode.Range(r.start.line, r.start.character, r.end.line, r.end.character),
            preserveFocus: true,
          });
        }
      }),
    );
  }

  getTreeItem(n: TreeNode): vscode.TreeItem {
    const item = new vscode.TreeItem(n.label, n.children > 0 ? vscode.TreeItemCollapsibleState.Collapsed : vscode.TreeItemCollapsibleState.None);
    item.description = n.key;
    item.tooltip = `${n.label} (key ${n.key})${n.children ? `, ${n.children} children` : ''}`;
    item.command = { command: 'grm.derivation.choose', title: 'Highlight its parts and go to its rule', arguments: [n] };
    return item;
  }

  getChildren(n?: TreeNode): Promise<TreeNode[]> {
    return n ? this.tree.children(n) : this.tree.roots();
  }

  getParent(n: TreeNode): TreeNode | undefined {
    return this.tree.parentOf(n);
  }

  /** New previews so far: each one drops the nodes read. */
  private generation = 0;

  /**
   * A new preview of `uri`: the view redrawn when its tree changed (another
   * document, version or seed). A preview of the model already shown (the
   * page regrows to highlight the rule at the cursor, as a click here moves
   * it) leaves the rows as they are: redrawing them lost a click that came
   * just after.
   */
  previewed(uri: string): void {
    this.generation++;
    if (uri !== this.tree.document) {
      this.tree.setDocument(uri, undefined);
      this.changed.fire(undefined);
      return;
    }
    this.tree.stillCurrent().then(
      (same) => {
        if (!same) this.changed.fire(undefined);
      },
      () => this.changed.fire(undefined),
    );
  }

  /**
   * A part picked in the preview: its node selected in the view. A new preview while it is found or revealed (a pick
   * moves the editor's cursor, and the page regrows to highlight the rule there) drops the nodes under the reveal
   * (VS Code logs "No tree item with id ..." and reveals nothing): it is found again on the new tree and revealed.
   */
  async reveal(key: string): Promise<void> {
    for (let attempt = 0; attempt < 10; attempt++) {
      if (!this.view.visible) return;
      const generation = this.generation;
      const n = await this.tree.find(key);
      if (!n) return;
      if (generation !== this.generation) continue;
      await this.view.reveal(n, { select: true, focus: false, expand: true });
      if (generation === this.generation) return;
    }
  }
}

function isExecutable(p: string): boolean {
  try {
    if (!statSync(p).isFile()) return false;
    accessSync(p, process.platform === 'win32' ? constants.F_OK : constants.X_OK);
    return true;
  } catch {
    return false;
  }
}

function findServer(context: vscode.ExtensionContext): string | undefined {
  const r = resolveServerPath({
    setting: vscode.workspace.getConfiguration('grm').get<string>('server.path'),
    extensionPath: context.extensionPath,
    workspaceFolders: (vscode.workspace.workspaceFolders ?? []).map((f) => f.uri.fsPath),
    platform: process.platform,
    pathEnv: process.env.PATH,
    home: os.homedir(),
    isExecutable,
  });
  if ('error' in r) {
    output.appendLine(`${r.error}\ntried:\n  ${r.tried.join('\n  ')}`);
    void vscode.window.showErrorMessage(r.error, 'Open settings').then((choice) => {
      if (choice) void vscode.commands.executeCommand('workbench.action.openSettings', 'grm.server.path');
    });
    return undefined;
  }
  output.appendLine(`grm: using ${r.path} (${r.source})`);
  return r.path;
}

async function startClient(context: vscode.ExtensionContext): Promise<void> {
  serverPath = findServer(context);
  if (!serverPath) return;
  const command = serverPath;
  // Started here rather than by vscode-languageclient: its stdout goes
  // through BlobFrames, which keeps the preview's binary frames (protocol 3,
  // docs/lsp-extensions.md) and passes the JSON-RPC messages on.
  const serverOptions: ServerOptions = async (): Promise<StreamInfo> => {
    const child = spawn(command, ['lsp'], { stdio: 'pipe' });
    await new Promise<void>((resolve, reject) => {
      child.once('spawn', () => resolve());
      child.once('error', reject);
    });
    serverProcess = child;
    child.stderr?.on('data', (d: Buffer) => output.append(d.toString('utf8')));
    child.on('exit', () => {
      if (serverProcess === child) serverProcess = undefined;
    });
    const reader = new BlobFrames(blobs);
    child.stdout?.pipe(reader);
    if (!child.stdin) throw new Error('the server has no stdin');
    return { reader, writer: child.stdin };
  };
  const clientOptions: LanguageClientOptions = {
    documentSelector: [
      { scheme: 'file', language: 'grm' },
      { scheme: 'untitled', language: 'grm' },
      // The persistent edits beside a grammar (docs/edits.md): the server
      // replays the open buffer and publishes its diagnostics there.
      { scheme: 'file', pattern: '**/*.edits.json' },
      // City layouts (docs/layout.md, "In the editor"): the preview's layout
      // view evaluates the open buffer.
      { scheme: 'file', pattern: '**/*.layout.json' },
    ],
    outputChannel: output,
    synchronize: { fileEvents: vscode.workspace.createFileSystemWatcher('**/*.{grm,curves.json,edits.json,obj}') },
  };
  // The client id `grm` makes vscode-languageclient honour `grm.trace.server`.
  let c: LanguageClient | undefined;
  try {
    c = new LanguageClient('grm', 'grm language server', serverOptions, clientOptions);
    c.onNotification('grm/layoutUpdated', (p: unknown) => preview?.host.layoutUpdated(p));
    c.onNotification('grm/previewUpdated', (p: unknown) => {
      preview?.host.previewUpdated(p);
      const q = p as { uri?: unknown; result?: { uri?: unknown } } | null;
      const uri = q?.result?.uri ?? q?.uri;
      if (typeof uri === 'string') derivation?.previewed(uri);
    });
    await c.start();
    client = c;
  } catch (e) {
    // A binary that is not grmc, crashes or exits: said, and activation (and the restart command) still succeed.
    const why = `the grm language server could not start (${serverPath} lsp): ${e instanceof Error ? e.message : String(e)}`;
    output.appendLine(why);
    void vscode.window.showErrorMessage(why, 'Show output').then((choice) => {
      if (choice) output.show();
    });
    try {
      await c?.dispose();
    } catch {
      // Never started: nothing to stop.
    }
  }
}

async function stopClient(): Promise<void> {
  const c = client;
  client = undefined;
  if (c) await c.stop();
  // It exits on `exit`; one that did not (hung) is ended, as vscode-languageclient does with a process it started.
  const p = serverProcess;
  serverProcess = undefined;
  if (p && p.exitCode === null) setTimeout(() => p.exitCode === null && p.kill(), 2000).unref();
}

/** The server announced preview protocol 3 (binary buffers). */
function serverHasBlobs(): boolean {
  const exp = client?.initializeResult?.capabilities.experimental as { grmPreview?: { version?: unknown } } | undefined;
  const v = exp?.grmPreview?.version;
  return typeof v === 'number' && v >= 3;
}

function isGrm(doc: vscode.TextDocument | undefined): doc is vscode.TextDocument {
  return doc?.languageId === 'grm';
}

/** A grammar, or a city layout sidecar (the preview's layout view). */
function isPreviewable(doc: vscode.TextDocument | undefined): doc is vscode.TextDocument {
  if (!doc) return false;
  return doc.languageId === 'grm' || (doc.uri.scheme === 'file' && doc.uri.fsPath.endsWith('.layout.json'));
}

class PreviewPanel {
  readonly host: PreviewHost;
  private readonly disposables: vscode.Disposable[] = [];
  private cursorTimer: NodeJS.Timeout | undefined;

  constructor(
    context: vscode.ExtensionContext,
    readonly panel: vscode.WebviewPanel,
  ) {
    const webview = panel.webview;
    this.host = new PreviewHost({
      request: async (method, params) => {
        if (!client) throw new Error('the grm language server is not running (see the "grm" output)');
        const result = await client.sendRequest(method, params);
        // The derivation view follows the preview and its picks.
        const uri = (params as { textDocument?: { uri?: unknown } } | null)?.textDocument?.uri;
        if (method === 'grm/preview' && typeof uri === 'string') derivation?.previewed(uri);
        const key = (result as { key?: unknown } | null)?.key;
        if (method === 'grm/pick' && typeof key === 'string') void derivation?.reveal(key).catch(() => {});
        return result;
      },
      readFile: async (file) => {
        try {
          return Buffer.from(await vscode.workspace.fs.readFile(vscode.Uri.file(file))).toString('utf8');
        } catch (e) {
          if (e instanceof vscode.FileSystemError && e.code === 'FileNotFound') return null;
          throw e;
        }
      },
      writeFile: async (file, text) => {
        await vscode.workspace.fs.writeFile(vscode.Uri.file(file), Buffer.from(text, 'utf8'));
      },
      savePicture: async (suggested, png) => {
        // A bare name (a document that is not a file) starts in the first workspace folder, if any.
        const folder = vscode.workspace.workspaceFolders?.[0]?.uri;
        const defaultUri = path.isAbsolute(suggested) ? vscode.Uri.file(suggested) : folder && vscode.Uri.joinPath(folder, suggested);
        const target = await vscode.window.showSaveDialog({ defaultUri, filters: { 'PNG picture': ['png'] }, title: 'Save picture' });
        if (!target) return null;
        await vscode.workspace.fs.writeFile(target, png);
        return target.scheme === 'file' ? target.fsPath : target.toString();
      },
      reveal: async (uri, line, character) => {
        const doc = await vscode.workspace.openTextDocument(vscode.Uri.parse(uri));
        const pos = new vscode.Position(line, character);
        const shown = vscode.window.visibleTextEditors.find((e) => e.document.uri.toString() === doc.uri.toString());
        const editor = await vscode.window.showTextDocument(doc, { viewColumn: shown?.viewColumn ?? vscode.ViewColumn.One, preserveFocus: false });
        editor.selection = new vscode.Selection(pos, pos);
        editor.revealRange(new vscode.Range(pos, pos), vscode.TextEditorRevealType.InCenterIfOutsideViewport);
      },
      fsPath: (uri) => {
        const u = vscode.Uri.parse(uri);
        return u.scheme === 'file' ? u.fsPath : null;
      },
      post: (msg) => void webview.postMessage(msg),
      blobs: { enabled: serverHasBlobs, take: (id) => blobs.take(id) },
    });
    const media = vscode.Uri.joinPath(context.extensionUri, 'dist', 'preview');
    webview.options = { enableScripts: true, localResourceRoots: [media] };
    const template = readFileSync(path.join(context.extensionPath, 'dist', 'preview', 'index.html'), 'utf8');
    webview.html = webviewHtml(template, {
      scriptUri: webview.asWebviewUri(vscode.Uri.joinPath(media, 'preview.js')).toString(),
      styleUri: webview.asWebviewUri(vscode.Uri.joinPath(media, 'preview.css')).toString(),
      cspSource: webview.cspSource,
      nonce: makeNonce((n) => new Uint8Array(randomBytes(n))),
    });
    this.disposables.push(
      webview.onDidReceiveMessage((m) => void this.host.handle(m)),
      vscode.window.onDidChangeActiveTextEditor((e) => {
        if (isPreviewable(e?.document)) this.show(e.document);
      }),
      vscode.workspace.onDidSaveTextDocument((d) => {
        if (d.uri.scheme === 'file') this.host.fileSaved(d.uri.fsPath);
      }),
      vscode.window.onDidChangeTextEditorSelection((e) => {
        if (!isGrm(e.textEditor.document)) return;
        const uri = e.textEditor.document.uri.toString();
        const pos = e.selections[0]?.active;
        if (!pos) return;
        // At most one highlight request per 120 ms of cursor movement.
        clearTimeout(this.cursorTimer);
        this.cursorTimer = setTimeout(() => this.host.cursor(uri, pos.line, pos.character), 120);
      }),
    );
    panel.onDidDispose(() => this.dispose(), null, this.disposables);
  }

  show(doc: vscode.TextDocument): void {
    this.host.setDocument(doc.uri.toString(), path.basename(doc.uri.fsPath));
    this.panel.title = `Preview ${path.basename(doc.uri.fsPath)}`;
  }

  dispose(): void {
    clearTimeout(this.cursorTimer);
    preview = undefined;
    for (const d of this.disposables) d.dispose();
  }
}

function openPreview(context: vscode.ExtensionContext): void {
  const doc = vscode.window.activeTextEditor?.document;
  if (!isPreviewable(doc)) {
    void vscode.window.showInformationMessage('Open a .grm file (or a city layout, NAME.layout.json) to preview it.');
    return;
  }
  if (!preview) {
    const panel = vscode.window.createWebviewPanel('grm.preview', 'grm preview', { viewColumn: vscode.ViewColumn.Beside, preserveFocus: true }, {
      enableScripts: true,
      retainContextWhenHidden: true,
    });
    preview = new PreviewPanel(context, panel);
  } else {
    preview.panel.reveal(vscode.ViewColumn.Beside, true);
  }
  preview.show(doc);
}

/**
 * `grm.exportModel` (`frames` false): what the preview shows, to one file.
 * `grm.exportFrames` (`frames` true): every iteration (derive) or generation
 * (sample) of it, as NAME-K.EXT files beside the name chosen (`grmc --frames`).
 */
async function exportModel(frames: boolean): Promise<void> {
  const doc = vscode.window.activeTextEditor?.document;
  if (!isGrm(doc) || doc.uri.scheme !== 'file') {
    void vscode.window.showInformationMessage(`Open a saved .grm file to export its ${frames ? 'frames' : 'model'}.`);
    return;
  }
  if (!serverPath) {
    void vscode.window.showErrorMessage('grmc was not found (see the "grm" output).');
    return;
  }
  if (doc.isDirty) await doc.save();
  const formats = [
    { label: 'glTF binary (.glb)', format: 'glb' as ExportFormat },
    { label: 'Wavefront OBJ + MTL (.obj)', format: 'obj' as ExportFormat },
    { label: frames ? 'PNG pictures (.png)' : 'PNG picture (.png)', format: 'png' as ExportFormat, description: "through the preview's camera" },
  ];
  // Frames are mostly pictures: PNG first.
  if (frames) formats.unshift(formats.pop()!);
  const pickFormat = await vscode.window.showQuickPick(formats, { placeHolder: frames ? 'Export every frame as' : 'Export the model as' });
  if (!pickFormat) return;
  const grammar = doc.uri.fsPath;
  const last = preview?.host.lastPreview(doc.uri.toString());
  const mode = last ? (last.mode === 'sample' ? 'sample' : 'derive') : firstSystemMode(doc.getText());
  const ext = pickFormat.format;
  const filters: Record<ExportFormat, Record<string, string[]>> = { glb: { glTF: ['glb'] }, obj: { OBJ: ['obj'] }, png: { 'PNG picture': ['png'] } };
  const target = await vscode.window.showSaveDialog({
    defaultUri: vscode.Uri.file(defaultOutput(grammar, ext)),
    filters: filters[ext],
    title: frames
      ? `Export frames: NAME.${ext} writes NAME-0.${ext}, NAME-1.${ext}, ... (one per ${mode === 'sample' ? 'generation' : 'iteration'}) in the folder chosen`
      : undefined,
  });
  if (!target) return;
  // A picture through the preview's camera (else from where it looks), of the canvas' shape; without a preview, grmc's own view and size.
  const view = preview?.host.lastView(doc.uri.toString());
  const args = exportArgs({
    grammar,
    output: target.fsPath,
    mode,
    seed: last?.seed,
    params: last?.params,
    curves: curvesPathFor(grammar),
    system: last?.system,
    generation: last?.generation,
    frames,
    view,
    camera: view?.camera,
    imageSize: view && pictureSize(view.width, view.height),
  });
  const exe = serverPath;
  if (frames) {
    // grmc writes into an existing folder only.
    try {
      await vscode.workspace.fs.createDirectory(vscode.Uri.file(path.dirname(target.fsPath)));
    } catch {
      // Said by grmc.
    }
  }
  output.appendLine(`grm: ${exe} ${args.join(' ')}`);
  const title = frames ? `Exporting the frames of ${path.basename(grammar)}` : `Exporting ${path.basename(target.fsPath)}`;
  await vscode.window.withProgress({ location: vscode.ProgressLocation.Notification, title, cancellable: frames }, (_progress, token) =>
    new Promise<void>((resolve) => {
      const child = execFile(exe, args, { cwd: path.dirname(grammar), maxBuffer: 16 << 20 }, (err, stdout, stderr) => {
        if (stdout) output.append(stdout);
        if (stderr) output.append(stderr);
        if (token.isCancellationRequested) {
          output.appendLine('grm: export cancelled');
        } else if (err) {
          void vscode.window.showErrorMessage(`grmc failed: ${(stderr || err.message).split('\n')[0]}`, 'Show output').then((c) => {
            if (c) output.show();
          });
        } else if (frames) {
          const written = framesWritten(stderr, target.fsPath);
          const summary = framesSummary(written, target.fsPath);
          if (written.length === 0) {
            void vscode.window.showWarningMessage(summary, 'Show output').then((c) => {
              if (c) output.show();
            });
          } else {
            void vscode.window.showInformationMessage(summary, 'Reveal in folder').then((c) => {
              // The first frame, selected in its folder.
              if (c) void vscode.commands.executeCommand('revealFileInOS', vscode.Uri.file(written[0]!));
            });
          }
        } else {
          void vscode.window.showInformationMessage(`Exported ${target.fsPath}`);
        }
        resolve();
      });
      token.onCancellationRequested(() => child.kill());
    }),
  );
}

export async function activate(context: vscode.ExtensionContext): Promise<void> {
  output = vscode.window.createOutputChannel('grm');
  derivation = new DerivationView(context);
  // The derivation view shows in the explorer once grm is active.
  void vscode.commands.executeCommand('setContext', 'grm.active', true);
  context.subscriptions.push(
    output,
    vscode.commands.registerCommand('grm.openPreview', () => openPreview(context)),
    vscode.commands.registerCommand('grm.exportModel', () => exportModel(false)),
    vscode.commands.registerCommand('grm.exportFrames', () => exportModel(true)),
    vscode.commands.registerCommand('grm.restartServer', async () => {
      await stopClient();
      await startClient(context);
      preview?.host.refresh();
      void vscode.window.showInformationMessage(client ? 'grm language server restarted' : 'grm language server could not start');
    }),
    vscode.workspace.onDidChangeConfiguration(async (e) => {
      if (e.affectsConfiguration('grm.server.path')) {
        await stopClient();
        await startClient(context);
      }
    }),
  );
  await startClient(context);
}

export async function deactivate(): Promise<void> {
  await stopClient();
}
