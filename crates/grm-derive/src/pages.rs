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

/// A server's allocator keeps what it frees: glibc gives blocks of up to
/// 32 MiB (its largest mapping threshold) from its heap instead of fresh
/// mappings, and trims the heap only past 1 GiB free, so a model regrown
/// again and again reuses the pages of the one before instead of
/// faulting in new ones (a fifth of a building's regrow was the kernel
/// zeroing and mapping pages).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn keep_freed_memory() {
    // SAFETY: mallopt only sets the allocator's tunables; it is called
    // once, when the process begins serving.
    #[allow(unsafe_code)]
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 30);
    }
}

/// Elsewhere: the system allocator as it is.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn keep_freed_memory() {}

/// A global allocator that gives large allocations their own 2 MiB-aligned
/// mappings marked for transparent huge pages, and everything else to the
/// system allocator ([`std::alloc::System`]).
///
/// Why: a one-shot derivation writes each string into fresh memory, and a
/// string of a few MiB (the bracketed plant at 6 iterations: three arrays
/// of 2.2 to 2.8 MiB) is faulted in a 4 KiB page at a time, about 2 us a
/// fault on the development VM: most of a `grmc derive` run.
/// [`advise_huge`] can only mark the aligned 2 MiB blocks inside a buffer
/// the system allocator placed anywhere (none in a 2.8 MiB buffer, often),
/// so a binary that installs this allocator (`grmc`) gets every large
/// buffer whole in huge pages, where the kernel's THP setting is `madvise`
/// or `always`: one fault per 2 MiB, and as cheap to unmap
/// (docs/benchmarks.md, "One-shot derivation").
///
/// Large: [`LARGE_BYTES`] or more, with an alignment of at most 2 MiB. Such
/// a block is an anonymous mapping of its size rounded up to 2 MiB (what a
/// huge page holds; at most 2 MiB more memory once it is all touched), so
/// freeing it returns it to the OS at once, and growing it moves its pages
/// (`mremap`) instead of copying them. Elsewhere than Linux it is the
/// system allocator.
///
/// A long-running process that grows a model again and again (the
/// language server, `grmc view`) is better served by the system
/// allocator, which reuses the memory it freed: each fresh mapping here is
/// zeroed by the kernel, and mapping and unmapping from several threads
/// serialise on the process's address space (the shape preview's regrow
/// was 1.4x slower, its two-thread derivation 4-20x). Such a process calls
/// [`HugePageAlloc::serve`] first, before its first large allocation.
#[derive(Clone, Copy, Debug, Default)]
pub struct HugePageAlloc;

/// [`HugePageAlloc`]'s mode: undecided until the first large allocation
/// (which makes it [`MAPPING`]) or [`HugePageAlloc::serve`] (which makes
/// it [`SERVING`]); never changed after, so a block is freed the way it
/// was made.
static MODE: std::sync::atomic::AtomicU8 = std::sync::atomic::AtomicU8::new(UNDECIDED);
const UNDECIDED: u8 = 0;
const MAPPING: u8 = 1;
const SERVING: u8 = 2;

impl HugePageAlloc {
    /// Give every allocation to the system allocator from now on (a
    /// server: see the type's doc). Refused, returning `false`, once a
    /// large block has been mapped (it must be unmapped as it was made).
    pub fn serve() -> bool {
        use std::sync::atomic::Ordering;
        let now =
            match MODE.compare_exchange(UNDECIDED, SERVING, Ordering::AcqRel, Ordering::Acquire) {
                Ok(_) => true,
                Err(m) => return m == SERVING,
            };
        keep_freed_memory();
        now
    }

    /// Whether large blocks are mapped in huge pages (not serving).
    pub fn maps_huge_pages() -> bool {
        MODE.load(std::sync::atomic::Ordering::Acquire) != SERVING
    }
}

