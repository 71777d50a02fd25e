// grm's one-shot derivation against the npm `lindenmayer` library 1.5.4
// (JavaScript, string mode: one character per module, no parameters), on
// the classic scenes, interleaved round by round. Run by scripts/peers-js.sh.
//
//   node scripts/peers-js.mjs GRMC ROUNDS LINDENMAYER_DIR [BASE_GRMC]
//
// With BASE_GRMC (an older build of grmc), each round also runs it, so the
// before/after ratios come from the same run on a busy machine.
//
// A JavaScript run is a fresh LSystem instance, `iterate(n)` and one read
// of the final string (`getString()`, which flattens it). A grm run is one
// `grmc derive FILE -n N --threads 1` process: its own figure for the
// derivation (fresh engine, fresh memory) and the whole process's wall time,
// twice: started by node's `spawnSync` (node's figure: it includes node's
// own cost of starting a process, a fork of node, pipes, an event loop:
// about 1.5 ms here, more than a small process lives) and by
// LINDENMAYER_DIR/spawn-time where scripts/peers-js.sh built it
// (scripts/spawn-time.c: posix_spawn, the process alone, start to exit).
// The process/js ratio is the lean spawner's where there is one.
import { spawnSync } from 'node:child_process';
import { existsSync } from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';

const [grmc, roundsArg, libDir, baseGrmc] = process.argv.slice(2);
const rounds = Number(roundsArg ?? 15);
const require = createRequire(path.join(path.resolve(libDir), 'index.js'));
const spawner = path.join(path.resolve(libDir), 'spawn-time');
const lean = existsSync(spawner);
const LSystem = require('lindenmayer');

const scenes = [
  { name: 'koch_island', file: 'examples/koch_island.grm', n: 6,
    axiom: 'F-F-F-F', productions: { F: 'F-F+F+FF-F-F+F' } },
  { name: 'bracketed_plant', file: 'examples/bracketed_plant.grm', n: 6,
    axiom: 'F', productions: { F: 'FF-[-F+F+F]+[+F-F-F]' } },
  { name: 'hilbert3d', file: 'examples/hilbert3d.grm', n: 6,
    axiom: 'A', productions: {
      A: 'B-F+CFC+F-D&F^D-F+&&CFC+F+B//',
      B: 'A&F^CFB^F^D^^-F-D^|F^B|FC^F^A//',
      C: '|D^|F^B-F+C^F^A&&FA&F^C+F+B^F^D//',
      D: '|CFB-F+B|FA&F^A&&FB-F+B|FC//',
    } },
];

const median = (v) => { const s = [...v].sort((a, b) => a - b); return s[Math.floor(s.length / 2)]; };

// One `grmc derive` process, started by node (`viaLean` false) or by the
// lean spawner: [its derivation's own figure, the process's wall time].
const runGrm = (bin, s, len, viaLean) => {
  const args = ['derive', s.file, '-n', String(s.n), '--threads', '1'];
  const t1 = process.hrtime.bigint();
  const g = viaLean
    ? spawnSync(spawner, [path.resolve(bin), ...args], { encoding: 'utf8' })
    : spawnSync(bin, args, { encoding: 'utf8' });
  let proc = Number(process.hrtime.bigint() - t1) / 1e6;
  if (g.status !== 0) throw new Error(`grmc failed: ${g.stderr}`);
  if (viaLean) proc = Number(g.stdout.trim());
  const m = /: ([\d]+) modules? \(.* in ([\d.]+) ms/.exec(g.stderr);
  if (!m || !(proc > 0)) throw new Error(`unexpected grmc output: ${g.stderr} ${g.stdout}`);
  if (Number(m[1]) !== len) throw new Error(`${s.name}: grm made ${m[1]} modules, lindenmayer ${len}`);
  return [Number(m[2]), proc];
};

console.log(`grm against npm lindenmayer 1.5.4 (node ${process.version}), one thread, median of ${rounds} interleaved rounds (ms)`);
console.log(lean ? `process: started by ${spawner} (posix_spawn); node: the same process started by node's spawnSync`
  : 'process: started by node\'s spawnSync (build scripts/spawn-time.c into LINDENMAYER_DIR for the process alone)');
console.log('scene              n     final |  js (derive+read)  grm derive  grm process' + (lean ? '   node' : '') +
  ' | derive/js  process/js' + (lean ? '  node/js' : '') +
  (baseGrmc ? ' |  base derive base process | derive/base process/base' : ''));
for (const s of scenes) {
  const js = [], derive = [], proc = [], nproc = [], bderive = [], bproc = [], rd = [], rp = [];
  let len = 0;
  for (let r = 0; r < rounds; r++) {
    const t0 = process.hrtime.bigint();
    const l = new LSystem({ axiom: s.axiom, productions: s.productions });
    l.iterate(s.n);
    const out = l.getString();
    js.push(Number(process.hrtime.bigint() - t0) / 1e6);
    len = out.length;
    // With a base, which of the two runs first alternates round by round
    // (a process run right after another of the same kind is faster).
    const baseFirst = baseGrmc && r % 2 === 1;
    const b = baseFirst ? runGrm(baseGrmc, s, len, lean) : null;
    const [d, p] = runGrm(grmc, s, len, lean);
    derive.push(d);
    proc.push(p);
    if (baseGrmc) {
      const [bd, bp] = b ?? runGrm(baseGrmc, s, len, lean);
      bderive.push(bd);
      bproc.push(bp);
      rd.push(d / bd);
      rp.push(p / bp);
    }
    if (lean) nproc.push(runGrm(grmc, s, len, false)[1]);
  }
  const [j, d, p] = [median(js), median(derive), median(proc)];
  let line = `${s.name.padEnd(16)} ${String(s.n).padStart(2)} ${String(len).padStart(9)} | ${j.toFixed(2).padStart(17)} ${d.toFixed(2).padStart(11)} ${p.toFixed(2).padStart(12)}` +
    (lean ? ` ${median(nproc).toFixed(2).padStart(6)}` : '') +
    ` | ${(d / j).toFixed(2).padStart(9)} ${(p / j).toFixed(2).padStart(11)}` +
    (lean ? ` ${(median(nproc) / j).toFixed(2).padStart(8)}` : '');
  if (baseGrmc) {
    // Ratios pair by pair (round by round), then their median.
    line += ` | ${median(bderive).toFixed(2).padStart(12)} ${median(bproc).toFixed(2).padStart(12)} | ${median(rd).toFixed(2).padStart(11)} ${median(rp).toFixed(2).padStart(12)}`;
  }
  console.log(line);
}
