//! Preview protocol 3: the answer's buffers as binary beside a small JSON
//! message (docs/lsp-extensions.md, "Binary buffers").
//!
//! A `grm/preview` with `"binary": true`, on a server that has somewhere
//! to send bytes ([`BlobSink`]), is answered with every buffer (positions,
//! normals, indices, picks, the skeleton's arrays) as `{ "at", "bytes" }`:
//! a range of one blob of little-endian words, named by the answer's
//! `"blob": { "id", "bytes" }`. The blob goes before the message that
//! names it: over stdio as a frame of its own in the server's output
//! (`Content-Type: application/vnd.grm.blob`, `Grm-Blob: ID`; written by
//! [`crate::stdio::merge_output`]), in process (`grmc view`) into a
//! [`BlobStore`] that the HTTP server serves. Without `binary` (or without
//! a sink) the buffers are base64 text in the JSON, as in protocol 2.
//!
//! Why: a 10,000-window building's answer is 7.2 MB of base64, and
//! writing it as JSON text (serde_json scans every character for escapes)
//! and reading it back (the client's JSON parse, then a base64 decode)
//! cost more than building it (issue 26).

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

/// One buffer of an answer.
#[derive(Clone, Debug, PartialEq)]
pub enum Buf {
    /// Base64 text (protocol 2; `""` for an empty buffer in either).
    Text(String),
    /// Bytes not yet placed in a blob ([`crate::preview::PreviewResult::take_blob`]);
    /// written as base64 if they never are.
    Bytes(Vec<u8>),
    /// A range of the answer's blob.
    At { at: u64, bytes: u64 },
}

impl Default for Buf {
    fn default() -> Buf {
        Buf::Text(String::new())
    }
}

#[derive(Serialize, Deserialize)]
struct Range {
    at: u64,
    bytes: u64,
}

impl Serialize for Buf {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Buf::Text(t) => s.serialize_str(t),
            Buf::Bytes(b) => s.serialize_str(&crate::b64::encode(b)),
            Buf::At { at, bytes } => Range {
                at: *at,
                bytes: *bytes,
            }
            .serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for Buf {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Buf, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Wire {
            Text(String),
            At(Range),
        }
        Ok(match Wire::deserialize(d)? {
            Wire::Text(t) => Buf::Text(t),
            Wire::At(r) => Buf::At {
                at: r.at,
                bytes: r.bytes,
            },
        })
    }
}

impl Buf {
    /// The base64 text (protocol 2), if this is text.
    pub fn text(&self) -> Option<&str> {
        match self {
            Buf::Text(t) => Some(t),
            _ => None,
        }
    }

    /// Nothing in it.
    pub fn is_empty(&self) -> bool {
        match self {
            Buf::Text(t) => t.is_empty(),
            Buf::Bytes(b) => b.is_empty(),
            Buf::At { bytes, .. } => *bytes == 0,
        }
    }

    /// Its bytes: base64 decoded, or its range of `blob` (None: bad base64,
    /// or a range outside the blob).
    pub fn decode(&self, blob: &[u8]) -> Option<Vec<u8>> {
        use base64::Engine as _;
        match self {
            Buf::Text(t) => base64::engine::general_purpose::STANDARD.decode(t).ok(),
            Buf::Bytes(b) => Some(b.clone()),
            Buf::At { at, bytes } => {
                let at = usize::try_from(*at).ok()?;
                let end = at.checked_add(usize::try_from(*bytes).ok()?)?;
                blob.get(at..end).map(<[u8]>::to_vec)
            }
        }
    }

    /// Places bytes at `*at` of a blob being gathered in `chunks`.
    pub(crate) fn place(&mut self, at: &mut u64, chunks: &mut Vec<Vec<u8>>) {
        if let Buf::Bytes(b) = self {
            let b = std::mem::take(b);
            let bytes = b.len() as u64;
            *self = Buf::At { at: *at, bytes };
            *at += bytes;
            chunks.push(b);
        }
    }
}

