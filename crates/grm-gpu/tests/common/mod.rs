//! Shared helpers of the GPU tests.

/// The shared GPU. GPU tests never skip: without an adapter they fail here
/// with the reason and the fix.
pub fn gpu() -> &'static grm_gpu::Gpu {
    match grm_gpu::shared() {
        Ok(g) => g,
        Err(e) => panic!(
            "GPU tests need a GPU adapter and found none: {e}\n\
             (scripts/test.sh installs Mesa's lavapipe: apt-get install mesa-vulkan-drivers libvulkan1)"
        ),
    }
}

/// A small deterministic PRNG for test inputs (splitmix64).
#[derive(Debug)]
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n`.
    pub fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
}
