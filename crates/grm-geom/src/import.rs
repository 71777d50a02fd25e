//! OBJ meshes declared with `mesh NAME = "file.obj";`, read with `tobj`.
//!
//! All objects of a file are merged into one [`MeshData`] (triangulated,
//! single index). Normals come from the file when every object has them,
//! otherwise they are computed (smooth, area weighted). The file's own
//! materials (`mtllib`) are not read: grm materials paint the mesh.

use std::io::Cursor;
use std::path::Path;

use crate::GeomError;
use crate::mesh::{MeshData, compute_normals};

/// Load one OBJ file. `name` is the mesh's name in the program (for errors).
/// The largest OBJ file a `mesh` declaration may name.
pub const MAX_OBJ_BYTES: u64 = 256 << 20;

pub fn load_obj(name: &str, path: &Path) -> Result<MeshData, GeomError> {
    // A regular file, read with a bound (a device or a pipe named as a
    // mesh is refused before a byte is read, like every input file).
    let what = "it is larger than 256 MiB, the most a mesh file may be";
    let bytes = grm_diag::input::read_bounded(path, MAX_OBJ_BYTES, what).map_err(|e| {
        GeomError::MeshMissing {
            mesh: name.to_string(),
            path: path.to_path_buf(),
            message: e.to_string(),
        }
    })?;
    parse_obj(name, path, &bytes)
}

/// Parse OBJ text (already read from `path`).
pub fn parse_obj(name: &str, path: &Path, bytes: &[u8]) -> Result<MeshData, GeomError> {
    let malformed = |message: String| GeomError::MeshMalformed {
        mesh: name.to_string(),
        path: path.to_path_buf(),
        message,
    };
    check_indices(bytes).map_err(malformed)?;
    let opts = tobj::LoadOptions {
        single_index: true,
        // Polygons are triangulated here (ear clipping, as `{ . }`
        // polygons): tobj fans them, which is wrong for concave faces.
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _materials) = tobj::load_obj_buf(&mut Cursor::new(bytes), &opts, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| malformed(e.to_string()))?;
    let mut out = MeshData::default();
    let mut all_normals = true;
    for model in &models {
        let m = &model.mesh;
        let arities_total: usize = m.face_arities.iter().map(|&k| k as usize).sum();
        if m.positions.len() % 3 != 0
            || (m.face_arities.is_empty() && m.indices.len() % 3 != 0)
            || (!m.face_arities.is_empty() && arities_total != m.indices.len())
        {
            return Err(malformed(format!(
                "object `{}` is not a triangle mesh",
                model.name
            )));
        }
        let count = m.positions.len() / 3;
        if m.normals.len() != m.positions.len() {
            all_normals = false;
        }
        let base = out.positions.len() as u32;
        for p in m.positions.chunks_exact(3) {
            if !p.iter().all(|x| x.is_finite()) {
                return Err(malformed(format!(
                    "object `{}` has a non-finite vertex",
                    model.name
                )));
            }
            out.positions.push([p[0], p[1], p[2]]);
        }
        for &i in &m.indices {
            if i as usize >= count {
                return Err(malformed(format!(
                    "object `{}` refers to vertex {} of {count}",
                    model.name,
                    i + 1
                )));
            }
        }
        triangulate_faces(
            &m.positions,
            &m.indices,
            &m.face_arities,
            base,
            &mut out.indices,
        );
        if all_normals {
            for n in m.normals.chunks_exact(3) {
                let v = glam::Vec3::new(n[0], n[1], n[2]);
                out.normals.push(v.normalize_or(glam::Vec3::Y).to_array());
            }
        }
    }
    if out.indices.is_empty() {
        return Err(malformed("the file has no faces".to_string()));
    }
    if !all_normals {
        out.normals = compute_normals(&out.positions, &out.indices);
    }
    Ok(out)
}

/// Append the triangles of the faces `indices` (vertex indices, checked
/// against `positions`) to `out`, offset by `base`. `arities` gives each
/// face's vertex count (empty: all triangles). A face of more than three
/// vertices is triangulated by ear clipping in its plane
/// ([`crate::polygon::triangulate`]), so a concave face covers exactly its
/// own area, wound as the face was; a face with no area gives nothing.
fn triangulate_faces(
    positions: &[f32],
    indices: &[u32],
    arities: &[u32],
    base: u32,
    out: &mut Vec<u32>,
) {
    if arities.is_empty() {
        out.extend(indices.iter().map(|&i| base + i));
        return;
    }
    let at = |i: u32| {
        let k = 3 * i as usize;
        glam::Vec3::new(positions[k], positions[k + 1], positions[k + 2])
    };
    let mut tris = Vec::new();
    let mut vs = Vec::new();
    let mut next = 0usize;
    for &k in arities {
        let face = &indices[next..next + k as usize];
        next += k as usize;
        if face.len() == 3 {
            out.extend(face.iter().map(|&i| base + i));
            continue;
        }
        vs.clear();
        vs.extend(face.iter().map(|&i| at(i)));
        // No area (or a non-finite one): no triangle.
        let Some(normal) = crate::polygon::newell_normal(&vs).try_normalize() else {
            continue;
        };
        crate::polygon::triangulate(&vs, normal, &mut tris);
        for t in &tris {
            out.extend(t.iter().map(|&j| base + face[j as usize]));
        }
    }
}

/// Check every index of every `f` and `l` line before `tobj` sees the file:
/// each position, texture coordinate and normal index must name an
/// element defined above it (1-based, or negative counting back from the
/// last one). `tobj` turns an index before the first element into a huge
/// one and multiplies it unchecked (an overflow panic in a debug build),
/// so such files are refused here with the line they are on.
fn check_indices(bytes: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(bytes);
    let mut counts = [0usize; 3];
    const WHAT: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    const WHATS: [&str; 3] = ["vertices", "texture coordinates", "normals"];
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => counts[0] += 1,
            Some("vt") => counts[1] += 1,
            Some("vn") => counts[2] += 1,
            Some("f" | "l") => {
                for word in words {
                    for (k, part) in word.split('/').enumerate().take(3) {
                        if part.is_empty() {
                            continue;
                        }
                        // Not a number: tobj reports the face as malformed.
                        let Ok(x) = part.parse::<i64>() else {
                            continue;
                        };
                        let count = counts[k];
                        if x == 0 || x.unsigned_abs() > count as u64 {
                            let what = WHAT[k];
                            return Err(match count {
                                0 => format!(
                                    "line {}: {what} index {x}, but no {what} is defined above it",
                                    n + 1
                                ),
                                _ => format!(
                                    "line {}: {what} index {x}, but only {count} {} defined above it \
                                     (indices run from 1 to {count}, or from -1 back to -{count})",
                                    n + 1,
                                    if count == 1 {
                                        format!("{what} is")
                                    } else {
                                        format!("{} are", WHATS[k])
                                    }
                                ),
                            });
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mesh declared as a device or a directory is refused before a byte
    /// is read (`/dev/zero` never ends; a folder is not a mesh).
    #[test]
    fn a_mesh_that_is_not_a_regular_file_is_refused_unread() {
        for path in ["/dev/zero", "/"] {
            let t = std::time::Instant::now();
            let e = load_obj("m", Path::new(path)).expect_err("refused");
            assert!(matches!(e, GeomError::MeshMissing { .. }), "{path}: {e:?}");
            assert!(t.elapsed().as_secs() < 5, "{path}: read instead of refused");
        }
    }
}
