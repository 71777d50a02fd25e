//! The GPU bytecode interpreter (`shaders/vm.wgsl`) against the CPU VM
//! (`grm_compile::vm`) on random well-typed expressions and on hand-picked
//! edge cases.
//!
//! Two families of random expressions:
//! - exact: ops whose f32 results WGSL must round exactly (`+ - *`,
//!   comparisons, floor/round/..., min/max, select, `%` and the integer and
//!   choice draws): GPU and CPU must agree bit for bit;
//! - continuous: transcendental functions, division, splines, uniform and
//!   normal draws, composed so that they stay in their domains: GPU and CPU
//!   must agree to 1e-3 relative to max(1, |value|): WGSL's functions are
//!   accurate to a few ulps, not correctly rounded, `a * b + c` may be
//!   contracted to an FMA, and compositions (cross products, inverse
//!   trigonometry) amplify those differences.

mod common;
use common::{Rng, gpu};
use grm_compile::op::Op;
use grm_compile::rng::DrawCtx;
use grm_compile::verify::verify_expr;
use grm_compile::vm::Vm;
use grm_gpu::layout::{VmJob, VmResult};
use grm_gpu::vmeval;

#[derive(Clone, Copy, PartialEq, Debug)]
enum T {
    F,
    V,
    B,
}

struct Gen<'a> {
    rng: &'a mut Rng,
    code: Vec<u32>,
    consts: Vec<f32>,
    exact: bool,
    draw: u32,
    bind_len: u32,
}

