// The TextMate grammar, tokenized by the same engine VS Code uses.
import assert from 'node:assert/strict';
import { readFileSync, readdirSync } from 'node:fs';
import { createRequire } from 'node:module';
import { join } from 'node:path';
import { test } from 'node:test';
import type * as Oniguruma from 'vscode-oniguruma';
import type * as Textmate from 'vscode-textmate';

// Both are CommonJS packages.
const require = createRequire(import.meta.url);
const oniguruma = require('vscode-oniguruma') as typeof Oniguruma;
const textmate = require('vscode-textmate') as typeof Textmate;
const editors = join(import.meta.dirname, '../..');

async function grammar(): Promise<Textmate.IGrammar> {
  const wasm = readFileSync(require.resolve('vscode-oniguruma/release/onig.wasm'));
  await oniguruma.loadWASM(wasm.buffer.slice(wasm.byteOffset, wasm.byteOffset + wasm.byteLength));
  const registry = new textmate.Registry({
    onigLib: Promise.resolve({ createOnigScanner: (p) => new oniguruma.OnigScanner(p), createOnigString: (s) => new oniguruma.OnigString(s) }),
    loadGrammar: async () => textmate.parseRawGrammar(readFileSync(join(editors, 'vscode/syntaxes/grm.tmLanguage.json'), 'utf8'), 'grm.tmLanguage.json'),
  });
  const g = await registry.loadGrammar('source.grm');
  assert.ok(g);
  return g;
}

/** [text, innermost scope] for every token of every line. */
function tokens(g: Textmate.IGrammar, text: string): Array<[string, string]> {
  let stack = textmate.INITIAL;
  const out: Array<[string, string]> = [];
  for (const line of text.split('\n')) {
    const r = g.tokenizeLine(line, stack);
    for (const t of r.tokens) {
      const s = line.slice(t.startIndex, t.endIndex);
      if (s.trim()) out.push([s.trim(), t.scopes[t.scopes.length - 1]]);
    }
    stack = r.ruleStack;
  }
  return out;
}

const scopeOf = (toks: Array<[string, string]>, text: string) => toks.filter(([t]) => t === text).map(([, s]) => s);

test('keywords, settings, numbers, strings and comments', async () => {
  const g = await grammar();
  const toks = tokens(g, `import "common.grm"; // shared\nparam spread = 30 in 10 .. 60;\n/* block\n still */ system Plant {\n  mode = sample;\n  iterations = 5;\n  axiom X;\n}`);
  assert.deepEqual(scopeOf(toks, 'import'), ['keyword.control.import.grm']);
  assert.deepEqual(scopeOf(toks, 'common.grm'), ['string.quoted.double.grm']);
  assert.deepEqual(scopeOf(toks, 'shared'), ['comment.line.double-slash.grm']);
  assert.deepEqual(scopeOf(toks, 'param'), ['keyword.declaration.grm']);
  assert.deepEqual(scopeOf(toks, 'spread'), ['variable.other.constant.grm']);
  assert.deepEqual(scopeOf(toks, '30'), ['constant.numeric.grm']);
  assert.deepEqual(scopeOf(toks, 'block'), ['comment.block.grm']);
  assert.deepEqual(scopeOf(toks, 'still'), ['comment.block.grm']);
  assert.deepEqual(scopeOf(toks, 'Plant'), ['entity.name.type.class.grm']);
  assert.deepEqual(scopeOf(toks, 'mode'), ['variable.other.property.setting.grm']);
  assert.deepEqual(scopeOf(toks, 'sample'), ['constant.language.mode.grm']);
  assert.deepEqual(scopeOf(toks, 'axiom'), ['keyword.other.axiom.grm']);
  assert.deepEqual(scopeOf(toks, 'X'), ['entity.name.type.module.grm']);
});

test('productions: turtle symbols, terminals, modules and expressions in parameters', async () => {
  const g = await grammar();
  const toks = tokens(g, `A(l, w) : l > 5 -> F(l * 0.9) [ + A(uniform(0, 1), w) ] / / rotx(30) sphere(0.1) A;`);
  assert.deepEqual(scopeOf(toks, 'F'), ['support.function.turtle.grm']);
  assert.deepEqual(scopeOf(toks, '['), ['punctuation.section.brackets.turtle.grm']);
  assert.deepEqual(scopeOf(toks, '+'), ['keyword.operator.turtle.grm']);
  assert.deepEqual(scopeOf(toks, '/'), ['keyword.operator.turtle.grm', 'keyword.operator.turtle.grm']);
  assert.deepEqual(scopeOf(toks, 'uniform'), ['support.function.random.grm']);
  assert.deepEqual(scopeOf(toks, 'rotx'), ['support.function.turtle.grm']);
  assert.deepEqual(scopeOf(toks, 'sphere'), ['support.function.turtle.grm']);
  assert.ok(scopeOf(toks, '*').includes('keyword.operator.arithmetic.grm'), 'arithmetic inside a parameter');
  assert.ok(scopeOf(toks, 'A').includes('entity.name.type.module.grm'));
  assert.deepEqual(scopeOf(toks, '->'), ['keyword.operator.arrow.grm']);
});

// `vec3` is a type (`const UP: vec3 = ...`) and a function (`vec3(0, 1, 0)`);
// outside parentheses the call was scoped as the type, e.g. in the
// `tropism = vec3(0, -1, 0);` setting of docs/language.md.
test('vec3: the type in a declaration, the built-in function in a call at any depth', async () => {
  const g = await grammar();
  const toks = tokens(g, `const UP: vec3 = vec3(0, 1, 0);\nsystem S {\n  tropism = vec3 (0, -1, 0);\n  module A(v: vec3);\n  axiom A(vec3(1, 2, 3));\n  A(v) -> translate(vec3(v.x, 0, 0)) A(v);\n}`);
  assert.deepEqual(scopeOf(toks, 'vec3'), [
    'storage.type.grm',
    'support.function.builtin.grm',
    'support.function.builtin.grm',
    'storage.type.grm',
    'support.function.builtin.grm',
    'support.function.builtin.grm',
  ]);
});

test('every example grammar tokenizes without a stray scope at the end', async () => {
  const g = await grammar();
  const examples = join(editors, '../examples');
  const files = readdirSync(examples).filter((f) => f.endsWith('.grm'));
  assert.ok(files.length >= 10, files.join(' '));
  for (const f of files) {
    let stack = textmate.INITIAL;
    for (const line of readFileSync(join(examples, f), 'utf8').split('\n')) stack = g.tokenizeLine(line, stack).ruleStack;
    // Back at the top level: no unclosed comment, string, successor or parenthesis.
    const probe = g.tokenizeLine('system Probe', stack);
    assert.deepEqual(probe.tokens[0].scopes, ['source.grm', 'keyword.declaration.system.grm'], `${f}: ends inside ${probe.tokens[0].scopes.join(' ')}`);
  }
});