/// The smallest allocation [`HugePageAlloc`] maps itself. Zeroing a whole
/// huge page costs about as much as faulting in a fifth of it 4 KiB at a
/// time on the development VM, so even a block of an eighth of one is
/// faster in a huge page: `grmc derive` with 256 KiB against 1 MiB here,
/// same build otherwise, 31 alternating runs, medians: 0.67-0.97 of the
/// time (load 5-6). What it costs is memory: at most 2 MiB more per large
/// block once it is all touched.
pub const LARGE_BYTES: usize = 256 << 10;

#[cfg(target_os = "linux")]
mod huge_alloc {
    use std::alloc::{GlobalAlloc, Layout, System};

    const HUGE: usize = 2 << 20;

    /// Whether a block of this layout is (or was) made by mapping: large,
    /// and the allocator not serving (the first large block decides the
    /// mode for good, `super::MODE`).
    fn large(size: usize, align: usize) -> bool {
        use std::sync::atomic::Ordering;
        if size < super::LARGE_BYTES || align > HUGE {
            return false;
        }
        match super::MODE.load(Ordering::Acquire) {
            super::MAPPING => true,
            super::SERVING => false,
            _ => match super::MODE.compare_exchange(
                super::UNDECIDED,
                super::MAPPING,
                Ordering::AcqRel,
                Ordering::Acquire,
            ) {
                Ok(_) => true,
                Err(m) => m == super::MAPPING,
            },
        }
    }

    /// `size` rounded up to whole huge pages (`None` past the address
    /// space).
    fn rounded(size: usize) -> Option<usize> {
        size.checked_add(HUGE - 1).map(|s| s & !(HUGE - 1))
    }

    /// A fresh zeroed mapping of `len` bytes (a multiple of 2 MiB) that
    /// starts on a 2 MiB boundary, marked for huge pages; null on failure.
    fn map(len: usize) -> *mut u8 {
        let Some(over) = len.checked_add(HUGE) else {
            return std::ptr::null_mut();
        };
        // SAFETY: an anonymous private mapping at an address of the
        // kernel's choosing touches no existing memory. The head and tail
        // cut off below lie inside this fresh mapping, which nothing else
        // refers to yet; what stays is [start, start + len), 2 MiB-aligned
        // and inside `over`'s range since `start - p < HUGE`. `madvise`
        // only marks that range for huge pages (it changes no contents and
        // no protection); its failure (THP off) is harmless.
        #[allow(unsafe_code)]
        unsafe {
            let p = libc::mmap(
                std::ptr::null_mut(),
                over,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                -1,
                0,
            );
            if p == libc::MAP_FAILED {
                return std::ptr::null_mut();
            }
            let p = p as usize;
            let start = p.div_ceil(HUGE) * HUGE;
            if start > p {
                libc::munmap(p as *mut libc::c_void, start - p);
            }
            let end = p + over;
            if end > start + len {
                libc::munmap((start + len) as *mut libc::c_void, end - start - len);
            }
            libc::madvise(start as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
            start as *mut u8
        }
    }

    // SAFETY: small blocks are the system allocator's, with its contract.
    // A large block (decided by the layout alone, so `dealloc` and
    // `realloc` classify a block as `alloc` did) is a mapping of exactly
    // `rounded(size)` bytes at a 2 MiB boundary, so it satisfies any
    // alignment up to 2 MiB, holds `size` bytes, is zeroed (fresh anonymous
    // memory, which `alloc_zeroed` relies on), and is unmapped with that
    // same length.
    #[allow(unsafe_code)]
    unsafe impl GlobalAlloc for super::HugePageAlloc {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            if large(layout.size(), layout.align()) {
                return rounded(layout.size()).map_or(std::ptr::null_mut(), map);
            }
            // SAFETY: the caller's contract, passed on.
            unsafe { System.alloc(layout) }
        }

        unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
            if large(layout.size(), layout.align()) {
                // Fresh anonymous memory reads as zeros.
                return rounded(layout.size()).map_or(std::ptr::null_mut(), map);
            }
            // SAFETY: the caller's contract, passed on.
            unsafe { System.alloc_zeroed(layout) }
        }

        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            if large(layout.size(), layout.align()) {
                if let Some(len) = rounded(layout.size()) {
                    // SAFETY: `ptr` is a mapping of `len` bytes made by
                    // `map` for this layout (the caller's contract).
                    unsafe { libc::munmap(ptr.cast(), len) };
                }
                return;
            }
            // SAFETY: the caller's contract, passed on.
            unsafe { System.dealloc(ptr, layout) }
        }

        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            let align = layout.align();
            match (large(layout.size(), align), large(new_size, align)) {
                (false, false) => {
                    // SAFETY: the caller's contract, passed on.
                    unsafe { System.realloc(ptr, layout, new_size) }
                }
                (true, true) if align <= 4096 => {
                    let (Some(old), Some(new)) = (rounded(layout.size()), rounded(new_size)) else {
                        return std::ptr::null_mut();
                    };
                    if old == new {
                        return ptr;
                    }
                    // SAFETY: `ptr` is a mapping of `old` bytes (as in
                    // `dealloc`). `mremap` keeps its contents and its
                    // huge-page advice and resizes or moves it whole (so
                    // on success the old address is no longer the
                    // caller's, as `realloc` allows); grown pages are
                    // fresh zeros. The new address is page-aligned, which
                    // covers `align` (at most a page here), though maybe
                    // not 2 MiB-aligned: that only costs huge pages.
                    let q = unsafe { libc::mremap(ptr.cast(), old, new, libc::MREMAP_MAYMOVE) };
                    if q == libc::MAP_FAILED {
                        return std::ptr::null_mut();
                    }
                    q.cast()
                }
                _ => {
                    // Across the threshold, or aligned beyond a page: a
                    // new block and a copy.
                    let Ok(new_layout) = Layout::from_size_align(new_size, align) else {
                        return std::ptr::null_mut();
                    };
                    // SAFETY: `new_layout` has a non-zero size (the caller's
                    // contract: `new_size > 0`) and a valid alignment.
                    let q = unsafe { self.alloc(new_layout) };
                    if !q.is_null() {
                        // SAFETY: both blocks are live and distinct, each
                        // at least `min` bytes long; the old one is the
                        // caller's to give up.
                        unsafe {
                            std::ptr::copy_nonoverlapping(ptr, q, layout.size().min(new_size));
                            self.dealloc(ptr, layout);
                        }
                    }
                    q
                }
            }
        }
    }
}

