// Which `grmc` binary the extension starts as its language server.
//
// Order: the `grm.server.path` setting; the binary bundled in the extension
// (`server/grmc`); `grmc` on PATH; `target/release/grmc` in a workspace
// folder (for people working on grm itself). A setting that names a missing
// file is an error, not a reason to fall back: the user asked for that one.
//
// Pure (the file system is passed in), so it is unit-tested under node.

import * as path from 'node:path';

export type ServerSource = 'setting' | 'bundled' | 'path' | 'workspace';

export interface ResolveEnv {
  /** The `grm.server.path` setting (empty or undefined = not set). */
  setting: string | undefined;
  /** The extension's install folder. */
  extensionPath: string;
  /** Workspace folder paths, in order. */
  workspaceFolders: readonly string[];
  platform: NodeJS.Platform;
  /** The PATH environment variable. */
  pathEnv: string | undefined;
  /** The user's home folder (for `~` in the setting). */
  home: string | undefined;
  /** True if the path is an existing file this process may execute. */
  isExecutable: (p: string) => boolean;
}

export type Resolved = { path: string; source: ServerSource } | { error: string; tried: string[] };

function exeName(platform: NodeJS.Platform): string {
  return platform === 'win32' ? 'grmc.exe' : 'grmc';
}

function pathApi(platform: NodeJS.Platform): path.PlatformPath {
  return platform === 'win32' ? path.win32 : path.posix;
}

/** The setting's value made absolute: `~` is the home folder, `${workspaceFolder}` the first folder, relative paths are relative to it. */
export function expandSetting(value: string, env: Pick<ResolveEnv, 'workspaceFolders' | 'home' | 'platform'>): string {
  const p = pathApi(env.platform);
  let v = value.trim();
  const ws = env.workspaceFolders[0];
  if (ws !== undefined) v = v.replace(/\$\{workspaceFolder\}/g, ws);
  if ((v === '~' || v.startsWith('~/') || v.startsWith('~\\')) && env.home) v = p.join(env.home, v.slice(1));
  if (!p.isAbsolute(v) && ws !== undefined) v = p.join(ws, v);
  return v;
}

export function resolveServerPath(env: ResolveEnv): Resolved {
  const p = pathApi(env.platform);
  const exe = exeName(env.platform);
  const tried: string[] = [];

  const setting = env.setting?.trim();
  if (setting) {
    const full = expandSetting(setting, env);
    if (env.isExecutable(full)) return { path: full, source: 'setting' };
    return { error: `grm.server.path is set to ${setting}, but ${full} is not an executable file`, tried: [full] };
  }

  const bundled = p.join(env.extensionPath, 'server', exe);
  tried.push(bundled);
  if (env.isExecutable(bundled)) return { path: bundled, source: 'bundled' };

  const sep = env.platform === 'win32' ? ';' : ':';
  for (const dir of (env.pathEnv ?? '').split(sep)) {
    if (!dir) continue;
    const candidate = p.join(dir, exe);
    tried.push(candidate);
    if (env.isExecutable(candidate)) return { path: candidate, source: 'path' };
  }

  for (const folder of env.workspaceFolders) {
    const candidate = p.join(folder, 'target', 'release', exe);
    tried.push(candidate);
    if (env.isExecutable(candidate)) return { path: candidate, source: 'workspace' };
  }

  return {
    error: 'grmc was not found: set grm.server.path, put grmc on PATH, or build it with `cargo build --release -p grmc`',
    tried,
  };
}
