// Build everything under editors/ with esbuild:
//   preview/dist/      the preview page (index.html, preview.js, preview.css), committed:
//                      `grmc view` embeds it, the extension ships a copy
//   vscode/dist/       the extension (extension.js) and its copy of the page
//   out/test/          unit tests (node --test)
//   out/browser-test/  the headless-Chromium test
// Usage: node scripts/build.mjs [--no-page]   (--no-page: keep the committed page as is)
import * as esbuild from 'esbuild';
import { cpSync, mkdirSync, readFileSync, readdirSync, rmSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const root = join(dirname(fileURLToPath(import.meta.url)), '..');
const buildPage = !process.argv.includes('--no-page');

async function page() {
  const dist = join(root, 'preview/dist');
  mkdirSync(dist, { recursive: true });
  await esbuild.build({
    entryPoints: [join(root, 'preview/src/main.ts')],
    outfile: join(dist, 'preview.js'),
    bundle: true,
    format: 'iife',
    platform: 'browser',
    target: 'es2022',
    minify: true,
    legalComments: 'eof',
    logLevel: 'warning',
  });
  cpSync(join(root, 'preview/src/style.css'), join(dist, 'preview.css'));
  cpSync(join(root, 'preview/index.html'), join(dist, 'index.html'));
}

async function extension() {
  const dist = join(root, 'vscode/dist');
  rmSync(dist, { recursive: true, force: true });
  mkdirSync(dist, { recursive: true });
  await esbuild.build({
    entryPoints: [join(root, 'vscode/src/extension.ts')],
    outfile: join(dist, 'extension.js'),
    bundle: true,
    format: 'cjs',
    platform: 'node',
    target: 'node18',
    external: ['vscode'],
    minify: true,
    sourcemap: false,
    logLevel: 'warning',
  });
  cpSync(join(root, 'preview/dist'), join(dist, 'preview'), { recursive: true });
}

async function tests() {
  for (const dir of ['test', 'browser-test']) {
    const out = join(root, 'out', dir);
    rmSync(out, { recursive: true, force: true });
    const entries = readdirSync(join(root, dir))
      .filter((f) => f.endsWith('.test.ts'))
      .map((f) => join(root, dir, f));
    if (entries.length === 0) continue;
    await esbuild.build({
      entryPoints: entries,
      outdir: out,
      outExtension: { '.js': '.mjs' },
      bundle: true,
      format: 'esm',
      platform: 'node',
      target: 'node20',
      packages: 'external',
      // The extension's modules import `vscode` only in extension.ts; tests never load it.
      external: ['vscode'],
      logLevel: 'warning',
    });
  }
}

if (buildPage) await page();
await extension();
await tests();
const size = readFileSync(join(root, 'preview/dist/preview.js')).length;
console.log(`built: preview.js ${(size / 1024).toFixed(0)} KiB, extension, tests`);
