// What every browser test file shares: where grmc, the page and the
// artifacts are, one headless Chromium for the file, `grmc view` servers
// started on a file, pages that collect their errors, and temporary
// folders removed at the end.
import assert from 'node:assert/strict';
import { type ChildProcess, spawn } from 'node:child_process';
import { existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { after, before } from 'node:test';
import { type Browser, type Page } from 'playwright-core';
import { launchChromium } from './chromium.js';

export const root = join(import.meta.dirname, '../../..');
export const artifacts = join(root, 'target/browser-test');
export const grmc = process.env.GRMC ?? join(process.env.CARGO_TARGET_DIR ?? join(root, 'target'), 'debug/grmc');
/** PAGE_DIST=editors/preview/dist serves the page from that folder instead of the copy built into grmc. */
export const pageDist = process.env.PAGE_DIST;

/** The file's browser, servers and temporary folders. */
export interface Harness {
  /** The file's Chromium (launched before its first test). */
  readonly browser: Browser;
  /** Processes killed after the file's last test. */
  readonly servers: ChildProcess[];
  /** A fresh temporary folder, removed after the file's last test. */
  temp(): string;
  /** Start `grmc view FILE [ARGS]` and return the URL it prints. */
  view(file: string, args?: string[]): Promise<string>;
  /** A page at `url` whose errors (`pageErrors`) are collected. */
  openPage(url: string, viewport?: { width: number; height: number }): Promise<Page>;
}

/**
 * Registers the file's `before` (grmc is there, the artifacts folder,
 * Chromium) and `after` (`finish`, then Chromium closed, servers killed,
 * temporary folders removed).
 */
export function harness(finish: () => void = () => {}): Harness {
  let browser: Browser | undefined;
  const servers: ChildProcess[] = [];
  const temps: string[] = [];
  before(async () => {
    assert.ok(existsSync(grmc), `${grmc} is missing: run cargo build -p grmc first`);
    mkdirSync(artifacts, { recursive: true });
    browser = await launchChromium();
  });
  after(async () => {
    finish();
    await browser?.close();
    for (const s of servers) s.kill();
    for (const d of temps) rmSync(d, { recursive: true, force: true });
  });
  const h: Harness = {
    get browser(): Browser {
      assert.ok(browser, 'the browser is launched before the first test');
      return browser;
    },
    servers,
    temp() {
      const dir = mkdtempSync(join(tmpdir(), 'grm-browser-'));
      temps.push(dir);
      return dir;
    },
    view(file, args = []) {
      const proc = spawn(grmc, ['view', file, ...args], { stdio: ['ignore', 'pipe', 'pipe'] });
      servers.push(proc);
      let out = '';
      let err = '';
      proc.stderr?.on('data', (d) => (err += d));
      return new Promise((resolve, reject) => {
        const timer = setTimeout(() => reject(new Error(`grmc view printed no URL in 20 s: ${out} ${err}`)), 20_000);
        proc.stdout?.on('data', (d) => {
          out += d;
          const m = /http:\/\/127\.0\.0\.1:\d+\//.exec(out);
          if (m) {
            clearTimeout(timer);
            resolve(m[0]);
          }
        });
        proc.on('exit', (code) => reject(new Error(`grmc view exited with ${code}: ${err}`)));
      });
    },
    async openPage(url, viewport = { width: 1100, height: 720 }) {
      const page = await h.browser.newPage({ viewport });
      const errors: string[] = [];
      page.on('pageerror', (e) => errors.push(String(e)));
      page.on('console', (m) => {
        if (m.type() === 'error') errors.push(m.text());
      });
      (page as unknown as { errors: string[] }).errors = errors;
      if (pageDist) {
        const types: Record<string, string> = { '': 'text/html', 'index.html': 'text/html', 'preview.js': 'text/javascript', 'preview.css': 'text/css' };
        await page.route(/\/(index\.html|preview\.js|preview\.css)?$/, (route) => {
          const name = new URL(route.request().url()).pathname.slice(1);
          return route.fulfill({ contentType: types[name], body: readFileSync(join(pageDist, name || 'index.html')) });
        });
      }
      await page.goto(url);
      return page;
    },
  };
  return h;
}

/** The errors and console errors of a page opened by `Harness::openPage`. */
export const pageErrors = (page: Page): string[] => (page as unknown as { errors: string[] }).errors;
