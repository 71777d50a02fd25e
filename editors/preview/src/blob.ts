// Preview protocol 3 (docs/lsp-extensions.md, "Binary buffers"): an answer
// whose `encoding` is `blob-le` names its buffers as `{ at, bytes }` ranges
// of one binary blob that travels beside the JSON (VS Code: a frame of its
// own in the server's output, read by the extension host and posted to the
// page as an ArrayBuffer; `grmc view`: `GET /api/blob/ID`). The transports
// put each range's bytes in place of the range (`attachBlob`), so the
// decoders see `Uint8Array`s where protocol 2 has base64 text; a range is a
// view of the blob, not a copy (ranges start at multiples of 4, so a
// `Float32Array` views them too).

function isObject(v: unknown): v is Record<string, unknown> {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

/** An answer's `blob`: `{ id, bytes }` when its buffers are ranges of a blob (`encoding: "blob-le"`), else null. */
export function blobRef(result: unknown): { id: number; bytes: number } | null {
  if (!isObject(result) || result.encoding !== 'blob-le' || !isObject(result.blob)) return null;
  const { id, bytes } = result.blob;
  if (typeof id !== 'number' || !Number.isSafeInteger(id) || typeof bytes !== 'number' || !Number.isSafeInteger(bytes) || bytes < 0) return null;
  return { id, bytes };
}

/** The buffer fields of a part and of the skeleton. */
const PART_BUFFERS = ['positions', 'normals', 'indices', 'picks'] as const;
const SKELETON_BUFFERS = ['bones', 'parents', 'origins'] as const;

/** What went wrong putting a blob in place (the message says which buffer). */
export class BlobError extends Error {}

function place(holder: Record<string, unknown>, key: string, data: ArrayBuffer, what: string): void {
  const r = holder[key];
  if (!isObject(r)) return; // base64 text, empty, or absent
  const { at, bytes } = r;
  if (typeof at !== 'number' || typeof bytes !== 'number' || !Number.isSafeInteger(at) || !Number.isSafeInteger(bytes) || at < 0 || bytes < 0) {
    throw new BlobError(`${what}: not a range of the blob`);
  }
  if (at + bytes > data.byteLength) throw new BlobError(`${what}: bytes ${at}..${at + bytes} are outside the blob of ${data.byteLength}`);
  holder[key] = new Uint8Array(data, at, bytes);
}

/**
 * Puts the bytes of `data` (the blob an answer names) in place of the
 * answer's ranges, in place; returns the answer. An answer without a blob
 * is returned as it is. Throws `BlobError` when the blob is missing, of
 * another length, or a range lies outside it.
 */
export function attachBlob(result: unknown, data: ArrayBuffer | undefined): unknown {
  const ref = blobRef(result);
  if (!ref || !isObject(result)) return result;
  if (!data) throw new BlobError(`the preview's buffers (blob ${ref.id}) did not arrive`);
  if (data.byteLength !== ref.bytes) throw new BlobError(`blob ${ref.id}: ${data.byteLength} bytes where the answer says ${ref.bytes}`);
  if (Array.isArray(result.parts)) {
    result.parts.forEach((p: unknown, i: number) => {
      if (isObject(p)) for (const k of PART_BUFFERS) place(p, k, data, `parts[${i}].${k}`);
    });
  }
  if (isObject(result.skeleton)) for (const k of SKELETON_BUFFERS) place(result.skeleton, k, data, `skeleton.${k}`);
  return result;
}

/** A `grm/previewUpdated`'s params with its result's blob in place. */
export function attachBlobToUpdate(params: unknown, data: ArrayBuffer | undefined): unknown {
  if (isObject(params) && blobRef(params.result)) attachBlob(params.result, data);
  return params;
}
