import assert from 'node:assert/strict';
import { test } from 'node:test';
import { type ResolveEnv, expandSetting, resolveServerPath } from '../vscode/src/serverPath.js';

function env(executables: string[], over: Partial<ResolveEnv> = {}): ResolveEnv {
  const set = new Set(executables);
  return {
    setting: undefined,
    extensionPath: '/ext',
    workspaceFolders: ['/ws', '/ws2'],
    platform: 'linux',
    pathEnv: '/usr/local/bin:/usr/bin',
    home: '/home/u',
    isExecutable: (p) => set.has(p),
    ...over,
  };
}

const all = ['/opt/grmc', '/ext/server/grmc', '/usr/bin/grmc', '/ws/target/release/grmc', '/ws2/target/release/grmc'];

test('the setting wins over everything', () => {
  assert.deepEqual(resolveServerPath(env(all, { setting: '/opt/grmc' })), { path: '/opt/grmc', source: 'setting' });
});

test('then the bundled binary, then PATH, then the workspace build', () => {
  assert.deepEqual(resolveServerPath(env(all)), { path: '/ext/server/grmc', source: 'bundled' });
  assert.deepEqual(resolveServerPath(env(all.slice(2))), { path: '/usr/bin/grmc', source: 'path' });
  assert.deepEqual(resolveServerPath(env(all.slice(3))), { path: '/ws/target/release/grmc', source: 'workspace' });
  assert.deepEqual(resolveServerPath(env(all.slice(4))), { path: '/ws2/target/release/grmc', source: 'workspace' });
});

test('PATH is searched in order and empty entries are skipped', () => {
  const r = resolveServerPath(env(['/b/grmc', '/c/grmc'], { pathEnv: '::/a:/b:/c' }));
  assert.deepEqual(r, { path: '/b/grmc', source: 'path' });
});

test('a setting naming a missing file is an error, with no fallback', () => {
  const r = resolveServerPath(env(all, { setting: '/nope/grmc' }));
  assert.ok('error' in r);
  assert.match(r.error, /\/nope\/grmc is not an executable file/);
  assert.deepEqual(r.tried, ['/nope/grmc']);
});

test('nothing found: an error that says how to fix it and everything tried', () => {
  const r = resolveServerPath(env([]));
  assert.ok('error' in r);
  assert.match(r.error, /grm.server.path/);
  assert.deepEqual(r.tried, ['/ext/server/grmc', '/usr/local/bin/grmc', '/usr/bin/grmc', '/ws/target/release/grmc', '/ws2/target/release/grmc']);
});

test('the setting expands ~, ${workspaceFolder} and relative paths; blank means unset', () => {
  assert.equal(expandSetting('~/bin/grmc', env([])), '/home/u/bin/grmc');
  assert.equal(expandSetting('${workspaceFolder}/target/debug/grmc', env([])), '/ws/target/debug/grmc');
  assert.equal(expandSetting('target/debug/grmc', env([])), '/ws/target/debug/grmc');
  assert.deepEqual(resolveServerPath(env(['/ws/target/debug/grmc'], { setting: './target/debug/grmc' })), { path: '/ws/target/debug/grmc', source: 'setting' });
  assert.deepEqual(resolveServerPath(env(all, { setting: '   ' })), { path: '/ext/server/grmc', source: 'bundled' });
});

test('windows: grmc.exe, ; separated PATH, backslashes', () => {
  const r = resolveServerPath(
    env(['C:\\tools\\grmc.exe'], { platform: 'win32', extensionPath: 'C:\\ext', workspaceFolders: ['C:\\ws'], pathEnv: 'C:\\Windows;C:\\tools' }),
  );
  assert.deepEqual(r, { path: 'C:\\tools\\grmc.exe', source: 'path' });
  const ws = resolveServerPath(env(['C:\\ws\\target\\release\\grmc.exe'], { platform: 'win32', extensionPath: 'C:\\ext', workspaceFolders: ['C:\\ws'], pathEnv: '' }));
  assert.deepEqual(ws, { path: 'C:\\ws\\target\\release\\grmc.exe', source: 'workspace' });
});
