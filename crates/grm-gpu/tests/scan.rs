//! The GPU scan against a CPU scan, on random sizes: empty, one, non-powers
//! of two, one block exactly, more than one block and more than one level
//! of block sums.

mod common;
use common::{Rng, gpu};
use grm_gpu::layout::SCAN_BLOCK;
use grm_gpu::scan;

fn cpu_scan(v: &[u32]) -> Vec<u32> {
    let mut s = 0u32;
    v.iter()
        .map(|&x| {
            let r = s;
            s = s.saturating_add(x);
            r
        })
        .collect()
}

#[test]
fn scan_matches_cpu_on_many_sizes() {
    let g = gpu();
    let b = SCAN_BLOCK as usize;
    let mut rng = Rng(7);
    let mut sizes = vec![
        0,
        1,
        2,
        3,
        255,
        256,
        257,
        b - 1,
        b,
        b + 1,
        3 * b + 17,
        b * b,
        b * b + 1,
        2 * b * b + 5,
    ];
    for _ in 0..6 {
        sizes.push(1 + rng.below(5 * b as u64) as usize);
    }
    for n in sizes {
        let v: Vec<u32> = (0..n).map(|_| rng.below(20) as u32).collect();
        let got = scan::exclusive_scan_u32(g, &v).expect("scan runs");
        assert_eq!(got, cpu_scan(&v), "n = {n}");
    }
}

#[test]
fn pair_scan_scans_each_component() {
    let g = gpu();
    let mut rng = Rng(11);
    for n in [1usize, 1000, 5000, 70_001] {
        let v: Vec<[u32; 2]> = (0..n)
            .map(|_| [rng.below(9) as u32, rng.below(1000) as u32])
            .collect();
        let got = scan::exclusive_scan_u32x2(g, &v).expect("scan runs");
        let a = cpu_scan(&v.iter().map(|p| p[0]).collect::<Vec<_>>());
        let c = cpu_scan(&v.iter().map(|p| p[1]).collect::<Vec<_>>());
        let want: Vec<[u32; 2]> = a.into_iter().zip(c).map(|(x, y)| [x, y]).collect();
        assert_eq!(got, want, "n = {n}");
    }
}

#[test]
fn scan_saturates_instead_of_wrapping() {
    let g = gpu();
    let v = vec![u32::MAX / 2, u32::MAX / 2, 5, 7, 1];
    let got = scan::exclusive_scan_u32(g, &v).expect("scan runs");
    assert_eq!(got, cpu_scan(&v));
    assert_eq!(got[3], u32::MAX);
}