/// Moves the bytes of `bufs` into one blob's chunks, in order, each
/// buffer becoming its range: the blob's length and chunks, or `None`
/// when none had bytes (base64 text already).
pub(crate) fn gather<'a>(
    bufs: impl IntoIterator<Item = &'a mut Buf>,
) -> Option<(u64, Vec<Vec<u8>>)> {
    let (mut at, mut chunks) = (0, Vec::new());
    for b in bufs {
        b.place(&mut at, &mut chunks);
    }
    (!chunks.is_empty()).then_some((at, chunks))
}

/// How an answer's buffers are written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Enc {
    /// Base64 text in the JSON (protocol 2).
    #[default]
    Base64,
    /// Bytes for the blob (protocol 3).
    Binary,
}

/// `xs` as little-endian bytes.
fn le_bytes<T: Copy, const N: usize>(xs: &[T], le: fn(T) -> [u8; N]) -> Vec<u8> {
    let mut out = vec![0u8; xs.len() * N];
    for (d, &x) in out.chunks_exact_mut(N).zip(xs) {
        d.copy_from_slice(&le(x));
    }
    out
}

impl Enc {
    pub(crate) fn f32s(self, xs: &[f32]) -> Buf {
        match self {
            Enc::Base64 => Buf::Text(crate::b64::words(xs, f32::to_le_bytes)),
            Enc::Binary => Buf::Bytes(le_bytes(xs, f32::to_le_bytes)),
        }
    }

    pub(crate) fn u32s(self, xs: &[u32]) -> Buf {
        match self {
            Enc::Base64 => Buf::Text(crate::b64::words(xs, u32::to_le_bytes)),
            Enc::Binary => Buf::Bytes(le_bytes(xs, u32::to_le_bytes)),
        }
    }

    pub(crate) fn i32s(self, xs: &[i32]) -> Buf {
        match self {
            Enc::Base64 => Buf::Text(crate::b64::words(xs, i32::to_le_bytes)),
            Enc::Binary => Buf::Bytes(le_bytes(xs, i32::to_le_bytes)),
        }
    }

    /// Bytes already laid out (the picks).
    pub(crate) fn bytes(self, b: Vec<u8>) -> Buf {
        match self {
            Enc::Base64 => Buf::Text(crate::b64::encode(&b)),
            Enc::Binary => Buf::Bytes(b),
        }
    }

    /// A quads mesh's positions (`layout: "quads"`): the corners `a b c`
    /// of each quad of four vertices.
    pub(crate) fn quad_corners(self, positions: &[[f32; 3]]) -> Buf {
        match self {
            Enc::Base64 => Buf::Text(crate::b64::quad_corners(positions)),
            Enc::Binary => {
                let quads = positions.len() / 4;
                let mut out = vec![0u8; quads * 36];
                for (d, q) in out.chunks_exact_mut(36).zip(positions.chunks_exact(4)) {
                    for (d, x) in d.chunks_exact_mut(4).zip(q[..3].as_flattened()) {
                        d.copy_from_slice(&x.to_le_bytes());
                    }
                }
                Buf::Bytes(out)
            }
        }
    }
}

/// An answer's `blob`: which one, and its length.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
pub struct BlobRef {
    pub id: u64,
    pub bytes: u64,
}

/// The bytes of one answer's buffers, in the order of their ranges.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Blob {
    pub id: u64,
    pub chunks: Vec<Vec<u8>>,
}

impl Blob {
    pub fn len(&self) -> usize {
        self.chunks.iter().map(Vec::len).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// All its bytes in one buffer.
    pub fn to_vec(&self) -> Vec<u8> {
        self.chunks.concat()
    }
}

/// The blobs kept in process for a client to fetch (`grmc view`'s
/// `GET /api/blob/ID`): the newest [`BlobStore::KEEP`], and while they
/// hold more than [`BlobStore::MAX_BYTES`], fewer (never none).
#[derive(Debug, Default)]
pub struct BlobStore {
    blobs: Mutex<VecDeque<Arc<Blob>>>,
}

impl BlobStore {
    pub const KEEP: usize = 8;
    pub const MAX_BYTES: usize = 512 << 20;

