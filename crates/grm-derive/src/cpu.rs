//! Whether this CPU and OS run AVX2 code (the rewrite's and the edit
//! filter's AVX2 builds), from three `cpuid` leaves and `xgetbv`.
//!
//! `std::arch::is_x86_feature_detected!` reads every feature at its first
//! use, about eight `cpuid` instructions, and each one exits to the
//! hypervisor on a virtual machine: 9-13 us apiece on the development VM,
//! about 65 us of a one-shot `grmc derive`'s 3 ms (docs/benchmarks.md,
//! "Two threads that pay on short scenes, and a cheaper one-shot
//! process"). Only AVX2 is asked for here, so only its leaves are read:
//! the highest leaf (0), AVX and OS-saved state (1, then `xgetbv`), AVX2
//! (7). The answer is the one std gives: AVX2 in leaf 7, AVX and OSXSAVE
//! in leaf 1, and the OS saving the SSE and AVX registers (XCR0 bits 1
//! and 2).

#[cfg(target_arch = "x86_64")]
pub(crate) fn avx2() -> bool {
    use std::sync::atomic::{AtomicU8, Ordering};
    /// 0: not read yet; 1: no; 2: yes.
    static AVX2: AtomicU8 = AtomicU8::new(0);
    match AVX2.load(Ordering::Relaxed) {
        1 => false,
        2 => true,
        _ => {
            let yes = detect();
            AVX2.store(if yes { 2 } else { 1 }, Ordering::Relaxed);
            yes
        }
    }
}

#[cfg(target_arch = "x86_64")]
fn detect() -> bool {
    use std::arch::x86_64::{__cpuid, __cpuid_count};
    if __cpuid(0).eax < 7 {
        return false;
    }
    let ecx = __cpuid(1).ecx;
    let (osxsave, avx) = (ecx & (1 << 27) != 0, ecx & (1 << 28) != 0);
    if !(osxsave && avx) || xcr0() & 0b110 != 0b110 {
        return false;
    }
    __cpuid_count(7, 0).ebx & (1 << 5) != 0
}

/// The extended control register 0: which register states the OS saves.
#[cfg(target_arch = "x86_64")]
fn xcr0() -> u64 {
    #[target_feature(enable = "xsave")]
    fn read() -> u64 {
        // SAFETY: `xgetbv` is available where OSXSAVE is set, which the
        // only caller (`detect`) checked first; reading XCR0 has no side
        // effect.
        #[allow(unsafe_code)]
        unsafe {
            std::arch::x86_64::_xgetbv(0)
        }
    }
    // SAFETY: the `xsave` feature `read` is compiled for is only its
    // `xgetbv` instruction, which OSXSAVE (checked by the caller) makes
    // available.
    #[allow(unsafe_code)]
    unsafe {
        read()
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_is_what_std_detects() {
        assert_eq!(super::avx2(), std::arch::is_x86_feature_detected!("avx2"));
        // Cached: the same answer again.
        assert_eq!(super::avx2(), std::arch::is_x86_feature_detected!("avx2"));
    }
}
