// The extension manifest agrees with the code and the files it names.
import assert from 'node:assert/strict';
import { existsSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import { test } from 'node:test';

const vscodeDir = join(import.meta.dirname, '../../vscode');
const manifest = JSON.parse(readFileSync(join(vscodeDir, 'package.json'), 'utf8'));
const source = readFileSync(join(vscodeDir, 'src/extension.ts'), 'utf8');

test('every contributed command is registered, and every registered command contributed', () => {
  const contributed = manifest.contributes.commands.map((c: { command: string }) => c.command).sort();
  const registered = [...source.matchAll(/registerCommand\('([^']+)'/g)].map((m) => m[1]).sort();
  assert.deepEqual(contributed, ['grm.derivation.choose', 'grm.exportFrames', 'grm.exportModel', 'grm.openPreview', 'grm.restartServer']);
  // The Derivation view's own (a node clicked): not in the command palette.
  const palette = manifest.contributes.menus.commandPalette.find((c: { command: string }) => c.command === 'grm.derivation.choose');
  assert.equal(palette?.when, 'false');
  assert.deepEqual(registered, contributed);
});

test('the export command names the formats its quick pick offers', () => {
  const exportCommand = manifest.contributes.commands.find((c: { command: string }) => c.command === 'grm.exportModel');
  assert.equal(exportCommand.title, 'Export Model (glTF/OBJ/PNG)');
  assert.deepEqual([...source.matchAll(/format: '(\w+)' as ExportFormat/g)].map((m) => m[1]), ['glb', 'obj', 'png']);
});

test('the frames command: the same formats, beside the export command, for .grm files only', () => {
  const frames = manifest.contributes.commands.find((c: { command: string }) => c.command === 'grm.exportFrames');
  assert.equal(frames.title, 'Export Frames (PNG/glTF/OBJ)');
  assert.equal(frames.category, 'grm');
  const palette = manifest.contributes.menus.commandPalette.find((m: { command: string }) => m.command === 'grm.exportFrames');
  assert.equal(palette.when, 'editorLangId == grm');
  // One quick pick serves both commands; the frames export runs grmc with --frames.
  assert.match(source, /registerCommand\('grm\.exportFrames', \(\) => exportModel\(true\)\)/);
});

test('the language, its configuration and grammar files exist; .grm files are grm', () => {
  const [lang] = manifest.contributes.languages;
  assert.equal(lang.id, 'grm');
  assert.deepEqual(lang.extensions, ['.grm']);
  assert.ok(existsSync(join(vscodeDir, lang.configuration)));
  const [grammar] = manifest.contributes.grammars;
  assert.equal(grammar.scopeName, 'source.grm');
  assert.ok(existsSync(join(vscodeDir, grammar.path)));
  const conf = JSON.parse(readFileSync(join(vscodeDir, lang.configuration), 'utf8'));
  assert.deepEqual(conf.comments, { lineComment: '//', blockComment: ['/*', '*/'] });
  assert.ok(new RegExp(conf.wordPattern.pattern, conf.wordPattern.flags).test('branchOrLeaf'));
});

test('the settings: grm.server.path and grm.trace.server (read by the client id `grm`)', () => {
  const props = manifest.contributes.configuration.properties;
  assert.equal(props['grm.server.path'].type, 'string');
  assert.deepEqual(props['grm.trace.server'].enum, ['off', 'messages', 'verbose']);
  assert.match(source, /new LanguageClient\('grm',/);
  assert.match(source, /get<string>\('server\.path'\)/);
});

test('the entry point is the esbuild bundle and the engine matches the @types/vscode in use', () => {
  assert.equal(manifest.main, './dist/extension.js');
  const types = JSON.parse(readFileSync(join(import.meta.dirname, '../../package.json'), 'utf8')).devDependencies['@types/vscode'];
  assert.equal(manifest.engines.vscode, `^${types}`);
});