impl Gen<'_> {
    fn pick(&mut self, n: u64) -> u64 {
        self.rng.below(n)
    }

    fn value(&mut self) -> f32 {
        if self.exact {
            // Quarters in [-8, 8]: sums and products stay exact.
            (self.pick(65) as f32 - 32.0) * 0.25
        } else {
            (self.pick(20_001) as f32 - 10_000.0) * 4e-4
        }
    }

    fn c(&mut self, x: f32) {
        let i = self.consts.len() as u32;
        self.consts.push(x);
        self.code.push(Op::Const.encode(i));
    }

    fn op(&mut self, op: Op, a: u32) {
        self.code.push(op.encode(a));
    }

    fn draw(&mut self, n: u32) -> u32 {
        let d = self.draw;
        self.draw += n;
        d
    }

    fn expr(&mut self, t: T, depth: u32) {
        let leaf = depth == 0 || self.pick(4) == 0;
        match t {
            T::F if leaf => {
                if self.pick(2) == 0 {
                    let v = self.value();
                    self.c(v);
                } else {
                    let i = self.pick(u64::from(self.bind_len)) as u32;
                    self.op(Op::Load, i);
                }
            }
            T::V if leaf => {
                if self.pick(2) == 0 {
                    let i = self.consts.len() as u32;
                    for _ in 0..3 {
                        let v = self.value();
                        self.consts.push(v);
                    }
                    self.op(Op::Const3, i);
                } else {
                    let i = self.pick(u64::from(self.bind_len - 2)) as u32;
                    self.op(Op::Load3, i);
                }
            }
            T::B if leaf => {
                self.expr(T::F, 0);
                self.expr(T::F, 0);
                self.op(Op::Lt, 0);
            }
            T::F if self.exact => self.exact_f(depth - 1),
            T::V if self.exact => self.exact_v(depth - 1),
            T::F => self.cont_f(depth - 1),
            T::V => self.cont_v(depth - 1),
            T::B => self.boolean(depth - 1),
        }
    }

    fn exact_f(&mut self, d: u32) {
        const UN: [Op; 7] = [
            Op::Neg,
            Op::Abs,
            Op::Floor,
            Op::Ceil,
            Op::Round,
            Op::Fract,
            Op::Sign,
        ];
        const BIN: [Op; 7] = [
            Op::Add,
            Op::Sub,
            Op::Mul,
            Op::Min,
            Op::Max,
            Op::Step,
            Op::Rem,
        ];
        match self.pick(9) {
            0 => {
                self.expr(T::F, d);
                let op = UN[self.pick(7) as usize];
                self.op(op, 1);
            }
            1 | 2 => {
                self.expr(T::F, d);
                self.expr(T::F, d);
                let op = BIN[self.pick(7) as usize];
                self.op(op, 1);
            }
            3 => {
                self.expr(T::V, d);
                let c = self.pick(3) as u32;
                self.op(Op::Pick, c);
            }
            4 => {
                self.expr(T::B, d);
                self.expr(T::F, d);
                self.expr(T::F, d);
                self.op(Op::Select, 1);
            }
            5 => {
                self.expr(T::F, d);
                self.expr(T::F, d);
                self.expr(T::F, d);
                self.op(Op::Clamp, 1);
            }
            6 => {
                self.expr(T::F, d);
                self.expr(T::F, d);
                let dr = self.draw(1);
                self.op(Op::RandInt, dr);
            }
            7 => {
                let n = 1 + self.pick(4) as u32;
                for _ in 0..n {
                    self.expr(T::F, d);
                    self.expr(T::F, d);
                }
                self.op(Op::RandChoose, n | 1 << 16);
                let dr = self.draw(1);
                self.code.push(dr);
            }
            _ => {
                self.expr(T::F, d);
                self.expr(T::F, d);
                self.op(Op::Mul, 1);
            }
        }
    }

    fn exact_v(&mut self, d: u32) {
        const UN: [Op; 7] = [
            Op::Neg,
            Op::Abs,
            Op::Floor,
            Op::Ceil,
            Op::Round,
            Op::Fract,
            Op::Sign,
        ];
        const BIN: [Op; 6] = [Op::Add, Op::Sub, Op::Mul, Op::Min, Op::Max, Op::Step];
        match self.pick(6) {
            0 => {
                self.expr(T::F, d);
                self.op(Op::Splat, 0);
            }
            1 => {
                self.expr(T::V, d);
                let op = UN[self.pick(7) as usize];
                self.op(op, 3);
            }
            2 | 3 => {
                self.expr(T::V, d);
                self.expr(T::V, d);
                let op = BIN[self.pick(6) as usize];
                self.op(op, 3);
            }
            4 => {
                self.expr(T::B, d);
                self.expr(T::V, d);
                self.expr(T::V, d);
                self.op(Op::Select, 3);
            }
            _ => {
                let n = 1 + self.pick(3) as u32;
                for _ in 0..n {
                    self.expr(T::V, d);
                    self.expr(T::F, d);
                }
                self.op(Op::RandChoose, n | 3 << 16);
                let dr = self.draw(1);
                self.code.push(dr);
            }
        }
    }

    fn boolean(&mut self, d: u32) {
        match self.pick(6) {
            0 => {
                self.expr(T::F, d);
                self.expr(T::F, d);
                let op = [Op::Lt, Op::Le, Op::Gt, Op::Ge][self.pick(4) as usize];
                self.op(op, 0);
            }
            1 => {
                let w = if self.pick(2) == 0 { 1 } else { 3 };
                let t = if w == 1 { T::F } else { T::V };
                self.expr(t, d);
                self.expr(t, d);
                let op = if self.pick(2) == 0 { Op::Eq } else { Op::Ne };
                self.op(op, w);
            }
            2 => {
                self.expr(T::B, d);
                self.op(Op::Not, 0);
            }
            3 | 4 => {
                self.expr(T::B, d);
                self.expr(T::B, d);
                let op = if self.pick(2) == 0 { Op::And } else { Op::Or };
                self.op(op, 0);
            }
            _ => {
                self.expr(T::F, d);
                let dr = self.draw(1);
                self.op(Op::RandChance, dr);
            }
        }
    }

    /// A continuous float expression, kept inside the functions' domains.
    fn cont_f(&mut self, d: u32) {
        match self.pick(16) {
            0 => {
                self.expr(T::F, d);
                self.expr(T::F, d);
                let op = [Op::Add, Op::Sub, Op::Mul][self.pick(3) as usize];
                self.op(op, 1);
            }
            1 => {
                self.expr(T::F, d);
                let op = [Op::Sin, Op::Cos, Op::Atan][self.pick(3) as usize];
                self.op(op, 0);
            }
            2 => {
                self.expr(T::F, d);
                self.op(Op::Abs, 1);
                self.op(Op::Sqrt, 0);
            }
            3 => {
                self.expr(T::F, d);
                self.op(Op::Abs, 1);
                self.c(1.0);
                self.op(Op::Add, 1);
                let op = if self.pick(2) == 0 { Op::Ln } else { Op::Log10 };
                self.op(op, 0);
            }
            4 => {
                self.expr(T::F, d);
                self.c(-4.0);
                self.c(4.0);
                self.op(Op::Clamp, 1);
                self.op(Op::Exp, 0);
            }
            5 => {
                self.expr(T::F, d);
                self.op(Op::Abs, 1);
                self.c(0.5);
                self.op(Op::Add, 1);
                self.expr(T::F, d);
                self.c(-2.0);
                self.c(2.0);
                self.op(Op::Clamp, 1);
                self.op(Op::Pow, 0);
            }
            6 => {
                self.expr(T::F, d);
                self.expr(T::F, d);
                self.op(Op::Abs, 1);
                self.c(0.1);
                self.op(Op::Add, 1);
                self.op(Op::Atan2, 0);
            }
            7 => {
                self.expr(T::F, d);
                self.op(Op::Sin, 0);
                self.c(0.9);
                self.op(Op::Mul, 1);
                let op = if self.pick(2) == 0 {
                    Op::Asin
                } else {
                    Op::Acos
                };
                self.op(op, 0);
            }
            8 => {
                self.expr(T::F, d);
                self.expr(T::F, d);
                self.op(Op::Abs, 1);
                self.c(1.0);
                self.op(Op::Add, 1);
                self.op(Op::Div, 1);
            }
            9 => {
                self.expr(T::F, d);
                self.expr(T::F, d);
                self.expr(T::F, d);
                self.op(Op::Mix, 1);
            }
            10 => {
                self.c(-1.0);
                self.c(1.0);
                self.expr(T::F, d);
                self.op(Op::Smoothstep, 1);
            }
            11 => {
                self.expr(T::V, d);
                self.expr(T::V, d);
                let op = if self.pick(2) == 0 {
                    Op::Dot
                } else {
                    Op::Distance
                };
                self.op(op, 0);
            }
            12 => {
                self.expr(T::V, d);
                self.op(Op::Length, 0);
            }
            13 => {
                let n = 4 + self.pick(3) as u32;
                self.expr(T::F, d);
                for _ in 0..n {
                    self.expr(T::F, d);
                }
                self.op(Op::Spline, n | 1 << 16);
            }
            14 => {
                self.expr(T::F, d);
                self.expr(T::F, d);
                let dr = self.draw(1);
                self.op(Op::RandUniform, dr);
            }
            _ => {
                self.expr(T::F, d);
                self.expr(T::F, d);
                self.op(Op::Abs, 1);
                let dr = self.draw(2);
                self.op(Op::RandNormal, dr);
            }
        }
    }

    fn cont_v(&mut self, d: u32) {
        match self.pick(5) {
            0 => {
                self.expr(T::F, d);
                self.op(Op::Splat, 0);
            }
            1 => {
                self.expr(T::V, d);
                self.expr(T::V, d);
                self.op(Op::Cross, 0);
            }
            2 => {
                self.expr(T::V, d);
                let i = self.consts.len() as u32;
                self.consts.extend([20.0, 20.0, 20.0]);
                self.op(Op::Const3, i);
                self.op(Op::Add, 3);
                self.op(Op::Normalize, 0);
            }
            3 => {
                self.expr(T::V, d);
                self.expr(T::V, d);
                self.expr(T::V, d);
                self.op(Op::Mix, 3);
            }
            _ => {
                let n = 4 + self.pick(2) as u32;
                self.expr(T::F, d);
                for _ in 0..n {
                    self.expr(T::V, d);
                }
                self.op(Op::Spline, n | 3 << 16);
            }
        }
    }
}

