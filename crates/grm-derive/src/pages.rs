//! Huge pages for fresh string buffers.
//!
//! A derivation writes every string once into fresh memory, and a cold run
//! (one `grmc derive`) spends most of its time in the page faults of that
//! memory: one per 4 KiB. Linux backs a mapping with 2 MiB pages on fault
//! when transparent huge pages are `always`, or when they are `madvise`
//! (the default of many distributions) and the mapping asked for them.
//! [`advise_huge`] asks, for buffers large enough to hold whole huge pages,
//! before they are first written. It is advice: where the kernel declines,
//! has no huge pages or is not Linux, nothing changes.

/// Buffers smaller than this are left alone (they cannot hold a whole,
/// aligned huge page, or would gain nothing).
const MIN_BYTES: usize = 4 << 20;

/// Ask the OS to back `v`'s untouched memory with huge pages.
#[cfg(target_os = "linux")]
pub(crate) fn advise_huge<T>(v: &[T]) {
    const HUGE: usize = 2 << 20;
    let bytes = std::mem::size_of_val(v);
    if bytes < MIN_BYTES {
        return;
    }
    let start = v.as_ptr() as usize;
    let first = start.div_ceil(HUGE) * HUGE;
    let end = (start + bytes) / HUGE * HUGE;
    if end <= first {
        return;
    }
    // SAFETY: `madvise` with `MADV_HUGEPAGE` changes no memory contents and
    // no mapping's protection: it only marks pages of the range as
    // eligible for huge pages. The range [first, end) is 2 MiB aligned and
    // lies inside `v`'s allocation, which this slice borrows, so it is
    // mapped for the whole call. A failure (an old kernel, THP off) leaves
    // the memory as it was, so the result is ignored.
    #[allow(unsafe_code)]
    unsafe {
        libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
    }
}

/// Other systems: nothing to ask.
#[cfg(not(target_os = "linux"))]
pub(crate) fn advise_huge<T>(_v: &[T]) {}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    /// The `VmFlags` of the mapping that holds `addr` (/proc/self/smaps).
    fn vm_flags(addr: usize) -> String {
        let smaps = std::fs::read_to_string("/proc/self/smaps").expect("/proc/self/smaps");
        let mut inside = false;
        for line in smaps.lines() {
            if let Some((range, _)) = line.split_once(' ')
                && let Some((a, b)) = range.split_once('-')
                && let (Ok(a), Ok(b)) = (usize::from_str_radix(a, 16), usize::from_str_radix(b, 16))
            {
                inside = a <= addr && addr < b;
            } else if inside && let Some(flags) = line.strip_prefix("VmFlags:") {
                return flags.trim().to_string();
            }
        }
        panic!("no mapping holds {addr:#x}")
    }

    #[test]
    fn a_large_fresh_buffer_is_marked_for_huge_pages_and_keeps_its_contents() {
        let mut v = vec![0u32; 8 << 20];
        let mid = v.as_ptr() as usize + (16 << 20);
        assert!(!vm_flags(mid).split(' ').any(|f| f == "hg"));
        advise_huge(&v);
        // A kernel built without transparent huge pages refuses the advice.
        if std::path::Path::new("/sys/kernel/mm/transparent_hugepage").exists() {
            assert!(
                vm_flags(mid).split(' ').any(|f| f == "hg"),
                "{}",
                vm_flags(mid)
            );
        }
        // Writable and zeroed as before.
        assert!(v.iter().all(|&x| x == 0));
        v[12345] = 7;
        assert_eq!(v.iter().map(|&x| u64::from(x)).sum::<u64>(), 7);
    }

    #[test]
    fn small_and_empty_buffers_are_left_alone() {
        let v: Vec<u64> = Vec::new();
        advise_huge(&v);
        let w = vec![1u8; MIN_BYTES - 1];
        advise_huge(&w);
        assert!(w.iter().all(|&x| x == 1));
    }
}