    pub fn put(&self, blob: Blob) {
        let mut q = self.blobs.lock().unwrap_or_else(|e| e.into_inner());
        q.push_back(Arc::new(blob));
        while q.len() > Self::KEEP
            || (q.len() > 1 && q.iter().map(|b| b.len()).sum::<usize>() > Self::MAX_BYTES)
        {
            q.pop_front();
        }
    }

    /// The blob `id`, if it is still kept.
    pub fn get(&self, id: u64) -> Option<Arc<Blob>> {
        let q = self.blobs.lock().unwrap_or_else(|e| e.into_inner());
        q.iter().rev().find(|b| b.id == id).cloned()
    }
}

/// Where a server with binary buffers sends its blobs.
#[derive(Clone, Debug)]
pub enum BlobSink {
    /// Frames in the stdio output, before the message that names them.
    Frames(tokio::sync::mpsc::UnboundedSender<Blob>),
    /// Kept in process for the client to fetch.
    Store(Arc<BlobStore>),
}

impl BlobSink {
    pub(crate) fn send(&self, blob: Blob) {
        match self {
            // A closed output has no client to read it.
            BlobSink::Frames(tx) => {
                let _ = tx.send(blob);
            }
            BlobSink::Store(s) => s.put(blob),
        }
    }
}

/// The header of a blob's frame in the stdio output.
pub fn frame_header(blob: &Blob) -> Vec<u8> {
    format!(
        "Content-Length: {}\r\nContent-Type: application/vnd.grm.blob\r\nGrm-Blob: {}\r\n\r\n",
        blob.len(),
        blob.id
    )
    .into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binary_words_are_the_base64_words() {
        use base64::Engine as _;
        let xs = [1.5f32, -2.0, 0.1, f32::MAX];
        let Buf::Bytes(b) = Enc::Binary.f32s(&xs) else {
            panic!("bytes")
        };
        let Buf::Text(t) = Enc::Base64.f32s(&xs) else {
            panic!("text")
        };
        assert_eq!(base64::engine::general_purpose::STANDARD.encode(&b), t);
        let q: Vec<[f32; 3]> = (0..8).map(|i| [i as f32, 2.0 * i as f32, -1.0]).collect();
        let Buf::Bytes(b) = Enc::Binary.quad_corners(&q) else {
            panic!("bytes")
        };
        assert_eq!(b.len(), 2 * 36);
        assert_eq!(Enc::Base64.quad_corners(&q).decode(&[]), Some(b));
    }

    #[test]
    fn placed_buffers_read_back_from_the_blob() {
        let mut a = Enc::Binary.u32s(&[1, 2, 3]);
        let mut b = Enc::Binary.i32s(&[-1]);
        let mut c = Buf::Text(String::new());
        let (mut at, mut chunks) = (0, Vec::new());
        for x in [&mut a, &mut b, &mut c] {
            x.place(&mut at, &mut chunks);
        }
        assert_eq!(a, Buf::At { at: 0, bytes: 12 });
        assert_eq!(b, Buf::At { at: 12, bytes: 4 });
        assert!(c.is_empty());
        let blob = Blob { id: 1, chunks }.to_vec();
        assert_eq!(b.decode(&blob), Some((-1i32).to_le_bytes().to_vec()));
        assert_eq!(Buf::At { at: 12, bytes: 8 }.decode(&blob), None);
        let json = serde_json::to_string(&a).unwrap();
        assert_eq!(json, r#"{"at":0,"bytes":12}"#);
        assert_eq!(serde_json::from_str::<Buf>(&json).unwrap(), a);
        // Bytes never placed go as base64.
        assert_eq!(
            serde_json::to_string(&Enc::Binary.u32s(&[1])).unwrap(),
            r#""AQAAAA==""#
        );
    }

    #[test]
    fn the_store_keeps_the_newest() {
        let s = BlobStore::default();
        for id in 0..20 {
            s.put(Blob {
                id,
                chunks: vec![vec![0; 4]],
            });
        }
        assert!(s.get(11).is_none());
        assert!(s.get(12).is_some() && s.get(19).is_some());
    }
}