struct Case {
    entry: u32,
    width: u32,
    job: VmJob,
}

/// Generate `n` expressions into one code array; returns code, consts,
/// binds and the cases.
fn generate(seed: u64, n: usize, exact: bool) -> (Vec<u32>, Vec<f32>, Vec<f32>, Vec<Case>) {
    let mut rng = Rng::seeded(seed);
    let mut code = Vec::new();
    let mut consts = Vec::new();
    let mut binds = Vec::new();
    let mut cases = Vec::new();
    for k in 0..n {
        let bind_len = 3 + rng.below(6) as u32;
        let bind_first = binds.len() as u32;
        for _ in 0..bind_len {
            let v = if exact {
                (rng.below(65) as f32 - 32.0) * 0.25
            } else {
                (rng.below(20_001) as f32 - 10_000.0) * 4e-4
            };
            binds.push(v);
        }
        let t = if rng.below(3) == 0 { T::V } else { T::F };
        let entry = code.len() as u32;
        let mut g = Gen {
            rng: &mut rng,
            code: std::mem::take(&mut code),
            consts: std::mem::take(&mut consts),
            exact,
            draw: 1,
            bind_len,
        };
        let depth = 1 + g.pick(4) as u32;
        g.expr(t, depth);
        g.op(Op::Ret, 0);
        code = g.code;
        consts = g.consts;
        let info = verify_expr(&code, entry, consts.len(), bind_len, None)
            .expect("generated code verifies");
        if info.max_depth as usize > grm_compile::op::STACK_SIZE {
            continue;
        }
        cases.push(Case {
            entry,
            width: info.width,
            job: VmJob {
                entry,
                bind_first,
                bind_len,
                seed: (seed as u32).wrapping_mul(31).wrapping_add(k as u32),
                iteration: (k % 5) as u32,
                position: k as u32 * 7,
            },
        });
    }
    (code, consts, binds, cases)
}

