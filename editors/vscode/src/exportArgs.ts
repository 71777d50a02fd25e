// The `grmc` command line that exports what the preview shows: `grmc derive`
// for derived systems, `grmc sample --curves` for guided ones, with the
// preview's seed and meta-parameters, and for a picture the preview's camera
// (or its view's direction); with `--frames`, every iteration (derive) or
// generation (sample) as NAME-K.EXT beside the output. Pure, unit-tested.

import { type CameraParams, usableCamera } from '../../preview/src/messages.js';

// The picture's size from the preview canvas' (the page's "Save picture" sizes its pictures the same way).
export { pictureSize } from '../../preview/src/picture.js';

export type ExportFormat = 'glb' | 'obj' | 'png';

/** Within `grmc --image-size`'s limits: whole sides of 1 to 16384 pixels, at most 4096 x 4096 pixels in all. */
function validImageSize(width: number, height: number): boolean {
  return Number.isInteger(width) && Number.isInteger(height) && width >= 1 && height >= 1 && width <= 16384 && height <= 16384 && width * height <= 4096 * 4096;
}

export interface ExportRequest {
  grammar: string;
  output: string;
  mode: 'derive' | 'sample';
  seed?: number;
  params?: Record<string, unknown>;
  /** The curves file (sample mode). */
  curves?: string;
  /** Sample mode: the generation of the search the preview shows (`--generation`); none: the result. Never with `frames`. */
  generation?: number;
  /**
   * `--frames`: the model (or picture) of every iteration 0..N (derive), or
   * what the search returns when stopped after each generation (sample), as
   * NAME-K.EXT beside `output`. grmc refuses `--generation` with it, so the
   * generation is left out.
   */
  frames?: boolean;
  system?: string;
  /** With a .png output: where the camera looks from, in degrees (`--view`); none: grmc's own choice. */
  view?: { azimuth: number; elevation: number };
  /** With a .png output: the preview's camera (`--camera`, `--look-at`, `--fov`), in place of `view` where it is usable. */
  camera?: CameraParams;
  /** With a .png output: the picture's size in pixels (`--image-size`); none: grmc's 1024x1024. */
  imageSize?: { width: number; height: number };
}

/** Two decimals are plenty for degrees; -0 is written 0. */
function round2(x: number): number {
  return Math.round(x * 100) / 100 || 0;
}

/**
 * A finite number as grmc reads it back exactly: JavaScript's shortest
 * round-trip form (an exponent such as `1e-7` or `1e+21` is one Rust's
 * parser takes; -0 is written 0). Rounded coordinates could make a camera
 * and the point it looks at one point, which grmc refuses.
 */
function exact(x: number): string {
  return String(x);
}

export function exportArgs(r: ExportRequest): string[] {
  const args = [r.mode === 'sample' ? 'sample' : 'derive', r.grammar];
  if (r.system) args.push('--system', r.system);
  if (r.mode === 'sample' && r.curves) args.push('--curves', r.curves);
  if (r.frames) args.push('--frames');
  else if (r.mode === 'sample' && r.generation !== undefined && Number.isInteger(r.generation) && r.generation >= 0) {
    args.push('--generation', String(r.generation));
  }
  if (r.seed !== undefined && Number.isInteger(r.seed) && r.seed >= 0) args.push('--seed', String(r.seed));
  for (const [name, value] of Object.entries(r.params ?? {}).sort(([a], [b]) => (a < b ? -1 : a > b ? 1 : 0))) {
    if (typeof value === 'number' && Number.isFinite(value)) args.push('--param', `${name}=${value}`);
  }
  // The picture flags: grmc refuses them for any other output.
  if (/\.png$/i.test(r.output)) {
    const v = r.view;
    // Only numbers grmc draws through (finite, two points, a field of view it takes); else the view's angles.
    const c = usableCamera(r.camera);
    if (c) {
      // One argument each with `=`: a negative coordinate is not taken for a flag.
      args.push(`--camera=${c.position.map(exact).join(',')}`, `--look-at=${c.target.map(exact).join(',')}`, `--fov=${exact(c.fov)}`);
    } else if (v && Number.isFinite(v.azimuth) && Number.isFinite(v.elevation)) {
      // One argument with `=`: a negative azimuth is not taken for a flag.
      args.push(`--view=${round2(v.azimuth)},${round2(Math.max(-90, Math.min(90, v.elevation)))}`);
    }
    const s = r.imageSize;
    if (s && validImageSize(s.width, s.height)) args.push(`--image-size=${s.width}x${s.height}`);
  }
  args.push('-o', r.output);
  return args;
}

