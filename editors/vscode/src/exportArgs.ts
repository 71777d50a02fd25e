// The `grmc` command line that exports what the preview shows: `grmc derive`
// for derived systems, `grmc sample --curves` for guided ones, with the
// preview's seed and meta-parameters. Pure, unit-tested.

export type ExportFormat = 'glb' | 'obj';

export interface ExportRequest {
  grammar: string;
  output: string;
  mode: 'derive' | 'sample';
  seed?: number;
  params?: Record<string, unknown>;
  /** The curves file (sample mode). */
  curves?: string;
  system?: string;
}

export function exportArgs(r: ExportRequest): string[] {
  const args = [r.mode === 'sample' ? 'sample' : 'derive', r.grammar];
  if (r.system) args.push('--system', r.system);
  if (r.mode === 'sample' && r.curves) args.push('--curves', r.curves);
  if (r.seed !== undefined && Number.isInteger(r.seed) && r.seed >= 0) args.push('--seed', String(r.seed));
  for (const [name, value] of Object.entries(r.params ?? {}).sort(([a], [b]) => (a < b ? -1 : a > b ? 1 : 0))) {
    if (typeof value === 'number' && Number.isFinite(value)) args.push('--param', `${name}=${value}`);
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
  return grammar.replace(/\.grm$/i, '') + (format === 'glb' ? '.glb' : '.obj');
}