fn cpu(code: &[u32], consts: &[f32], binds: &[f32], c: &Case) -> Vec<f32> {
    cpu_job(code, consts, binds, &c.job)
}

/// The CPU VM's result for one GPU job: the same entry, binding words and
/// draw coordinates.
fn cpu_job(code: &[u32], consts: &[f32], binds: &[f32], job: &VmJob) -> Vec<f32> {
    let mut vm = Vm::new();
    let b = &binds[job.bind_first as usize..(job.bind_first + job.bind_len) as usize];
    let ctx = DrawCtx {
        seed: job.seed,
        iteration: job.iteration,
        position: job.position,
    };
    vm.run(code, consts, job.entry, b, &ctx)
        .expect("cpu vm runs")
        .to_vec()
}

fn gpu_words(r: &VmResult) -> [f32; 3] {
    [r.x, r.y, r.z]
}

fn disasm(code: &[u32], entry: u32) -> String {
    let mut out = Vec::new();
    let mut pc = entry as usize;
    while let Some(&w) = code.get(pc) {
        let (c, a) = grm_compile::op::decode(w);
        let op = Op::from_code(c);
        out.push(format!("{}({a})", op.map_or("?", |o| o.name())));
        pc += 1;
        if op == Some(Op::RandChoose) {
            pc += 1;
        }
        if op == Some(Op::Ret) {
            break;
        }
    }
    out.join(" ")
}

#[test]
fn exact_ops_agree_bit_for_bit() {
    let g = gpu();
    let (code, consts, binds, cases) = generate(1, 3000, true);
    let jobs: Vec<VmJob> = cases.iter().map(|c| c.job).collect();
    let results = vmeval::eval(g, &code, &consts, &binds, &jobs).expect("gpu vm runs");
    let mut bad = Vec::new();
    for (c, r) in cases.iter().zip(&results) {
        let want = cpu(&code, &consts, &binds, c);
        assert_eq!(
            r.words,
            c.width,
            "result width of {}",
            disasm(&code, c.entry)
        );
        let got = gpu_words(r);
        let same = want.iter().zip(got).all(|(w, g)| {
            w.to_bits() == g.to_bits() || (w.is_nan() && g.is_nan()) || (*w == 0.0 && g == 0.0)
        });
        if !same {
            bad.push(format!(
                "{} -> cpu {want:?} gpu {got:?}",
                disasm(&code, c.entry)
            ));
        }
    }
    assert!(
        bad.is_empty(),
        "{} of {} differ:\n{}",
        bad.len(),
        cases.len(),
        bad[..bad.len().min(10)].join("\n")
    );
}