/// Other systems: the system allocator.
#[cfg(not(target_os = "linux"))]
#[allow(unsafe_code)]
// SAFETY: every call is the system allocator's.
unsafe impl std::alloc::GlobalAlloc for HugePageAlloc {
    unsafe fn alloc(&self, layout: std::alloc::Layout) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        unsafe { std::alloc::System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: std::alloc::Layout) {
        // SAFETY: the caller's contract, passed on.
        unsafe { std::alloc::System.dealloc(ptr, layout) }
    }
}

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

    /// Once a large block is mapped, the allocator cannot start serving
    /// (that block must be unmapped as it was made). (Serving itself is
    /// not tested here: it would change the mode for every test of this
    /// binary; the shape_regrow bench serves from its start.)
    #[test]
    #[allow(unsafe_code)]
    fn serving_is_refused_after_a_block_was_mapped() {
        use std::alloc::{GlobalAlloc, Layout};
        let a = HugePageAlloc;
        let layout = Layout::from_size_align(LARGE_BYTES, 8).expect("layout");
        // SAFETY: a non-zero size; the block is freed with its layout.
        let p = unsafe { a.alloc(layout) };
        assert!(!p.is_null());
        assert_eq!(p as usize % (2 << 20), 0, "a 2 MiB-aligned mapping");
        assert!(!HugePageAlloc::serve());
        assert!(HugePageAlloc::maps_huge_pages());
        // SAFETY: made above with this layout.
        unsafe { a.dealloc(p, layout) };
    }

    #[test]
    fn small_and_empty_buffers_are_left_alone() {
        let v: Vec<u64> = Vec::new();
        advise_huge(&v);
        let w = vec![1u8; MIN_BYTES - 1];
        advise_huge(&w);
        assert!(w.iter().all(|&x| x == 1));
    }

    /// The allocator's blocks, through its `GlobalAlloc` calls: large ones
    /// 2 MiB-aligned, zeroed, marked for huge pages; contents kept by
    /// every `realloc` (within the large sizes, across the threshold both
    /// ways, among small ones).
    #[test]
    #[allow(unsafe_code)]
    fn huge_page_alloc_blocks_keep_their_contents() {
        use std::alloc::{GlobalAlloc, Layout};
        let a = HugePageAlloc;
        let fill = |p: *mut u8, n: usize, seed: u8| {
            for i in 0..n {
                // SAFETY: `p` holds at least `n` bytes (each caller).
                unsafe { *p.add(i) = seed.wrapping_add((i % 251) as u8) };
            }
        };
        let same = |p: *const u8, n: usize, seed: u8| {
            // SAFETY: `p` holds at least `n` initialized bytes.
            (0..n).all(|i| unsafe { *p.add(i) } == seed.wrapping_add((i % 251) as u8))
        };
        // SAFETY: every block is used within its size and freed once, with
        // the layout (size and alignment) it has at that moment.
        unsafe {
            let big = Layout::from_size_align(3 << 20, 8).expect("layout");
            let p = a.alloc_zeroed(big);
            assert!(!p.is_null());
            assert_eq!(p as usize % (2 << 20), 0, "2 MiB-aligned");
            assert!((0..big.size()).step_by(4093).all(|i| *p.add(i) == 0));
            let flags = vm_flags(p as usize + (1 << 20));
            if std::path::Path::new("/sys/kernel/mm/transparent_hugepage").exists() {
                assert!(flags.split(' ').any(|f| f == "hg"), "{flags}");
            }
            fill(p, big.size(), 1);
            // Grow within the large sizes (moved by mremap), then shrink.
            let q = a.realloc(p, big, 9 << 20);
            assert!(!q.is_null());
            assert!(same(q, big.size(), 1));
            assert!((big.size()..9 << 20).step_by(4093).all(|i| *q.add(i) == 0));
            let l9 = Layout::from_size_align(9 << 20, 8).expect("layout");
            let r = a.realloc(q, l9, (2 << 20) + 5);
            assert!(same(r, (2 << 20) + 5, 1));
            // Across the threshold: down to a small block and back up.
            let l2 = Layout::from_size_align((2 << 20) + 5, 8).expect("layout");
            let s = a.realloc(r, l2, 1000);
            assert!(same(s, 1000, 1));
            let small = Layout::from_size_align(1000, 8).expect("layout");
            let t = a.realloc(s, small, LARGE_BYTES + 1);
            assert!(same(t, 1000, 1));
            assert_eq!(t as usize % (2 << 20), 0);
            a.dealloc(
                t,
                Layout::from_size_align(LARGE_BYTES + 1, 8).expect("layout"),
            );
            // A large block aligned beyond a page, grown: still aligned.
            let wide = Layout::from_size_align(LARGE_BYTES, 1 << 16).expect("layout");
            let u = a.alloc(wide);
            fill(u, wide.size(), 7);
            let v = a.realloc(u, wide, 5 << 20);
            assert_eq!(v as usize % (1 << 16), 0);
            assert!(same(v, wide.size(), 7));
            a.dealloc(
                v,
                Layout::from_size_align(5 << 20, 1 << 16).expect("layout"),
            );
            // Small blocks are the system allocator's.
            let w = a.alloc(small);
            fill(w, 1000, 3);
            let x = a.realloc(w, small, 5000);
            assert!(same(x, 1000, 3));
            a.dealloc(x, Layout::from_size_align(5000, 8).expect("layout"));
        }
        // And as a `Vec`'s allocator would see it: a large zeroed vector.
        let v: Vec<u32> = vec![0; 1 << 20];
        assert!(v.iter().all(|&x| x == 0));
    }
}
