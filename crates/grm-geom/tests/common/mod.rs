//! Helpers shared by the grm-geom test files.
#![allow(dead_code)]

use std::collections::HashMap;

use glam::Vec3;
use grm_derive::ModuleString;
use grm_geom::MeshData;
use grm_sema::{Program, System, TModule, Value};

/// Check a program text (imports and meshes relative to `path`).
pub fn program(path: &str, text: &str) -> Program {
    let (_sources, checked) = grm_sema::check_text(path, text);
    let errors: Vec<String> = checked
        .diagnostics
        .iter()
        .filter(|d| d.is_error())
        .map(|d| format!("{d:?}"))
        .collect();
    assert!(errors.is_empty(), "check errors: {errors:#?}");
    checked.program
}

fn push_module(s: &mut ModuleString, m: &TModule, env: &grm_sema::eval::Env<'_>) {
    let mut params = Vec::new();
    for a in &m.args {
        let value = a
            .constant()
            .or_else(|| grm_sema::eval::eval(a, env).ok())
            .expect("argument without bindings or random draws");
        match value {
            Value::Float(x) => params.push(x as f32),
            Value::Vec3(v) => params.extend(v.map(|x| x as f32)),
            Value::Bool(b) => params.push(if b { 1.0 } else { 0.0 }),
            Value::Mesh(id) => params.push(id.0 as f32),
            Value::Material(id) => params.push(id.0 as f32),
        }
    }
    s.push(m.symbol.0, &params);
}

/// The axiom as a module string.
pub fn axiom(system: &System) -> ModuleString {
    let env = grm_sema::eval::Env {
        params: &[],
        globals: &[],
        bindings: &[],
    };
    let mut s = ModuleString::new();
    for m in &system.axiom {
        push_module(&mut s, m, &env);
    }
    s
}

/// A minimal derivation for deterministic, context-free systems whose
/// successors have constant arguments (e.g. the Koch island): every module
/// with a production is replaced by its first group's first alternative.
/// Arguments that depend on meta-parameters take their defaults.
pub fn derive(program: &Program, system: &System, iterations: u32) -> ModuleString {
    let mut cur: Vec<&TModule> = system.axiom.iter().collect();
    for _ in 0..iterations {
        let mut next = Vec::new();
        for m in cur {
            match system.groups_of(m.symbol).next() {
                Some(g) => next.extend(g.alternatives[0].successor.iter()),
                None => next.push(m),
            }
        }
        cur = next;
    }
    let params = program.default_params();
    let globals = program.global_values(&params).expect("constants evaluate");
    let env = grm_sema::eval::Env {
        params: &params,
        globals: &globals,
        bindings: &[],
    };
    let mut s = ModuleString::new();
    for m in cur {
        push_module(&mut s, m, &env);
    }
    s
}

fn key(p: [f32; 3]) -> [i64; 3] {
    p.map(|x| (f64::from(x) * 1e4).round() as i64)
}

/// Each vertex's id after welding positions equal to 1e-4.
fn weld(m: &MeshData) -> Vec<u32> {
    let mut ids: HashMap<[i64; 3], u32> = HashMap::new();
    m.positions
        .iter()
        .map(|p| {
            let n = ids.len() as u32;
            *ids.entry(key(*p)).or_insert(n)
        })
        .collect()
}

/// Whether the welded surface is closed and consistently oriented: every
/// directed edge appears once and its reverse once.
pub fn is_closed(m: &MeshData) -> bool {
    let weld = weld(m);
    let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
    for t in m.indices.chunks_exact(3) {
        let [a, b, c] = [
            weld[t[0] as usize],
            weld[t[1] as usize],
            weld[t[2] as usize],
        ];
        if a == b || b == c || a == c {
            continue; // degenerate (e.g. a cap of radius 0)
        }
        for (x, y) in [(a, b), (b, c), (c, a)] {
            *edges.entry((x, y)).or_default() += 1;
        }
    }
    edges
        .iter()
        .all(|(&(x, y), &n)| n == 1 && edges.get(&(y, x)) == Some(&1))
}

/// Whether the welded mesh is a union of closed, consistently oriented
/// surfaces, which may touch (two tubes meeting at a ring or a cap): every
/// edge is used as often in one direction as in the other. Unlike
/// [`is_closed`], this survives welding vertices of different surfaces
/// together, so it can check a whole model (a chain split between two
/// parts leaves each part open at the split and the union closed).
pub fn edges_balanced(m: &MeshData) -> bool {
    let weld = weld(m);
    let mut edges: HashMap<(u32, u32), i64> = HashMap::new();
    for t in m.indices.chunks_exact(3) {
        let w = |k: usize| weld[t[k] as usize];
        for (x, y) in [(w(0), w(1)), (w(1), w(2)), (w(2), w(0))] {
            if x != y {
                *edges.entry((x.min(y), x.max(y))).or_default() += if x < y { 1 } else { -1 };
            }
        }
    }
    edges.values().all(|&n| n == 0)
}

/// Every normal has unit length and every triangle's winding agrees with
/// its vertex normals.
pub fn normals_ok(m: &MeshData) -> bool {
    let unit = m
        .normals
        .iter()
        .all(|n| (Vec3::from_array(*n).length() - 1.0).abs() < 1e-4);
    let agree = m.indices.chunks_exact(3).all(|t| {
        let p = |i: u32| Vec3::from_array(m.positions[i as usize]);
        let n = |i: u32| Vec3::from_array(m.normals[i as usize]);
        let g = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));
        g.length() < 1e-9 || g.dot(n(t[0]) + n(t[1]) + n(t[2])) > 0.0
    });
    unit && agree && m.normals.len() == m.positions.len()
}

/// Sum of triangle areas.
pub fn area(m: &MeshData) -> f32 {
    m.indices
        .chunks_exact(3)
        .map(|t| {
            let p = |i: u32| Vec3::from_array(m.positions[i as usize]);
            0.5 * (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])).length()
        })
        .sum()
}

/// Build `string` of `system` with the meta-parameters' default values.
pub fn build_with_defaults(
    program: &Program,
    system: &System,
    string: &ModuleString,
) -> Result<grm_geom::Model, grm_geom::GeomError> {
    grm_geom::build_model(
        program,
        system,
        string,
        &system.settings,
        &program.default_params(),
    )
}
