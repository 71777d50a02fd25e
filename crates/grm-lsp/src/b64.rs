//! Base64 (standard alphabet, `=` padding) of the preview's buffers,
//! written with a table of the 4,096 two-character pairs: six input bytes
//! become eight characters through one 48-bit read and four look-ups, where
//! the `base64` crate's general engine makes eight. The preview encodes a
//! 10,000-window building's 5.4 MB of positions and picks on every regrow
//! (issue 26); the text is the same as `base64`'s `STANDARD` (tested).
//!
//! Words go in blocks of [`BLOCK`] bytes, a whole number of 3-byte groups,
//! so the text of the blocks is that of all the bytes encoded at once,
//! without a copy of the whole buffer as bytes.

const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// The two characters of each 12-bit value.
static PAIRS: [[u8; 2]; 4096] = pairs();

const fn pairs() -> [[u8; 2]; 4096] {
    let mut t = [[0u8; 2]; 4096];
    let mut i = 0;
    while i < 4096 {
        t[i] = [ALPHABET[i >> 6], ALPHABET[i & 63]];
        i += 1;
    }
    t
}

/// Bytes per block of words: 3,060 (255 quads' three corners, 765 words,
/// 1,020 groups of three bytes).
pub(crate) const BLOCK: usize = 3060;

/// The length of the base64 text of `n` bytes.
pub(crate) fn encoded_len(n: usize) -> usize {
    n.div_ceil(3) * 4
}

/// Characters of a full block.
const OUT_BLOCK: usize = BLOCK / 3 * 4;

/// Writes the base64 of `src` (at most [`BLOCK`] bytes) to `dst`, padded;
/// returns its length.
fn encode_block(src: &[u8], dst: &mut [u8; OUT_BLOCK]) -> usize {
    let len = encoded_len(src.len());
    // Twelve bytes (96 bits, eight 12-bit values) at a time.
    let whole = src.len() / 12;
    let (src12, rest) = src.split_at(whole * 12);
    let (dst16, dst_rest) = dst[..len].split_at_mut(whole * 16);
    for (s, d) in src12.chunks_exact(12).zip(dst16.chunks_exact_mut(16)) {
        let mut hi = [0u8; 8];
        hi.copy_from_slice(&s[..8]);
        let mut lo = [0u8; 4];
        lo.copy_from_slice(&s[8..]);
        let a = u64::from_be_bytes(hi);
        let b = u32::from_be_bytes(lo);
        let g = [
            (a >> 52) as usize,
            (a >> 40) as usize & 0xfff,
            (a >> 28) as usize & 0xfff,
            (a >> 16) as usize & 0xfff,
            (a >> 4) as usize & 0xfff,
            ((a as usize & 0xf) << 8) | (b >> 24) as usize,
            (b >> 12) as usize & 0xfff,
            b as usize & 0xfff,
        ];
        for (d, g) in d.chunks_exact_mut(2).zip(g) {
            d.copy_from_slice(&PAIRS[g]);
        }
    }
    // Then whole groups of three bytes, and the padded end.
    let groups = rest.len() / 3;
    let (src3, last) = rest.split_at(groups * 3);
    let (dst4, dst_last) = dst_rest.split_at_mut(groups * 4);
    for (s, d) in src3.chunks_exact(3).zip(dst4.chunks_exact_mut(4)) {
        let n = (usize::from(s[0]) << 16) | (usize::from(s[1]) << 8) | usize::from(s[2]);
        d[0..2].copy_from_slice(&PAIRS[n >> 12]);
        d[2..4].copy_from_slice(&PAIRS[n & 0xfff]);
    }
    if let [d0, d1, d2, d3] = dst_last {
        let b0 = usize::from(last[0]);
        let b1 = last.get(1).map_or(0, |&b| usize::from(b));
        *d0 = ALPHABET[b0 >> 2];
        *d1 = ALPHABET[((b0 & 3) << 4) | (b1 >> 4)];
        *d2 = if last.len() == 2 {
            ALPHABET[(b1 & 15) << 2]
        } else {
            b'='
        };
        *d3 = b'=';
    }
    len
}

/// Appends the base64 of `bytes` to `out`, padded: a caller that appends
/// more after it passes a whole number of 3-byte groups.
pub(crate) fn encode_into(bytes: &[u8], out: &mut Vec<u8>) {
    let mut buf = [0u8; OUT_BLOCK];
    for block in bytes.chunks(BLOCK) {
        let n = encode_block(block, &mut buf);
        out.extend_from_slice(&buf[..n]);
    }
}