#[test]
fn continuous_ops_agree_within_tolerance() {
    let g = gpu();
    let (code, consts, binds, cases) = generate(2, 3000, false);
    let jobs: Vec<VmJob> = cases.iter().map(|c| c.job).collect();
    let results = vmeval::eval(g, &code, &consts, &binds, &jobs).expect("gpu vm runs");
    let mut bad = Vec::new();
    for (c, r) in cases.iter().zip(&results) {
        let want = cpu(&code, &consts, &binds, c);
        assert_eq!(r.words, c.width);
        let got = gpu_words(r);
        let close = want.iter().zip(got).all(|(w, g)| {
            (w.is_nan() && g.is_nan()) || w == &g || (w - g).abs() <= 1e-3 * w.abs().max(1.0)
        });
        if !close {
            bad.push(format!(
                "{} -> cpu {want:?} gpu {got:?}",
                disasm(&code, c.entry)
            ));
        }
    }
    assert!(
        bad.is_empty(),
        "{} of {} differ:\n{}",
        bad.len(),
        cases.len(),
        bad[..bad.len().min(10)].join("\n")
    );
}

/// Edge cases where WGSL's own builtins differ from Rust's f32 semantics.
#[test]
fn edge_semantics_match_the_cpu() {
    let g = gpu();
    let mut code = Vec::new();
    let mut consts = Vec::new();
    let mut cases = Vec::new();
    let mut add = |ops: &[(Op, u32)], vals: &[f32]| {
        let entry = code.len() as u32;
        for v in vals {
            code.push(Op::Const.encode(consts.len() as u32));
            consts.push(*v);
        }
        for (op, a) in ops {
            code.push(op.encode(*a));
        }
        code.push(Op::Ret.encode(0));
        cases.push(entry);
    };
    for x in [2.5f32, -2.5, 0.5, -0.5, 1.4999999, 3.5, -0.0] {
        add(&[(Op::Round, 1)], &[x]);
    }
    for (x, y) in [(-1.0f32, 360.0f32), (7.0, -3.0), (-7.5, 2.0), (5.0, 2.5)] {
        add(&[(Op::Rem, 1)], &[x, y]);
    }
    for (x, y) in [
        (-2.0f32, 3.0f32),
        (-2.0, 2.0),
        (0.0, 2.0),
        (0.0, 0.0),
        (5.0, 0.0),
        (4.0, 0.5),
        (1.0, 7.0),
    ] {
        add(&[(Op::Pow, 0)], &[x, y]);
    }
    for x in [0.0f32, -0.0, 3.0, -3.0] {
        add(&[(Op::Sign, 1)], &[x]);
    }
    for (a, b) in [(4.0f32, 8.0f32), (8.0, 4.0), (2.5, 2.5), (-1.5, 1.5)] {
        add(&[(Op::RandInt, 1)], &[a, b]);
    }
    let binds = [0.0f32];
    let jobs: Vec<VmJob> = cases
        .iter()
        .enumerate()
        .map(|(k, &entry)| VmJob {
            entry,
            bind_first: 0,
            bind_len: 1,
            seed: 9,
            iteration: 1,
            position: k as u32,
        })
        .collect();
    let results = vmeval::eval(g, &code, &consts, &binds, &jobs).expect("gpu vm runs");
    for (job, r) in jobs.iter().zip(&results) {
        let want = cpu_job(&code, &consts, &binds, job);
        let close = (want[0] - r.x).abs() <= 1e-5 * want[0].abs().max(1.0) || want[0] == r.x;
        assert!(
            close,
            "{}: cpu {want:?} gpu {}",
            disasm(&code, job.entry),
            r.x
        );
    }
}

/// The hash itself, over many coordinates, through `uniform(0, 1)`.
#[test]
fn random_draws_are_the_cpu_draws() {
    let g = gpu();
    // uniform(0, 1) with draw index 5: 0 + (1 - 0) * u is exactly u.
    let code = vec![
        Op::Const.encode(0),
        Op::Const.encode(1),
        Op::RandUniform.encode(5),
        Op::Ret.encode(0),
    ];
    let consts = vec![0.0f32, 1.0];
    let mut rng = Rng::seeded(99);
    let jobs: Vec<VmJob> = (0..20_000)
        .map(|_| VmJob {
            entry: 0,
            bind_first: 0,
            bind_len: 0,
            seed: rng.next_u64() as u32,
            iteration: rng.below(64) as u32,
            position: rng.next_u64() as u32,
        })
        .collect();
    let results = vmeval::eval(g, &code, &consts, &[], &jobs).expect("gpu vm runs");
    for (j, r) in jobs.iter().zip(&results) {
        let want = grm_compile::rng::uniform(j.seed, j.iteration, j.position, 5);
        assert_eq!(r.x.to_bits(), want.to_bits(), "{j:?}");
    }
}

