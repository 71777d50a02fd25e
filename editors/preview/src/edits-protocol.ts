// Persistent edits (issue 27) on the wire: the preview result's `edits`
// (the edits file's edits with their classes and retarget candidates), and
// the `grm/edit` / `grm/removeEdit` requests and their answer
// (docs/lsp-extensions.md, "Persistent edits"). Decoders throw
// ProtocolError on what does not fit, as protocol.ts's do.

import { ProtocolError } from './protocol.js';

/** An edit's class after the last derivation (docs/edits.md, "Classes"). */
export type EditClass = 'valid' | 'structurally_invalid' | 'semantically_invalid' | 'ambiguous' | 'stale';

export const EDIT_CLASSES: readonly EditClass[] = ['valid', 'structurally_invalid', 'semantically_invalid', 'ambiguous', 'stale'];

/** The three kinds of target (docs/edits.md, "Targets"). */
export type TargetKind = 'exact' | 'semantic' | 'key';

/** A target as the file writes it: `{ "exact": "{Lot, 1, ...}" }`, `{ "semantic": "(floor = 3) Window" }`, `{ "key": "0a1b2c3d" }`. */
export interface TargetRef {
  kind: TargetKind;
  text: string;
}

/** A target the preview proposes for an edit that no longer finds its part (best first). */
export interface RetargetCandidate {
  target: TargetRef;
  /** `ordering`, `symbol_and_tags`, `nearest` or `one_of_matched`. */
  reason: string;
  /** The tree nodes the target names. */
  parts: number[];
}

/** One edit of the file, as the last preview classified it. */
export interface EditEntry {
  id: number;
  system: string;
  target: TargetRef;
  /** The operation in words (`material glass`, `force alternative 2`, `remove`). */
  op: string;
  /** One of EDIT_CLASSES; an unknown class from a newer server is kept as it came. */
  class: string;
  /** Why, for an edit that is not valid. */
  detail: string;
  /** Whether it changed the model. */
  replayed: boolean;
  /** Shape mode: the tree nodes its target names now. */
  parts: number[];
  retarget: RetargetCandidate[];
}

/** The preview result's `edits`: the edits file beside the system's grammar. */
export interface EditsInfo {
  /** The edits file. */
  uri: string;
  /** False: there is none (no edits). */
  found: boolean;
  /** Its R0901-R0911 problems (those edits are skipped; `grm/edit` refuses to rewrite such a file). */
  problems: number;
  list: EditEntry[];
}

/** An operation as the file writes it (the fields beside `op`). */
export type EditOp =
  | { op: 'set'; name: string; value: number }
  | { op: 'offset'; name: string; by: number }
  | { op: 'force'; alternative: number }
  | { op: 'pin'; key: string }
  | { op: 'material'; name: string }
  | { op: 'mesh'; name: string }
  | { op: 'remove' };

/** `grm/edit`'s parameters. */
export interface EditParams {
  /** The grammar. */
  uri: string;
  system?: string;
  /** As in the file (`{ exact: ... }`), or its text. */
  target: { exact: string } | { semantic: string } | { key: string };
  op: EditOp;
  note?: string;
}

/** `grm/removeEdit`'s parameters. */
export interface RemoveEditParams {
  uri: string;
  id: number;
  system?: string;
}

/** What `grm/edit` and `grm/removeEdit` answer. */
export interface EditAnswer {
  /** The edits file. */
  uri: string;
  /** The edit added or removed. */
  id: number;
  /** The client applied the workspace edit (or the server wrote the file, `written`). */
  applied: boolean;
  written: boolean;
  failureReason: string | null;
}

function isObject(v: unknown): v is Record<string, unknown> {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

const KEY = /^[0-9a-f]{8}$/;

/** A target object as the file and the preview write it. */
export function decodeTarget(v: unknown, what: string): TargetRef {
  if (!isObject(v)) throw new ProtocolError(`${what}: expected a target object`);
  const kinds = (['exact', 'semantic', 'key'] as const).filter((k) => typeof v[k] === 'string');
  if (kinds.length !== 1) throw new ProtocolError(`${what}: expected exactly one of exact, semantic, key`);
  return { kind: kinds[0], text: v[kinds[0]] as string };
}

/** The target as `grm/edit` takes it. */
export function targetParam(t: TargetRef): EditParams['target'] {
  if (t.kind === 'exact') return { exact: t.text };
  if (t.kind === 'semantic') return { semantic: t.text };
  return { key: t.text };
}

function nodes(v: unknown, what: string): number[] {
  if (v === undefined) return [];
  if (!Array.isArray(v)) throw new ProtocolError(`${what}: expected an array of nodes`);
  return v.map((n: unknown, i: number) => {
    if (typeof n !== 'number' || !Number.isSafeInteger(n) || n < 0) throw new ProtocolError(`${what}[${i}]: expected a node index`);
    return n;
  });
}

/** Decode the preview result's `edits` (null: the server sent none, e.g. sample mode or an older server). */
export function decodeEdits(v: unknown): EditsInfo | null {
  if (v === undefined || v === null) return null;
  if (!isObject(v)) throw new ProtocolError('edits: expected an object');
  const list = (Array.isArray(v.list) ? v.list : []).map((e: unknown, i: number): EditEntry => {
    const what = `edits.list[${i}]`;
    if (!isObject(e)) throw new ProtocolError(`${what}: expected an object`);
    if (typeof e.id !== 'number' || !Number.isSafeInteger(e.id) || e.id < 1) throw new ProtocolError(`${what}.id: expected a whole number from 1`);
    const retarget = (Array.isArray(e.retarget) ? e.retarget : []).map((c: unknown, k: number): RetargetCandidate => {
      if (!isObject(c)) throw new ProtocolError(`${what}.retarget[${k}]: expected an object`);
      return {
        target: decodeTarget(c.target, `${what}.retarget[${k}].target`),
        reason: typeof c.reason === 'string' ? c.reason : '',
        parts: nodes(c.parts, `${what}.retarget[${k}].parts`),
      };
    });
    return {
      id: e.id,
      system: typeof e.system === 'string' ? e.system : '',
      target: decodeTarget(e.target, `${what}.target`),
      op: typeof e.op === 'string' ? e.op : '',
      class: typeof e.class === 'string' ? e.class : '',
      detail: typeof e.detail === 'string' ? e.detail : '',
      replayed: e.replayed === true,
      parts: nodes(e.parts, `${what}.parts`),
      retarget,
    };
  });
  return {
    uri: typeof v.uri === 'string' ? v.uri : '',
    found: v.found === true,
    problems: typeof v.problems === 'number' && Number.isSafeInteger(v.problems) && v.problems >= 0 ? v.problems : 0,
    list,
  };
}

/** Decode `grm/edit`'s or `grm/removeEdit`'s answer. */
export function decodeEditAnswer(v: unknown): EditAnswer {
  if (!isObject(v)) throw new ProtocolError('edit: expected an object');
  if (typeof v.id !== 'number' || !Number.isSafeInteger(v.id) || v.id < 1) throw new ProtocolError('edit: id: expected a whole number from 1');
  return {
    uri: typeof v.uri === 'string' ? v.uri : '',
    id: v.id,
    applied: v.applied === true,
    written: v.written === true,
    failureReason: typeof v.failureReason === 'string' ? v.failureReason : null,
  };
}

/** Whether a pin key is 8 hex digits (what the file takes). */
export function isKey(s: string): boolean {
  return KEY.test(s);
}
