//! `cargo run -p grm-sample --release --example arm_probe -- [SEEDS]
//! [KEY=V,KEY=V]`: where the Calder tree's arms stop, and why (the
//! measurements behind docs/sampling.md section 4.4).
//!
//! Samples `examples/calder_tree.grm` with its curves for seeds `0 ..
//! SEEDS` (default 10) and prints, per seed, the bones, the cost and each
//! curve's coverage, then for each arm the bone that covers the arm's
//! farthest covered point: its length, its depth, the length of its chain
//! of bones from the root, its children (length and how far each child's
//! tip is from the arm), and the lengths along the chain (each branch is
//! 0.63 to 0.91 times its parent, so a chain that starts short cannot
//! reach). Options, the defaults changed: `pscale=F` (particles times F),
//! `pa=A..B`, `gens=G`, `cand=K`, `paper` (`Guide::paper()`), `order=N`,
//! `rc`, `ro`, `rs`, `recent` (the `Reach` fields `candidates`, `order`,
//! `scale`, `recent`), `off` (`Reach::off()`).
use glam::Vec3;
use grm_guide::{CoverageOptions, Curves, coverage};
use grm_sample::{ExpectedOptions, Guide, NodeKind, Objective, SampleOptions, Sampler, Schedule};
use std::path::PathBuf;

fn seg_dist(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let ab = b - a;
    let l2 = ab.length_squared();
    if l2 <= 0.0 {
        return p.distance(a);
    }
    let t = ((p - a).dot(ab) / l2).clamp(0.0, 1.0);
    p.distance(a + ab * t)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seeds: u32 = args.first().and_then(|s| s.parse().ok()).unwrap_or(10);
    let cfg = args.get(1).cloned().unwrap_or_default();
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let path = root.join("calder_tree.grm");
    let text = std::fs::read_to_string(&path).unwrap();
    let (_s, checked) = grm_sema::check_text(path.to_str().unwrap(), &text);
    let program = checked.program;
    let system = &program.systems[0];
    let compiled = grm_compile::compile(&program, system, &program.default_params()).unwrap();
    let curves = Curves::load(root.join("calder_tree.curves.json")).unwrap();
    let sampler = Sampler::new(
        system,
        &compiled,
        &curves,
        Objective::Curves,
        ExpectedOptions::default(),
    )
    .unwrap();
    for sym in ["START", "branch", "branchOrLeaf", "maybeBranch"] {
        println!("reach {sym}: {:?}", sampler.reach_factor(sym));
    }
    for seed in 0..seeds {
        let mut o = SampleOptions {
            seed,
            schedule: Schedule::from_settings(&compiled.settings),
            ..SampleOptions::default()
        };
        for kv in cfg.split(',').filter(|s| !s.is_empty()) {
            let (k, v) = kv.split_once('=').unwrap_or((kv, ""));
            match k {
                "pscale" => {
                    let f: f64 = v.parse().unwrap();
                    o.schedule.particles_start =
                        (f64::from(o.schedule.particles_start) * f).round() as u32;
                    o.schedule.particles_end =
                        (f64::from(o.schedule.particles_end) * f).round() as u32;
                }
                "gens" => o.schedule = o.schedule.with_generations(v.parse().unwrap()),
                "cand" => o.candidates = v.parse().unwrap(),
                "paper" => o.guide = Guide::paper(),
                "off" => o.reach = grm_sample::Reach::off(),
                "rc" => o.reach.candidates = v.parse().unwrap(),
                "ro" => o.reach.order = v.parse().unwrap(),
                "rs" => o.reach.scale = v.parse().unwrap(),
                "recent" => o.reach.recent = v.parse().unwrap(),
                "order" => o.guide.order = v.parse().unwrap(),
                "pa" => {
                    let (a, b) = v.split_once("..").unwrap();
                    o.schedule.particles_start = a.parse().unwrap();
                    o.schedule.particles_end = b.parse().unwrap();
                }
                _ => panic!("{k}"),
            }
        }
        let r = sampler.sample(&o).unwrap();
        let m = r.best().unwrap();
        let it = &m.interpretation;
        // skeleton bone indices
        let mut skel = vec![false; it.bones.len()];
        for n in &m.tree.nodes {
            if n.kind != NodeKind::Geometry {
                for i in n.bones.start..n.bones.end {
                    skel[i as usize] = true;
                }
            }
        }
        let bones: Vec<(Vec3, Vec3)> = it
            .bones
            .iter()
            .zip(&skel)
            .filter(|(_, s)| **s)
            .map(|(b, _)| (b.base, b.tip))
            .collect();
        let cov = coverage(&curves, &bones, &CoverageOptions::default());
        print!(
            "seed {seed:2} bones {:3} cost {:8.0} cov",
            bones.len(),
            m.cost.total()
        );
        for c in &cov {
            print!(" {:3.0}%", 100.0 * c.fraction);
        }
        println!();
        for (ci, c) in curves.curves().iter().enumerate().skip(1) {
            // farthest covered sample
            let n = 256;
            let table = c.bezier.arc_length_table(2048);
            let len = *table.last().unwrap();
            let mut far = None;
            for i in 0..n {
                let s = len * (i as f64 + 0.5) / n as f64;
                let j = table.iter().position(|&x| x >= s).unwrap_or(2048);
                let p = c.bezier.eval(j as f64 / 2048.0).as_vec3();
                let best = it
                    .bones
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| skel[*k])
                    .map(|(k, b)| (k, seg_dist(p, b.base, b.tip)))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .unwrap();
                if best.1 <= 0.15 {
                    far = Some((i, best.0));
                }
            }
            let Some((i, b)) = far else {
                println!("  curve {ci}: nothing covered");
                continue;
            };
            let bone = &it.bones[b];
            let mut depth = 0;
            let mut chain = 0.0;
            let mut p = Some(b as u32);
            let mut lens = Vec::new();
            while let Some(j) = p {
                let bb = &it.bones[j as usize];
                let l = bb.base.distance(bb.tip);
                chain += l;
                lens.push(l);
                depth += 1;
                p = bb.parent;
            }
            lens.reverse();
            let kids: Vec<String> = it
                .bones
                .iter()
                .enumerate()
                .filter(|(k, x)| skel[*k] && x.parent == Some(b as u32))
                .map(|(_, x)| {
                    let cp = c.bezier.closest_point(x.tip.as_dvec3());
                    format!("len {:.2} tipdist {:.2}", x.base.distance(x.tip), cp.dist)
                })
                .collect();
            let lens_s: Vec<String> = lens.iter().map(|l| format!("{l:.2}")).collect();
            println!(
                "  curve {ci}: far {:.0}% bone len {:.3} depth {depth} chain {chain:.2} kids [{}] lens {}",
                100.0 * (i as f64 + 0.5) / n as f64,
                bone.base.distance(bone.tip),
                kids.join("; "),
                lens_s.join(" ")
            );
        }
    }
}