/**
 * The mode of the file's first system, which `grmc` exports when no system
 * is named: `sample` when that system's block says `mode = sample`, else
 * `derive`. Read from the text when no preview has said it; comments and
 * strings do not count, nor do later systems.
 */
export function firstSystemMode(text: string): 'derive' | 'sample' {
  const code = text.replace(/\/\/[^\n]*|\/\*[\s\S]*?\*\/|"(?:[^"\\\n]|\\.)*"/g, (m) => ' '.repeat(m.length));
  const start = /\bsystem\s+[A-Za-z_]\w*\s*\{/.exec(code);
  if (!start) return 'derive';
  let depth = 0;
  let end = code.length;
  for (let i = start.index + start[0].length - 1; i < code.length; i++) {
    if (code[i] === '{') depth++;
    else if (code[i] === '}' && --depth === 0) {
      end = i;
      break;
    }
  }
  return /\bmode\s*=\s*sample\b/.test(code.slice(start.index, end)) ? 'sample' : 'derive';
}

/** The default output path: the grammar's name with the format's extension. */
export function defaultOutput(grammar: string, format: ExportFormat): string {
  return `${grammar.replace(/\.grm$/i, '')}.${format}`;
}

/** A path's folder and file name, at its last `/` or `\\` (grmc's paths are the platform's). */
function splitPath(p: string): { dir: string; base: string } {
  const i = Math.max(p.lastIndexOf('/'), p.lastIndexOf('\\'));
  return { dir: i < 0 ? '' : i === 0 ? p[0]! : p.slice(0, i), base: p.slice(i + 1) };
}

function escapeRegExp(s: string): string {
  return s.replace(/[.*+?^${}()|[\]\\]/g, '\\$&');
}

/**
 * Whether `file` is one of the frames `grmc --frames -o output` writes:
 * NAME-K.EXT (K in decimal, zero-padded) in output's folder.
 */
export function isFrameOf(output: string, file: string): boolean {
  const o = splitPath(output);
  const f = splitPath(file);
  if (f.dir !== o.dir && f.dir !== '') return false;
  const dot = o.base.lastIndexOf('.');
  const [stem, ext] = dot > 0 ? [o.base.slice(0, dot), o.base.slice(dot)] : [o.base, ''];
  return new RegExp(`^${escapeRegExp(stem)}-\\d+${escapeRegExp(ext)}$`).test(f.base);
}

/**
 * The frames grmc says it wrote (its `wrote PATH (what)` lines on stderr),
 * in order; other files it names (an OBJ's materials) and other lines do
 * not count.
 */
export function framesWritten(log: string, output: string): string[] {
  const files: string[] = [];
  for (const line of log.split(/\r?\n/)) {
    const m = /^wrote (.+?)(?: \([^()]*\))?$/.exec(line);
    if (m && isFrameOf(output, m[1]!)) files.push(m[1]!);
  }
  return files;
}

/** What the frames export says when done: how many files, the first and last, and the folder. */
export function framesSummary(files: string[], output: string): string {
  const dir = splitPath(output).dir || '.';
  if (files.length === 0) return `grmc wrote no frames in ${dir}`;
  const first = splitPath(files[0]!).base;
  // An OBJ's materials are written beside it (NAME-K.mtl).
  const mtl = /\.obj$/i.test(output) ? (files.length === 1 ? ', with its .mtl' : ', each with its .mtl') : '';
  if (files.length === 1) return `Wrote 1 frame (${first}${mtl}) in ${dir}`;
  return `Wrote ${files.length} frames (${first} ... ${splitPath(files[files.length - 1]!).base}${mtl}) in ${dir}`;
}