/// Distance in units in the last place between two f32 values (0 for
/// equal values, zeros of either sign, or two NaNs; `u32::MAX` for a NaN
/// against a number).
fn ulps(a: f32, b: f32) -> u32 {
    if a == b || (a.is_nan() && b.is_nan()) {
        return 0;
    }
    if a.is_nan() || b.is_nan() {
        return u32::MAX;
    }
    // Map to a line where consecutive floats are consecutive integers.
    let key = |x: f32| {
        let i = x.to_bits() as i32;
        if i < 0 { i32::MIN - i } else { i }
    };
    key(a).abs_diff(key(b))
}

/// Inputs that stress each function: dense steps over its domain, the
/// points near 1 where a logarithm is near 0, the ends of the domains,
/// the branch points of the approximations, and special values.
fn probes(op: Op) -> Vec<(f32, f32)> {
    let mut xs: Vec<f32> = Vec::new();
    let near_one = |xs: &mut Vec<f32>| {
        for k in 0..24 {
            let e = (2.0f32).powi(-24 + k);
            xs.extend([1.0 - e, 1.0 + 2.0 * e, 1.0 - 3.0 * e]);
        }
    };
    let octaves = |xs: &mut Vec<f32>| {
        for k in -30..30 {
            for m in [1.0f32, 1.1, 1.25, 1.5, 1.75, 1.99] {
                xs.push(m * (2.0f32).powi(k));
            }
        }
    };
    match op {
        Op::Asin | Op::Acos => {
            xs.extend((-1024..=1024).map(|k| k as f32 / 1024.0));
            xs.extend([1.0 - 2.0f32.powi(-24), -1.0 + 2.0f32.powi(-24), 0.5, -0.5]);
            xs.extend([0.5f32.next_up(), 0.5f32.next_down(), 1e-30, -0.0, 1.5, -1.5]);
        }
        Op::Atan => {
            octaves(&mut xs);
            let neg: Vec<f32> = xs.iter().map(|x| -x).collect();
            xs.extend(neg);
            for b in [0.414_213_57f32, 2.414_213_7] {
                xs.extend([b.next_down(), b, b.next_up()]);
            }
            xs.extend([0.0, -0.0, f32::INFINITY, f32::NEG_INFINITY]);
        }
        Op::Ln | Op::Log10 => {
            near_one(&mut xs);
            octaves(&mut xs);
            xs.extend([
                0.5,
                2.0,
                0.5f32.next_up(),
                2.0f32.next_down(),
                0.0,
                f32::INFINITY,
            ]);
        }
        Op::Atan2 => {
            let vs = [
                -3.0f32,
                -1.0,
                -0.5,
                -0.0,
                0.0,
                0.5,
                1.0,
                3.0,
                1e-30,
                1e30,
                f32::INFINITY,
                f32::NEG_INFINITY,
            ];
            let mut pairs = Vec::new();
            for &y in &vs {
                for &x in &vs {
                    pairs.push((y, x));
                }
            }
            for k in 0..360 {
                let t = (k as f32).to_radians();
                pairs.push((t.sin() * 2.5, t.cos() * 2.5));
            }
            return pairs;
        }
        Op::Pow => {
            let mut pairs = Vec::new();
            let mut bases = Vec::new();
            near_one(&mut bases);
            bases.extend([0.6f32, 0.9, 1.1, 1.5, 1.9999, 3.0, 10.0]);
            for &x in &bases {
                for y in [-2.0f32, -0.5, 0.5, 1.5, 3.0, 100.0, 1000.0] {
                    pairs.push((x, y));
                }
            }
            return pairs;
        }
        _ => unreachable!("not probed"),
    }
    xs.into_iter().map(|x| (x, 0.0)).collect()
}

