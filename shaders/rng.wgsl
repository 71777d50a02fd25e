// The counter-based random draws of grm_compile::rng, bit for bit:
// MurmurHash3 x86_32 of the key (iteration, position, draw) with the seed,
// and the uniform float f32(h >> 8) * 2^-24. u32 arithmetic wraps in WGSL
// as in Rust's wrapping ops.

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

fn rng_hash(seed: u32, iteration: u32, position: u32, draw: u32) -> u32 {
    var h = seed;
    h = mm3_mix(h, iteration);
    h = mm3_mix(h, position);
    h = mm3_mix(h, draw);
    h = h ^ 12u;
    h = h ^ (h >> 16u);
    h = h * 0x85ebca6bu;
    h = h ^ (h >> 13u);
    h = h * 0xc2b2ae35u;
    return h ^ (h >> 16u);
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
