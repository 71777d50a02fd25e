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
    let mut rng = Rng::seeded(7);
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
    let mut rng = Rng::seeded(11);
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

/// The segmented inclusive scan of turtle transforms (`turtle_scan.wgsl`)
/// against a sequential composition, over more than two levels of block
/// sums. Entries are small integers so every product is exact.
#[test]
fn segmented_turtle_scan_matches_sequential_composition() {
    use grm_gpu::layout::{SEG_START, TurtleElem};
    let g = gpu();
    fn compose(a: &TurtleElem, b: &TurtleElem) -> TurtleElem {
        let mut r = *a;
        for c in 0..3 {
            for row in 0..3 {
                r.m[3 * c + row] = (0..3).map(|k| a.m[3 * k + row] * b.m[3 * c + k]).sum();
            }
        }
        for row in 0..3 {
            r.m[9 + row] =
                a.m[9 + row] + (0..3).map(|k| a.m[3 * k + row] * b.m[9 + k]).sum::<f32>();
        }
        r.wa = b.wa * a.wa;
        r.wb = b.wa * a.wb + b.wb;
        r.bone = if b.bone != u32::MAX { b.bone } else { a.bone };
        r.seg = a.seg;
        r
    }
    let mut rng = Rng::seeded(3);
    let b = SCAN_BLOCK as usize;
    for n in [1usize, 1000, b + 3, b * b + 77] {
        let v: Vec<TurtleElem> = (0..n)
            .map(|k| {
                let mut e = TurtleElem::default();
                // A signed permutation matrix and a small translation.
                let p = [[0, 1, 2], [1, 2, 0], [2, 0, 1], [0, 2, 1]][rng.below(4) as usize];
                for (c, row) in p.iter().enumerate() {
                    e.m[3 * c + row] = if rng.below(2) == 0 { 1.0 } else { -1.0 };
                }
                for r in 0..3 {
                    e.m[9 + r] = rng.below(5) as f32 - 2.0;
                }
                e.wa = [0.0, 1.0, 0.5][rng.below(3) as usize];
                e.wb = rng.below(3) as f32;
                e.bone = if rng.below(3) == 0 {
                    k as u32
                } else {
                    u32::MAX
                };
                e.seg = if k == 0 || rng.below(50) == 0 {
                    SEG_START | k as u32
                } else {
                    0
                };
                e
            })
            .collect();
        let got = scan::inclusive_scan_turtle(g, &v).expect("scan runs");
        let mut acc = v[0];
        for (k, (x, y)) in v.iter().zip(&got).enumerate() {
            if k > 0 {
                acc = if x.seg & SEG_START != 0 {
                    *x
                } else {
                    compose(&acc, x)
                };
            }
            assert_eq!(*y, acc, "n = {n}, element {k}");
        }
    }
}