/// The functions grm's WGSL computes itself rather than trusting the
/// driver's builtins (WGSL bounds asin and acos only by 4096 ulps, log and
/// log2 near 1 only by an absolute 2^-21: lavapipe's asin(0.8288) was 2e-4
/// radians off and its log(1 - 2^-24) 73%), one by one against Rust's f32
/// functions: within 8 ulps for the inverse trigonometry, the logarithms
/// and pow of bases in (0.5, 2) (whose error is 3 + 2|y ln x| ulps by
/// exp2's bound), special values alike.
#[test]
fn elementary_functions_are_within_a_few_ulps_of_the_cpu() {
    let g = gpu();
    let mut code = Vec::new();
    let mut consts = Vec::new();
    let mut cases = Vec::new();
    for op in [
        Op::Asin,
        Op::Acos,
        Op::Atan,
        Op::Ln,
        Op::Log10,
        Op::Atan2,
        Op::Pow,
    ] {
        let binary = matches!(op, Op::Atan2 | Op::Pow);
        for (x, y) in probes(op) {
            let entry = code.len() as u32;
            code.push(Op::Const.encode(consts.len() as u32));
            consts.push(x);
            if binary {
                code.push(Op::Const.encode(consts.len() as u32));
                consts.push(y);
            }
            code.push(op.encode(0));
            code.push(Op::Ret.encode(0));
            cases.push((op, x, y, entry));
        }
    }
    let jobs: Vec<VmJob> = cases
        .iter()
        .map(|&(_, _, _, entry)| VmJob {
            entry,
            bind_first: 0,
            bind_len: 0,
            seed: 0,
            iteration: 0,
            position: 0,
        })
        .collect();
    let results = vmeval::eval(g, &code, &consts, &[], &jobs).expect("gpu vm runs");
    let mut bad = Vec::new();
    let mut worst = std::collections::BTreeMap::new();
    for ((&(op, x, y, _), job), r) in cases.iter().zip(&jobs).zip(&results) {
        let want = cpu_job(&code, &consts, &[], job)[0];
        let d = ulps(want, r.x);
        let allowed = match op {
            // exp2's own bound grows with its argument.
            Op::Pow => 8 + 2 * (y * x.ln()).abs().ceil() as u32,
            _ => 8,
        };
        let w = worst.entry(op.name()).or_insert(0u32);
        *w = (*w).max(d);
        if d > allowed {
            bad.push(format!(
                "{}({x:e}, {y:e}): cpu {want:e} gpu {:e} ({d} ulps)",
                op.name(),
                r.x
            ));
        }
    }
    eprintln!("worst ulps: {worst:?}");
    assert!(
        bad.is_empty(),
        "{} of {} beyond the bound:\n{}",
        bad.len(),
        cases.len(),
        bad[..bad.len().min(20)].join("\n")
    );
}

/// The normal draw's `sqrt(-2 ln(1 - u1))` where `u1` is tiny (1 - u1 is
/// then just below 1, where a GPU's log may be wildly off or of the wrong
/// sign: a NaN where the CPU draws a number): positions whose first
/// uniform is below 2^-14, found on the CPU, drawn on both sides.
#[test]
fn normal_draws_with_tiny_uniforms_are_the_cpu_draws() {
    let g = gpu();
    let code = vec![
        Op::Const.encode(0),
        Op::Const.encode(1),
        Op::RandNormal.encode(0),
        Op::Ret.encode(0),
    ];
    let consts = vec![0.0f32, 1.0];
    let mut jobs = Vec::new();
    let mut position = 0u32;
    while jobs.len() < 64 && position < 50_000_000 {
        if grm_compile::rng::uniform(7, 3, position, 0) < (2.0f32).powi(-14) {
            jobs.push(VmJob {
                entry: 0,
                bind_first: 0,
                bind_len: 0,
                seed: 7,
                iteration: 3,
                position,
            });
        }
        position += 1;
    }
    assert!(jobs.len() >= 16, "only {} tiny draws found", jobs.len());
    let results = vmeval::eval(g, &code, &consts, &[], &jobs).expect("gpu vm runs");
    for (j, r) in jobs.iter().zip(&results) {
        let ctx = DrawCtx {
            seed: j.seed,
            iteration: j.iteration,
            position: j.position,
        };
        let want = ctx.standard_normal(0);
        // sqrt and cos: a few ulps each; the logarithm itself within 8.
        assert!(
            ulps(want, r.x) <= 16 || (want - r.x).abs() <= 1e-6,
            "u1 = {:e}: cpu {want:e} gpu {:e}",
            grm_compile::rng::uniform(j.seed, j.iteration, j.position, 0),
            r.x
        );
    }
}