/// The text of `out` (base64 is ASCII).
pub(crate) fn into_string(out: Vec<u8>) -> String {
    String::from_utf8(out).unwrap_or_else(|e| String::from_utf8_lossy(e.as_bytes()).into_owned())
}

/// The base64 of `bytes`.
pub(crate) fn encode(bytes: &[u8]) -> String {
    let mut out = Vec::with_capacity(encoded_len(bytes.len()));
    encode_into(bytes, &mut out);
    into_string(out)
}

/// The base64 of `xs`'s 4-byte words (`to`: a word's little-endian
/// bytes), encoded block by block.
pub(crate) fn words<T: Copy>(xs: &[T], to: fn(T) -> [u8; 4]) -> String {
    const WORDS: usize = BLOCK / 4;
    let mut out = Vec::with_capacity(encoded_len(xs.len() * 4));
    let mut block = [0u8; BLOCK];
    let mut buf = [0u8; OUT_BLOCK];
    for chunk in xs.chunks(WORDS) {
        for (d, &x) in block.chunks_exact_mut(4).zip(chunk) {
            d.copy_from_slice(&to(x));
        }
        let k = encode_block(&block[..chunk.len() * 4], &mut buf);
        out.extend_from_slice(&buf[..k]);
    }
    into_string(out)
}

/// The base64 of the first three corners of each quad of `positions`
/// (four corners per quad; the fourth is `a + c - b`), as `f32`s x, y, z.
pub(crate) fn quad_corners(positions: &[[f32; 3]]) -> String {
    const QUADS: usize = BLOCK / 36;
    let mut out = Vec::with_capacity(encoded_len(positions.len() / 4 * 36));
    let mut block = [0u8; BLOCK];
    let mut buf = [0u8; OUT_BLOCK];
    for chunk in positions.chunks(4 * QUADS) {
        let mut n = 0;
        for q in chunk.chunks_exact(4) {
            let [a, b, c] = [q[0], q[1], q[2]];
            let xs = [a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]];
            for (d, x) in block[n..n + 36].chunks_exact_mut(4).zip(xs) {
                d.copy_from_slice(&x.to_le_bytes());
            }
            n += 36;
        }
        let k = encode_block(&block[..n], &mut buf);
        out.extend_from_slice(&buf[..k]);
    }
    into_string(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use base64::Engine as _;
    use base64::engine::general_purpose::STANDARD;

    /// Bytes from a small generator (xorshift), every value likely.
    fn bytes(n: usize, seed: u64) -> Vec<u8> {
        let mut x = seed | 1;
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x >> 24) as u8
            })
            .collect()
    }

    #[test]
    fn the_text_is_the_base64_crates() {
        for n in 0..200 {
            let b = bytes(n, n as u64 + 7);
            assert_eq!(encode(&b), STANDARD.encode(&b), "{n} bytes");
        }
        let big = bytes(3 * BLOCK + 17, 3);
        assert_eq!(encode(&big), STANDARD.encode(&big));
        let all: Vec<u8> = (0..=255).collect();
        assert_eq!(encode(&all), STANDARD.encode(&all));
    }

    #[test]
    fn words_and_quads_across_blocks() {
        for n in [0, 1, 2, 3, 764, 765, 766, 1530, 2000] {
            let xs: Vec<u32> = bytes(n * 4, n as u64 + 1)
                .chunks_exact(4)
                .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            let raw: Vec<u8> = xs.iter().flat_map(|x| x.to_le_bytes()).collect();
            assert_eq!(
                words(&xs, u32::to_le_bytes),
                STANDARD.encode(&raw),
                "{n} words"
            );
        }
        for quads in [0, 1, 2, 254, 255, 256, 600] {
            let ps: Vec<[f32; 3]> = (0..quads * 4)
                .map(|i| [i as f32, -(i as f32) * 0.5, 1e-3 * i as f32])
                .collect();
            let raw: Vec<u8> = ps
                .chunks_exact(4)
                .flat_map(|q| q[..3].iter().flatten().flat_map(|x| x.to_le_bytes()))
                .collect();
            assert_eq!(quad_corners(&ps), STANDARD.encode(&raw), "{quads} quads");
        }
    }
}
