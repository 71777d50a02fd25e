// The built extension bundle (vscode/dist/extension.js) activates against a
// stand-in for the `vscode` module: commands registered, and a server path
// that does not exist reported rather than started.
import assert from 'node:assert/strict';
import Module, { createRequire } from 'node:module';
import { join } from 'node:path';
import { test } from 'node:test';

test('the bundle activates: three commands, a clear error for a missing server', async () => {
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
      },
      workspace: {
        getConfiguration: () => ({ get: (k: string) => (k === 'server.path' ? '/nonexistent/grmc' : undefined) }),
        workspaceFolders: [],
        onDidChangeConfiguration: () => disposable,
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
    const ext = require(join(import.meta.dirname, '../../vscode/dist/extension.js')) as {
      activate(c: unknown): Promise<void>;
      deactivate(): Promise<void>;
    };
    const context = { subscriptions: [] as unknown[], extensionPath: '/ext', extensionUri: {} };
    await ext.activate(context);
    assert.deepEqual(calls.commands.sort(), ['grm.exportModel', 'grm.openPreview', 'grm.restartServer']);
    assert.deepEqual(calls.errors, ['grm.server.path is set to /nonexistent/grmc, but /nonexistent/grmc is not an executable file']);
    assert.match(calls.log.join('\n'), /tried:\n {2}\/nonexistent\/grmc/);
    assert.ok(context.subscriptions.length >= 4);
    await ext.deactivate();
  } finally {
    loader._load = original;
  }
});
