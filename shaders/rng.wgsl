// The counter-based random draws of grm_compile::rng, bit for bit:
// MurmurHash3 x86_32 of the key (iteration, position, draw) with the seed,
// and the uniform float f32(h >> 8) * 2^-24; and the identity keys'
// `child_key`. u32 arithmetic wraps in WGSL as in Rust's wrapping ops.
// (`position` is the drawing module's identity key: grm_compile::rng,
// "Identity keys".)

fn rotl32(x: u32, r: u32) -> u32 {
    return (x << r) | (x >> (32u - r));
}

fn mm3_mix(h: u32, k0: u32) -> u32 {
    var k = k0 * 0xcc9e2d51u;
    k = rotl32(k, 15u);
    k = k * 0x1b873593u;
    var x = h ^ k;
    x = rotl32(x, 13u);
    return x * 5u + 0xe6546b64u;
}

// The MurmurHash3 finalizer.
fn mm3_fmix(h0: u32) -> u32 {
    var h = h0;
    h = h ^ (h >> 16u);
    h = h * 0x85ebca6bu;
    h = h ^ (h >> 13u);
    h = h * 0xc2b2ae35u;
    return h ^ (h >> 16u);
}

fn rng_hash(seed: u32, iteration: u32, position: u32, draw: u32) -> u32 {
    return rng_finish(rng_prefix(seed, iteration, position), draw);
}

// The part of rng_hash that does not depend on the draw index
// (grm_compile::rng::hash_prefix), for several draws of one module.
fn rng_prefix(seed: u32, iteration: u32, position: u32) -> u32 {
    return mm3_mix(mm3_mix(seed, iteration), position);
}

// rng_hash from its prefix (grm_compile::rng::hash_finish): the same value.
fn rng_finish(prefix: u32, draw: u32) -> u32 {
    return mm3_fmix(mm3_mix(prefix, draw) ^ 12u);
}

// The key of a module written by a rewrite (grm_compile::rng::child_key):
// MurmurHash3 x86_32 of the 4-byte key `salt` (its successor module's
// compile-time salt) with the parent's key as the seed.
fn child_key(parent: u32, salt: u32) -> u32 {
    return mm3_fmix(mm3_mix(parent, salt) ^ 4u);
}

fn rng_unit(h: u32) -> f32 {
    return f32(h >> 8u) * (1.0 / 16777216.0);
}

struct Draws {
    seed: u32,
    iteration: u32,
    position: u32,
}

fn rng_uniform(d: Draws, draw: u32) -> f32 {
    return rng_unit(rng_hash(d.seed, d.iteration, d.position, draw));
}
