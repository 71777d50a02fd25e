// Preview protocol 3 over stdio (docs/lsp-extensions.md, "Binary
// buffers"): the language server writes a preview's buffers as a frame of
// their own before the message that names them,
//
//   Content-Length: N\r\n
//   Content-Type: application/vnd.grm.blob\r\n
//   Grm-Blob: ID\r\n
//   \r\n
//   <N bytes>
//
// `BlobFrames` sits between the server's stdout and vscode-languageclient:
// it keeps those frames' bytes (by id, for the host to take and post to the
// page as an ArrayBuffer) and passes every other frame through unchanged,
// streaming its body. A blob is stored before any later message is passed
// on, so it is there when the answer or notification naming it is handled.
// Free of the `vscode` module (unit-tested under node).

import { Transform, type TransformCallback } from 'node:stream';

const BLOB_TYPE = 'application/vnd.grm.blob';
/** The longest header block read (a frame's headers are a few dozen bytes). */
const MAX_HEADERS = 8192;

/** The blobs read and not yet taken: the newest `keep` of them. */
export class BlobShelf {
  private readonly blobs = new Map<number, ArrayBuffer>();

  constructor(private readonly keep = 8) {}

  put(id: number, data: ArrayBuffer): void {
    this.blobs.delete(id);
    this.blobs.set(id, data);
    while (this.blobs.size > this.keep) {
      const oldest = this.blobs.keys().next().value;
      if (oldest === undefined) break;
      this.blobs.delete(oldest);
    }
  }

  /** The blob `id`, removed from the shelf (undefined: never read, or dropped as old). */
  take(id: number): ArrayBuffer | undefined {
    const b = this.blobs.get(id);
    this.blobs.delete(id);
    return b;
  }

  get size(): number {
    return this.blobs.size;
  }
}

type State =
  | { kind: 'headers' }
  | { kind: 'pass'; left: number }
  | { kind: 'blob'; id: number; data: Uint8Array; at: number };

export class BlobFrames extends Transform {
  private head: Buffer = Buffer.alloc(0);
  private state: State = { kind: 'headers' };

  constructor(private readonly shelf: BlobShelf) {
    super();
  }

  override _transform(chunk: Buffer, _enc: BufferEncoding, done: TransformCallback): void {
    let buf: Buffer = chunk;
    while (buf.length > 0) {
      const st = this.state;
      if (st.kind === 'pass') {
        const n = Math.min(st.left, buf.length);
        this.push(buf.subarray(0, n));
        buf = buf.subarray(n);
        st.left -= n;
        if (st.left === 0) this.state = { kind: 'headers' };
      } else if (st.kind === 'blob') {
        const n = Math.min(st.data.length - st.at, buf.length);
        st.data.set(buf.subarray(0, n), st.at);
        buf = buf.subarray(n);
        st.at += n;
        if (st.at === st.data.length) {
          this.shelf.put(st.id, st.data.buffer as ArrayBuffer);
          this.state = { kind: 'headers' };
        }
      } else {
        this.head = this.head.length === 0 ? buf : Buffer.concat([this.head, buf]);
        buf = Buffer.alloc(0);
        const end = this.head.indexOf('\r\n\r\n');
        if (end < 0) {
          if (this.head.length > MAX_HEADERS) {
            // Not ours to judge: pass it on for the client's reader to report.
            this.push(this.head);
            this.head = Buffer.alloc(0);
          }
          break;
        }
        const headers = this.head.subarray(0, end + 4);
        const rest = this.head.subarray(end + 4);
        this.head = Buffer.alloc(0);
        const fields = new Map<string, string>();
        for (const line of headers.toString('ascii').split('\r\n')) {
          const colon = line.indexOf(':');
          if (colon > 0) fields.set(line.slice(0, colon).trim().toLowerCase(), line.slice(colon + 1).trim());
        }
        const length = Number(fields.get('content-length'));
        const id = Number(fields.get('grm-blob'));
        if (fields.get('content-type') === BLOB_TYPE && Number.isSafeInteger(length) && length >= 0 && Number.isSafeInteger(id)) {
          this.state = { kind: 'blob', id, data: new Uint8Array(length), at: 0 };
          if (length === 0) {
            this.shelf.put(id, new ArrayBuffer(0));
            this.state = { kind: 'headers' };
          }
        } else {
          this.push(headers);
          if (Number.isSafeInteger(length) && length > 0) this.state = { kind: 'pass', left: length };
        }
        buf = rest;
      }
    }
    done();
  }
}
