// The built extension bundle (vscode/dist/extension.js) activates against a
// stand-in for the `vscode` module: commands registered, and a server path
// that does not exist reported rather than started, and one that does not
// start reported without failing the activation.
import assert from 'node:assert/strict';
import { chmodSync, mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import Module, { createRequire } from 'node:module';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { test } from 'node:test';

/** Activate the built bundle against a stand-in `vscode` whose `grm.server.path` is `setting`. */
async function activateWith(setting: string): Promise<{ commands: string[]; errors: string[]; log: string[] }> {
  const calls = { commands: [] as string[], errors: [] as string[], log: [] as string[] };
  // Anything the extension touches that the test does not care about is a
  // harmless callable (a `function`, so that classes may extend it).
  const stub = () => new Proxy(function () {}, anything);
  const anything: ProxyHandler<object> = {
    get: (t, p) => (p in t ? (t as Record<string | symbol, unknown>)[p] : stub()),
    apply: () => stub(),
    construct: () => new Proxy({}, anything),
  };
  const disposable = { dispose() {} };
  const vscode = new Proxy(
    {
      // The derivation view's change event (esbuild's namespace copy of the
      // module sees only these own properties).
      EventEmitter: class {
        event = () => disposable;
        fire() {}
        dispose() {}
      },
      commands: {
        registerCommand: (id: string) => {
          calls.commands.push(id);
          return disposable;
        },
        executeCommand: async () => undefined,
      },
      window: {
        createOutputChannel: () => ({ appendLine: (l: string) => calls.log.push(l), append() {}, show() {}, dispose() {} }),
        showErrorMessage: async (m: string) => {
          calls.errors.push(m);
          return undefined;
        },
        showInformationMessage: async () => undefined,
        createTreeView: () => ({ visible: false, reveal: async () => undefined, dispose() {} }),
      },
      workspace: {
        getConfiguration: () => ({ get: (k: string) => (k === 'server.path' ? setting : undefined) }),
        workspaceFolders: [],
        onDidChangeConfiguration: () => disposable,
        createFileSystemWatcher: () => disposable,
      },
    },
    anything,
  );
  const loader = Module as unknown as { _load: (req: string, ...rest: unknown[]) => unknown };
  const original = loader._load;
  loader._load = function (this: unknown, req: string, ...rest: unknown[]) {
    return req === 'vscode' ? vscode : original.call(this, req, ...rest);
  };
  try {
    const require = createRequire(import.meta.url);
    const bundle = join(import.meta.dirname, '../../vscode/dist/extension.js');
    // A fresh copy each time: the bundle binds the `vscode` module it is loaded with.
    delete require.cache[require.resolve(bundle)];
    const ext = require(bundle) as {
      activate(c: unknown): Promise<void>;
      deactivate(): Promise<void>;
    };
    const context = { subscriptions: [] as unknown[], extensionPath: '/ext', extensionUri: {} };
    await ext.activate(context);
    assert.ok(context.subscriptions.length >= 4);
    await ext.deactivate();
    return calls;
  } finally {
    loader._load = original;
  }
}

test("the bundle activates: four commands (and the Derivation view's own), a clear error for a missing server", async () => {
  const calls = await activateWith('/nonexistent/grmc');
  assert.deepEqual(calls.commands.sort(), ['grm.derivation.choose', 'grm.exportFrames', 'grm.exportModel', 'grm.openPreview', 'grm.restartServer']);
  assert.deepEqual(calls.errors, ['grm.server.path is set to /nonexistent/grmc, but /nonexistent/grmc is not an executable file']);
  assert.match(calls.log.join('\n'), /tried:\n {2}\/nonexistent\/grmc/);
});

// A server that is found but whose client does not start (a binary that is
// not grmc or crashes; here the client fails against the stand-in `vscode`):
// activation used to reject, so VS Code reported the extension as failed, the
// restart command threw and the preview said nothing useful.
test('a server that cannot start is reported; activation still succeeds', async () => {
  const dir = mkdtempSync(join(tmpdir(), 'grm-activation-'));
  try {
    const fake = join(dir, 'grmc');
    writeFileSync(fake, '#!/bin/sh\nexit 3\n');
    chmodSync(fake, 0o755);
    const calls = await activateWith(fake);
    assert.deepEqual(calls.commands.sort(), ['grm.derivation.choose', 'grm.exportFrames', 'grm.exportModel', 'grm.openPreview', 'grm.restartServer']);
    assert.equal(calls.errors.length, 1, JSON.stringify(calls));
    assert.match(calls.errors[0], new RegExp(`^the grm language server could not start \\(${fake} lsp\\): `));
    assert.match(calls.log.join('\n'), /could not start/);
  } finally {
    rmSync(dir, { recursive: true, force: true });
  }
});
