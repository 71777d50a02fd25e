//! Writing a [`Model`] to disk.
//!
//! Formats, chosen by extension (case-insensitive) in [`export`]:
//! - `.glb`: glTF 2.0 binary. One mesh with one primitive per part
//!   (material): `POSITION` (with min/max), `NORMAL`, `u32` indices; each
//!   material a `pbrMetallicRoughness` with `baseColorFactor`. Buffer views
//!   are 4-byte aligned, the JSON chunk is padded with spaces and the BIN
//!   chunk with zeros.
//! - `.obj`: Wavefront OBJ plus `NAME.mtl` beside it (see [`mtl_file_name`]:
//!   white space in NAME as `_`, `#`, `%`, control characters and bytes
//!   that are not UTF-8 as `%XX`; `mtllib`, one group and `usemtl` per
//!   part, `v`/`vn`/`f v//vn`).
//! - `.ply`: binary little-endian PLY with normals and 8-bit vertex
//!   colours (the part's material colour, sRGB-encoded as in the PNG),
//!   turned from grm's +y up to PLY's usual (and Blender's) +z up: a point
//!   (x, y, z) is written as (x, -z, y), as Blender's glTF importer turns
//!   a glb. A model without a vertex is written as one vertex at the
//!   origin and no faces (Blender refuses a PLY without vertices).
//!   [`ExportFormat::PlyAscii`] via [`export_as`].
//! - `.svg`: the XY projection (for 2D systems): bones as lines with their
//!   widths as stroke widths (width 0: a one-pixel hairline), polygons as
//!   filled paths, in sRGB colours; y points up (the picture is flipped
//!   into SVG's y-down space); the viewBox is the projected bounds plus a
//!   2% margin.
//!   Primitives and meshes are not drawn in SVG.
//! - `.png`: a shaded picture of the whole model (surfaces, and bones
//!   without a tube as lines) drawn by [`crate::render`], 1024 x 1024 from
//!   [`crate::render::View::Auto`] by default; [`export_image`] takes the
//!   size, view and background.
//!
//! Every write is atomic: the data goes to a temporary file in the target's
//! directory, which is renamed over the target only when complete, so a
//! failure never leaves a truncated file (OBJ: the `.mtl` is renamed first,
//! then the `.obj`).

use std::fmt::Write as _;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use glam::Vec3;
use grm_diag::{Code, Diagnostic, FileId, Span};
use grm_turtle::{Aabb, Paint};
use serde_json::{Value as Json, json};

use crate::Model;
use crate::render::{self, RenderOptions};

/// An output format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ExportFormat {
    Glb,
    Obj,
    Ply,
    PlyAscii,
    Svg,
    Png,
}

impl ExportFormat {
    /// The format for a path's extension.
    pub fn from_path(path: &Path) -> Option<ExportFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "glb" => ExportFormat::Glb,
            "obj" => ExportFormat::Obj,
            "ply" => ExportFormat::Ply,
            "svg" => ExportFormat::Svg,
            "png" => ExportFormat::Png,
            _ => return None,
        })
    }
}

/// Why an export failed. Each names the path it was about.
#[derive(Debug)]
pub enum ExportError {
    /// The extension names no supported format.
    UnknownFormat { path: PathBuf },
    /// Creating, writing or renaming the file failed.
    Io { path: PathBuf, source: io::Error },
    /// The model is too large for the format (glb: 4 GiB).
    TooLarge { path: PathBuf },
}

impl ExportError {
    pub fn path(&self) -> &Path {
        match self {
            ExportError::UnknownFormat { path }
            | ExportError::Io { path, .. }
            | ExportError::TooLarge { path } => path,
        }
    }
}

impl ExportError {
    /// The stable code: `R0406` to `R0408`.
    pub fn code(&self) -> Code {
        match self {
            ExportError::UnknownFormat { .. } => Code::UnknownExportFormat,
            ExportError::Io { .. } => Code::ExportIo,
            ExportError::TooLarge { .. } => Code::ModelTooLarge,
        }
    }

    /// The error as a diagnostic pointing at `file`/`span`, the system
    /// whose model was being exported (an export names no source place).
    pub fn to_diagnostic(&self, file: FileId, span: Span) -> Diagnostic {
        let help = match self {
            ExportError::UnknownFormat { .. } => {
                "name the output with the extension of its format: .glb, .obj, .ply, .svg or .png"
            }
            ExportError::Io { .. } => {
                "check that the output's directory exists and that you may write to it"
            }
            ExportError::TooLarge { .. } => {
                "glb files hold at most 4 GiB: export as .obj or .ply, or derive fewer iterations"
            }
        };
        Diagnostic::new(
            self.code(),
            self.to_string(),
            file,
            span,
            "the model of this system",
        )
        .with_help(help)
    }
}

impl std::fmt::Display for ExportError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ExportError::UnknownFormat { path } => write!(
                f,
                "cannot export {}: unknown format (use .glb, .obj, .ply, .svg or .png)",
                path.display()
            ),
            ExportError::Io { path, source } => {
                write!(f, "cannot write {}: {source}", path.display())
            }
            ExportError::TooLarge { path } => {
                write!(
                    f,
                    "cannot write {}: the model is too large for the format",
                    path.display()
                )
            }
        }
    }
}

impl std::error::Error for ExportError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ExportError::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// Export `model` to `path` in the format its extension names.
pub fn export(model: &Model, path: &Path) -> Result<(), ExportError> {
    let format = ExportFormat::from_path(path).ok_or_else(|| ExportError::UnknownFormat {
        path: path.to_path_buf(),
    })?;
    export_as(model, path, format)
}

/// Export `model` to `path` in `format` (a `.png` with the default
/// [`RenderOptions`]).
pub fn export_as(model: &Model, path: &Path, format: ExportFormat) -> Result<(), ExportError> {
    match format {
        ExportFormat::Png => export_image(model, path, &RenderOptions::default()),
        ExportFormat::Glb => {
            // Exported models name their parts (`_PART`, `extras.grm`);
            // shape-mode models their groups (glTF nodes).
            let ids = part_ids(model);
            let (json_bytes, bin_len) =
                glb_layout(model, ids.as_ref()).ok_or_else(|| ExportError::TooLarge {
                    path: path.to_path_buf(),
                })?;
            let tmp = stage(path, |w| {
                write_glb(model, ids.as_ref(), &json_bytes, bin_len, w)
            })?;
            commit(tmp, path)
        }
        ExportFormat::Obj => {
            let mtl_name = mtl_file_name(path);
            let mtl_path = path.with_file_name(&mtl_name);
            let mtl = stage(&mtl_path, |w| write_mtl(model, w))?;
            let obj = stage(path, |w| write_obj(model, &mtl_name, w))?;
            commit(mtl, &mtl_path)?;
            commit(obj, path)
        }
        ExportFormat::Ply | ExportFormat::PlyAscii => {
            let tmp = stage(path, |w| {
                write_ply(model, format == ExportFormat::PlyAscii, w)
            })?;
            commit(tmp, path)
        }
        ExportFormat::Svg => {
            let svg = svg_string(model);
            let tmp = stage(path, |w| w.write_all(svg.as_bytes()))?;
            commit(tmp, path)
        }
    }
}

/// Draw `model` as `options` say and write the picture to `path` as PNG
/// (whatever its extension). Options that [`RenderOptions::validate`]
/// refuses are an [`ExportError::Io`] of kind `InvalidInput` (grmc checks
/// its flags before it derives, so it never sees one).
pub fn export_image(
    model: &Model,
    path: &Path,
    options: &RenderOptions,
) -> Result<(), ExportError> {
    let image = render::render(model, options).map_err(|e| {
        io_error(
            path,
            io::Error::new(io::ErrorKind::InvalidInput, e.to_string()),
        )
    })?;
    write_image(&image, path)
}

/// Write a drawn picture to `path` as PNG (whatever its extension), as
/// every export is written: to a temporary file renamed into place.
pub fn write_image(image: &render::Image, path: &Path) -> Result<(), ExportError> {
    let tmp = stage(path, |w| render::write_png(image, w))?;
    commit(tmp, path)
}

fn io_error(path: &Path, source: io::Error) -> ExportError {
    ExportError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Write a temporary file beside `path` (deleted again if anything fails).
fn stage(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<tempfile::NamedTempFile, ExportError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".grm-export-").suffix(".tmp");
    // Temporary files are private (0600); the export gets the permissions
    // of the file it replaces, or the usual 0644.
    #[cfg(unix)]
    let perms = {
        use std::os::unix::fs::PermissionsExt;
        std::fs::metadata(path)
            .map(|m| m.permissions())
            .unwrap_or_else(|_| std::fs::Permissions::from_mode(0o644))
    };
    #[cfg(unix)]
    builder.permissions(perms);
    let mut tmp = builder
        .tempfile_in(dir)
        .map_err(|e| io_error(path, without_temp_path(e)))?;
    {
        let mut w = BufWriter::with_capacity(1 << 16, tmp.as_file_mut());
        write(&mut w).map_err(|e| io_error(path, e))?;
        w.flush().map_err(|e| io_error(path, e))?;
    }
    Ok(tmp)
}

/// Rename a staged file over `path`.
/// tempfile's errors read `<the OS error> at path "<temporary file>"`: the
/// user never asked for that file (and its random name would make the
/// message differ run to run), so keep only the operating system's error.
fn without_temp_path(e: io::Error) -> io::Error {
    let text = e.to_string();
    match text.split_once(" at path ") {
        Some((os, _)) => io::Error::new(e.kind(), os.to_string()),
        None => e,
    }
}

fn commit(tmp: tempfile::NamedTempFile, path: &Path) -> Result<(), ExportError> {
    tmp.persist(path).map_err(|e| io_error(path, e.error))?;
    Ok(())
}

/// Write a file the way every export is written: `write` fills a temporary
/// file beside `path` (private while written), which then gets the
/// permissions of the file it replaces (or 0644) and is renamed over
/// `path`. Any failure leaves no file behind and `path` as it was. For
/// the other files the tools write beside a model (`--tree`).
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), ExportError> {
    if path.is_dir() {
        return Err(io_error(path, io::ErrorKind::IsADirectory.into()));
    }
    commit(stage(path, write)?, path)
}

/// Write `[f32; 3]`s little-endian, in chunks.
fn write_f32s(w: &mut dyn Write, vs: &[[f32; 3]]) -> io::Result<()> {
    let mut buf = [0u8; 12 * 1024];
    for chunk in vs.chunks(1024) {
        for (v, out) in chunk.iter().zip(buf.chunks_exact_mut(12)) {
            out[0..4].copy_from_slice(&v[0].to_le_bytes());
            out[4..8].copy_from_slice(&v[1].to_le_bytes());
            out[8..12].copy_from_slice(&v[2].to_le_bytes());
        }
        w.write_all(&buf[..chunk.len() * 12])?;
    }
    Ok(())
}

fn write_u32s(w: &mut dyn Write, vs: &[u32]) -> io::Result<()> {
    let mut buf = [0u8; 4 * 4096];
    for chunk in vs.chunks(4096) {
        for (v, out) in chunk.iter().zip(buf.chunks_exact_mut(4)) {
            out.copy_from_slice(&v.to_le_bytes());
        }
        w.write_all(&buf[..chunk.len() * 4])?;
    }
    Ok(())
}

/// The glb's JSON chunk (padded) and the length of its BIN chunk; `None`
/// past the format's 4 GiB limit. The BIN chunk holds, per non-empty part
/// in order, its positions, normals and indices (all 4-byte data, so every
/// view stays 4-byte aligned).
fn glb_layout(model: &Model, ids: Option<&crate::parts::PartIds>) -> Option<(Vec<u8>, usize)> {
    if !model.groups.is_empty() {
        return shape_glb_layout(model);
    }
    let mut offset = 0usize;
    let mut views: Vec<Json> = Vec::new();
    let mut accessors: Vec<Json> = Vec::new();
    let mut primitives: Vec<Json> = Vec::new();
    for (k, part) in model
        .parts
        .iter()
        .filter(|p| !p.mesh.is_empty())
        .enumerate()
    {
        let m = &part.mesh;
        let mut view = |len: usize, target: u32| {
            views.push(json!({
                "buffer": 0,
                "byteOffset": offset,
                "byteLength": len,
                "target": target,
            }));
            offset += len;
            views.len() - 1
        };
        let pv = view(m.positions.len() * 12, 34962);
        let nv = view(m.normals.len() * 12, 34962);
        let iv = view(m.indices.len() * 4, 34963);
        // `_PART`: after the indices, one float per vertex.
        let part_view = ids.map(|_| view(m.positions.len() * 4, 34962));
        let mut bounds = Aabb::EMPTY;
        for p in &m.positions {
            bounds.add(Vec3::from_array(*p));
        }
        accessors.push(json!({
            "bufferView": pv,
            "componentType": 5126,
            "count": m.positions.len(),
            "type": "VEC3",
            "min": bounds.min.to_array(),
            "max": bounds.max.to_array(),
        }));
        accessors.push(json!({
            "bufferView": nv,
            "componentType": 5126,
            "count": m.normals.len(),
            "type": "VEC3",
        }));
        accessors.push(json!({
            "bufferView": iv,
            "componentType": 5125,
            "count": m.indices.len(),
            "type": "SCALAR",
        }));
        let a = accessors.len();
        let mut attributes = json!({ "POSITION": a - 3, "NORMAL": a - 2 });
        if let (Some(pv), Some(ids)) = (part_view, ids) {
            // The primitive's own range of part ids: a declared bound must
            // be the data's (the Khronos validator checks it).
            let own = ids.vertex_ids.get(k).map_or(&[][..], Vec::as_slice);
            let lo = own.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = own.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            let (lo, hi) = if lo <= hi { (lo, hi) } else { (0.0, 0.0) };
            accessors.push(json!({
                "bufferView": pv,
                "componentType": 5126,
                "count": m.positions.len(),
                "type": "SCALAR",
                "min": [lo],
                "max": [hi],
            }));
            attributes["_PART"] = json!(accessors.len() - 1);
        }
        primitives.push(json!({
            "attributes": attributes,
            "indices": a - 1,
            "material": part.material,
            "mode": 4,
        }));
    }
    let materials = materials_json(model);
    // An empty model is just the asset (a scene needs at least one node).
    let mut doc = json!({
        "asset": { "version": "2.0", "generator": "grm" },
    });
    if !primitives.is_empty() {
        add_textures(model, &mut doc, &mut views, &mut offset);
        doc["scene"] = json!(0);
        doc["scenes"] = json!([ { "name": "grm", "nodes": [0] } ]);
        doc["nodes"] = json!([ { "name": "model", "mesh": 0 } ]);
        doc["meshes"] = json!([ { "name": "model", "primitives": primitives } ]);
        doc["materials"] = json!(materials);
        doc["accessors"] = json!(accessors);
        doc["bufferViews"] = json!(views);
        doc["buffers"] = json!([ { "byteLength": offset } ]);
        if let Some(ids) = ids {
            doc["extras"] = crate::parts::parts_table(model, ids);
        }
    }
    // Serialising a `Value` of plain data cannot fail.
    let mut json_bytes = serde_json::to_vec(&doc).unwrap_or_default();
    json_bytes.resize(json_bytes.len().next_multiple_of(4), b' ');
    let total = 12 + 8 + json_bytes.len() + if offset > 0 { 8 + offset } else { 0 };
    u32::try_from(total).ok()?;
    Some((json_bytes, offset))
}

/// The glTF materials of the model's materials (a texture as the
/// `baseColorTexture`, texture `i` being `model.textures[i]`).
fn materials_json(model: &Model) -> Vec<Json> {
    model
        .materials
        .iter()
        .map(|m| {
            let mut j = json!({
                "name": m.name,
                "pbrMetallicRoughness": {
                    "baseColorFactor": [m.color[0], m.color[1], m.color[2], m.opacity],
                    "metallicFactor": m.metallic,
                    "roughnessFactor": m.roughness,
                },
                "emissiveFactor": m.emissive,
            });
            if m.opacity < 1.0 {
                j["alphaMode"] = json!("BLEND");
            }
            if let Some(t) = m.texture.filter(|&t| t < model.textures.len()) {
                j["pbrMetallicRoughness"]["baseColorTexture"] = json!({ "index": t });
            }
            j
        })
        .collect()
}

/// Part ids for a glb: none for a shape-mode model (its groups are nodes).
fn part_ids(model: &Model) -> Option<crate::parts::PartIds> {
    if model.groups.is_empty() {
        crate::parts::part_ids(model)
    } else {
        None
    }
}

/// The model's textures as glTF images (their bytes in buffer views after
/// `offset`, each padded to 4 bytes), one sampler (linear, repeat) and a
/// texture per image.
fn add_textures(model: &Model, doc: &mut Json, views: &mut Vec<Json>, offset: &mut usize) {
    if model.textures.is_empty() {
        return;
    }
    let mut images = Vec::new();
    let mut textures = Vec::new();
    for (i, t) in model.textures.iter().enumerate() {
        views.push(json!({
            "buffer": 0,
            "byteOffset": *offset,
            "byteLength": t.bytes.len(),
        }));
        *offset += t.bytes.len().next_multiple_of(4);
        images.push(json!({
            "name": t.name,
            "bufferView": views.len() - 1,
            "mimeType": t.mime,
        }));
        textures.push(json!({ "sampler": 0, "source": i }));
    }
    doc["images"] = json!(images);
    doc["textures"] = json!(textures);
    doc["samplers"] = json!([{
        "magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497
    }]);
}

/// Write the textures' bytes as [`add_textures`] laid them out.
fn write_textures(model: &Model, w: &mut dyn Write) -> io::Result<()> {
    for t in &model.textures {
        w.write_all(&t.bytes)?;
        let pad = t.bytes.len().next_multiple_of(4) - t.bytes.len();
        w.write_all(&[0u8; 3][..pad])?;
    }
    Ok(())
}

/// The vertices and triangles of one group span.
fn span_data<'a>(model: &'a Model, s: &crate::shape::GroupSpan) -> Option<SpanData<'a>> {
    let m = &model.parts.get(s.part)?.mesh;
    let v = s.first_vertex as usize..(s.first_vertex + s.vertex_count) as usize;
    let t = 3 * s.first_triangle as usize..3 * (s.first_triangle + s.triangle_count) as usize;
    Some(SpanData {
        positions: m.positions.get(v.clone())?,
        normals: m.normals.get(v.clone())?,
        uvs: if m.has_uvs() { m.uvs.get(v) } else { None },
        indices: m.indices.get(t)?,
        first: s.first_vertex,
    })
}

struct SpanData<'a> {
    positions: &'a [[f32; 3]],
    normals: &'a [[f32; 3]],
    uvs: Option<&'a [[f32; 2]]>,
    indices: &'a [u32],
    first: u32,
}

/// The glb layout of a shape-mode model: a root node `grm` whose children
/// are the groups, each a node named as the group with its locators in
/// `extras` and its own mesh, one primitive per part (material) it uses;
/// each primitive's positions, normals, UVs (`TEXCOORD_0`) and indices
/// (from 0) in the BIN chunk in group order, then the textures' images.
fn shape_glb_layout(model: &Model) -> Option<(Vec<u8>, usize)> {
    let mut offset = 0usize;
    let mut views: Vec<Json> = Vec::new();
    let mut accessors: Vec<Json> = Vec::new();
    let mut meshes: Vec<Json> = Vec::new();
    let mut nodes: Vec<Json> = vec![json!({ "name": "grm", "children": [] })];
    for g in &model.groups {
        let mut primitives = Vec::new();
        for span in &g.spans {
            let Some(d) = span_data(model, span) else {
                continue;
            };
            let mut view = |len: usize, target: u32| {
                views.push(json!({
                    "buffer": 0,
                    "byteOffset": offset,
                    "byteLength": len,
                    "target": target,
                }));
                offset += len;
                views.len() - 1
            };
            let pv = view(d.positions.len() * 12, 34962);
            let nv = view(d.normals.len() * 12, 34962);
            let tv = d.uvs.map(|uv| view(uv.len() * 8, 34962));
            let iv = view(d.indices.len() * 4, 34963);
            let mut bounds = Aabb::EMPTY;
            for p in d.positions {
                bounds.add(Vec3::from_array(*p));
            }
            let mut accessor = |a: Json| {
                accessors.push(a);
                accessors.len() - 1
            };
            let pa = accessor(json!({
                "bufferView": pv, "componentType": 5126, "count": d.positions.len(),
                "type": "VEC3", "min": bounds.min.to_array(), "max": bounds.max.to_array(),
            }));
            let na = accessor(json!({
                "bufferView": nv, "componentType": 5126, "count": d.normals.len(), "type": "VEC3",
            }));
            let mut attributes = json!({ "POSITION": pa, "NORMAL": na });
            if let (Some(tv), Some(uv)) = (tv, d.uvs) {
                attributes["TEXCOORD_0"] = json!(accessor(json!({
                    "bufferView": tv, "componentType": 5126, "count": uv.len(), "type": "VEC2",
                })));
            }
            let ia = accessor(json!({
                "bufferView": iv, "componentType": 5125, "count": d.indices.len(), "type": "SCALAR",
            }));
            primitives.push(json!({
                "attributes": attributes,
                "indices": ia,
                "material": model.parts[span.part].material,
                "mode": 4,
            }));
        }
        if primitives.is_empty() {
            continue;
        }
        meshes.push(json!({ "name": g.name, "primitives": primitives }));
        nodes.push(json!({ "name": g.name, "mesh": meshes.len() - 1, "extras": g.extras() }));
    }
    let children: Vec<usize> = (1..nodes.len()).collect();
    nodes[0]["children"] = json!(children);
    let mut doc = json!({
        "asset": { "version": "2.0", "generator": "grm" },
        "scene": 0,
        "scenes": [ { "name": "grm", "nodes": [0] } ],
    });
    if children.is_empty() {
        nodes[0] = json!({ "name": "grm" });
    } else {
        add_textures(model, &mut doc, &mut views, &mut offset);
        doc["meshes"] = json!(meshes);
        doc["materials"] = json!(materials_json(model));
        doc["accessors"] = json!(accessors);
        doc["bufferViews"] = json!(views);
        doc["buffers"] = json!([ { "byteLength": offset } ]);
    }
    doc["nodes"] = json!(nodes);
    let mut json_bytes = serde_json::to_vec(&doc).unwrap_or_default();
    json_bytes.resize(json_bytes.len().next_multiple_of(4), b' ');
    let total = 12 + 8 + json_bytes.len() + if offset > 0 { 8 + offset } else { 0 };
    u32::try_from(total).ok()?;
    Some((json_bytes, offset))
}

/// Write the BIN data [`shape_glb_layout`] laid out.
fn write_shape_bin(model: &Model, w: &mut dyn Write) -> io::Result<()> {
    let mut rebased: Vec<u32> = Vec::new();
    for g in &model.groups {
        for span in &g.spans {
            let Some(d) = span_data(model, span) else {
                continue;
            };
            write_f32s(w, d.positions)?;
            write_f32s(w, d.normals)?;
            if let Some(uv) = d.uvs {
                let mut buf = Vec::with_capacity(uv.len() * 8);
                for [u, v] in uv {
                    buf.extend_from_slice(&u.to_le_bytes());
                    buf.extend_from_slice(&v.to_le_bytes());
                }
                w.write_all(&buf)?;
            }
            rebased.clear();
            rebased.extend(d.indices.iter().map(|&i| i.saturating_sub(d.first)));
            write_u32s(w, &rebased)?;
        }
    }
    write_textures(model, w)
}

/// Write the glb of `model` laid out by [`glb_layout`].
fn write_glb(
    model: &Model,
    ids: Option<&crate::parts::PartIds>,
    json_bytes: &[u8],
    bin_len: usize,
    w: &mut dyn Write,
) -> io::Result<()> {
    let total = 12 + 8 + json_bytes.len() + if bin_len > 0 { 8 + bin_len } else { 0 };
    // `glb_layout` checked that everything fits in u32.
    let len32 = |x: usize| u32::try_from(x).unwrap_or(u32::MAX).to_le_bytes();
    w.write_all(b"glTF")?;
    w.write_all(&2u32.to_le_bytes())?;
    w.write_all(&len32(total))?;
    w.write_all(&len32(json_bytes.len()))?;
    w.write_all(b"JSON")?;
    w.write_all(json_bytes)?;
    if bin_len > 0 && !model.groups.is_empty() {
        w.write_all(&len32(bin_len))?;
        w.write_all(b"BIN\0")?;
        write_shape_bin(model, w)?;
    } else if bin_len > 0 {
        w.write_all(&len32(bin_len))?;
        w.write_all(b"BIN\0")?;
        for (k, part) in model
            .parts
            .iter()
            .filter(|p| !p.mesh.is_empty())
            .enumerate()
        {
            write_f32s(w, &part.mesh.positions)?;
            write_f32s(w, &part.mesh.normals)?;
            write_u32s(w, &part.mesh.indices)?;
            if let Some(v) = ids.and_then(|ids| ids.vertex_ids.get(k)) {
                let bits: Vec<u32> = v.iter().map(|x| x.to_bits()).collect();
                write_u32s(w, &bits)?;
            }
        }
        write_textures(model, w)?;
    }
    Ok(())
}

/// The model as a glTF 2.0 binary (`.glb`) file in memory; `None` when it
/// exceeds the format's 4 GiB limit.
pub fn glb_bytes(model: &Model) -> Option<Vec<u8>> {
    let ids = part_ids(model);
    let (json_bytes, bin_len) = glb_layout(model, ids.as_ref())?;
    let mut out = Vec::with_capacity(28 + json_bytes.len() + bin_len);
    // Writing to a Vec cannot fail.
    write_glb(model, ids.as_ref(), &json_bytes, bin_len, &mut out).ok()?;
    Some(out)
}

/// The name of an OBJ's material library: the OBJ's stem with `.mtl`
/// (`model.mtl` for a path without one), spelt so that `mtllib` names it
/// exactly. `mtllib` takes a list of names separated by spaces and `#`
/// starts a comment, so white space becomes `_` (`my model.obj` gets
/// `my_model.mtl`) and `#` `%XX` (`%23`), as do `%` itself, control
/// characters and each byte of a name that is not UTF-8 (`\xff.obj` gets
/// `%FF.mtl`, where replacing such bytes with U+FFFD gave every such name
/// the same library, one export's overwriting another's).
pub fn mtl_file_name(obj: &Path) -> String {
    let Some(stem) = obj.file_stem().filter(|s| !s.is_empty()) else {
        return "model.mtl".to_string();
    };
    let mut out = String::with_capacity(stem.len() + 4);
    let escape = |out: &mut String, bytes: &[u8]| {
        for b in bytes {
            let _ = write!(out, "%{b:02X}");
        }
    };
    for chunk in stem.as_encoded_bytes().utf8_chunks() {
        for c in chunk.valid().chars() {
            if c.is_whitespace() {
                out.push('_');
            } else if c == '#' || c == '%' || c.is_control() {
                escape(&mut out, c.encode_utf8(&mut [0; 4]).as_bytes());
            } else {
                out.push(c);
            }
        }
        escape(&mut out, chunk.invalid());
    }
    out + ".mtl"
}

fn write_mtl(model: &Model, w: &mut dyn Write) -> io::Result<()> {
    writeln!(w, "# grm materials")?;
    for m in &model.materials {
        let [r, g, b] = m.color;
        let [er, eg, eb] = m.emissive;
        writeln!(w, "\nnewmtl {}", m.name)?;
        writeln!(w, "Ka 0 0 0")?;
        writeln!(w, "Kd {r} {g} {b}")?;
        writeln!(w, "Ks 0.04 0.04 0.04")?;
        writeln!(w, "Ke {er} {eg} {eb}")?;
        writeln!(w, "d {}", m.opacity)?;
        writeln!(w, "Pr {}", m.roughness)?;
        writeln!(w, "Pm {}", m.metallic)?;
        writeln!(w, "illum 2")?;
        if let Some(t) = m.texture.and_then(|t| model.textures.get(t)) {
            writeln!(w, "map_Kd {}", t.path.display())?;
        }
    }
    Ok(())
}

/// A shape-mode model's OBJ: per group an object and a group of its name
/// (`o`, `g`), then per part it uses the span's `v`, `vt`, `vn`, `usemtl`
/// and faces `f v/vt/vn`.
fn write_shape_obj(model: &Model, w: &mut dyn Write) -> io::Result<()> {
    let mut base = 1usize;
    for g in &model.groups {
        writeln!(w, "o {}\ng {}", g.name, g.name)?;
        for span in &g.spans {
            let Some(d) = span_data(model, span) else {
                continue;
            };
            for [x, y, z] in d.positions {
                writeln!(w, "v {x} {y} {z}")?;
            }
            if let Some(uv) = d.uvs {
                for [u, v] in uv {
                    writeln!(w, "vt {u} {v}")?;
                }
            }
            for [x, y, z] in d.normals {
                writeln!(w, "vn {x} {y} {z}")?;
            }
            let name = model
                .parts
                .get(span.part)
                .and_then(|p| model.materials.get(p.material))
                .map_or("default", |m| m.name.as_str());
            writeln!(w, "usemtl {name}")?;
            for t in d.indices.chunks_exact(3) {
                let [a, b, c] =
                    [t[0], t[1], t[2]].map(|i| i.saturating_sub(d.first) as usize + base);
                if d.uvs.is_some() {
                    writeln!(w, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}")?;
                } else {
                    writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
                }
            }
            base += d.positions.len();
        }
    }
    Ok(())
}

fn write_obj(model: &Model, mtl_name: &str, w: &mut dyn Write) -> io::Result<()> {
    writeln!(
        w,
        "# grm model: {} vertices, {} triangles",
        model.stats.vertices, model.stats.triangles
    )?;
    writeln!(w, "mtllib {mtl_name}")?;
    if !model.groups.is_empty() {
        return write_shape_obj(model, w);
    }
    let mut base = 1usize;
    for (k, part) in model.parts.iter().enumerate() {
        let m = &part.mesh;
        let name = model
            .materials
            .get(part.material)
            .map_or("default", |m| m.name.as_str());
        writeln!(w, "o part{k}_{name}")?;
        for [x, y, z] in &m.positions {
            writeln!(w, "v {x} {y} {z}")?;
        }
        for [x, y, z] in &m.normals {
            writeln!(w, "vn {x} {y} {z}")?;
        }
        writeln!(w, "usemtl {name}")?;
        for t in m.indices.chunks_exact(3) {
            let (a, b, c) = (
                t[0] as usize + base,
                t[1] as usize + base,
                t[2] as usize + base,
            );
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        }
        base += m.positions.len();
    }
    Ok(())
}

/// grm's +y-up space turned to PLY's +z up: (x, y, z) as (x, -z, y), a
/// quarter turn about x (a rotation: windings and normals stay right).
fn z_up([x, y, z]: [f32; 3]) -> [f32; 3] {
    [x, -z, y]
}

fn write_ply(model: &Model, ascii: bool, w: &mut dyn Write) -> io::Result<()> {
    let format = if ascii {
        "ascii"
    } else {
        "binary_little_endian"
    };
    let vertices: usize = model.parts.iter().map(|p| p.mesh.positions.len()).sum();
    let faces: usize = model.parts.iter().map(|p| p.mesh.indices.len() / 3).sum();
    // Blender (4.5) refuses a PLY without vertices ("no vertices"): an
    // empty model is one vertex at the origin, without faces.
    let placeholder = vertices == 0;
    writeln!(w, "ply")?;
    writeln!(w, "format {format} 1.0")?;
    writeln!(w, "comment generated by grm")?;
    writeln!(
        w,
        "comment z up (grm's y up turned: x, -z, y); sRGB colours"
    )?;
    writeln!(w, "element vertex {}", vertices.max(1))?;
    for p in ["x", "y", "z", "nx", "ny", "nz"] {
        writeln!(w, "property float {p}")?;
    }
    for p in ["red", "green", "blue"] {
        writeln!(w, "property uchar {p}")?;
    }
    writeln!(w, "element face {faces}")?;
    writeln!(w, "property list uchar uint vertex_indices")?;
    writeln!(w, "end_header")?;
    // Vertex colours are 8-bit sRGB, as viewers show them (a linear value
    // scaled to 255 came out darker than the glb and the picture).
    let rgb = |part: &crate::Part| {
        model
            .materials
            .get(part.material)
            .map_or([204, 204, 204], |m| m.color.map(render::srgb))
    };
    let mut vertex = |p: [f32; 3], n: [f32; 3], c: [u8; 3]| -> io::Result<()> {
        if ascii {
            writeln!(
                w,
                "{} {} {} {} {} {} {} {} {}",
                p[0], p[1], p[2], n[0], n[1], n[2], c[0], c[1], c[2]
            )
        } else {
            let mut buf = [0u8; 27];
            for (i, x) in p.iter().chain(&n).enumerate() {
                buf[i * 4..i * 4 + 4].copy_from_slice(&x.to_le_bytes());
            }
            buf[24..27].copy_from_slice(&c);
            w.write_all(&buf)
        }
    };
    if placeholder {
        vertex([0.0; 3], [0.0, 0.0, 1.0], [204, 204, 204])?;
    }
    for part in &model.parts {
        let c = rgb(part);
        for (p, n) in part.mesh.positions.iter().zip(&part.mesh.normals) {
            vertex(z_up(*p), z_up(*n), c)?;
        }
    }
    let mut base = 0u32;
    for part in &model.parts {
        for t in part.mesh.indices.chunks_exact(3) {
            let (a, b, c) = (t[0] + base, t[1] + base, t[2] + base);
            if ascii {
                writeln!(w, "3 {a} {b} {c}")?;
            } else {
                let mut buf = [0u8; 13];
                buf[0] = 3;
                buf[1..5].copy_from_slice(&a.to_le_bytes());
                buf[5..9].copy_from_slice(&b.to_le_bytes());
                buf[9..13].copy_from_slice(&c.to_le_bytes());
                w.write_all(&buf)?;
            }
        }
        base += part.mesh.positions.len() as u32;
    }
    Ok(())
}

/// A linear colour as an SVG colour: sRGB-encoded, as SVG colours are.
fn hex(c: [f32; 3]) -> String {
    let [r, g, b] = c.map(render::srgb);
    format!("#{r:02x}{g:02x}{b:02x}")
}

/// A number for SVG (non-finite values become 0).
fn num(x: f32) -> f32 {
    if x.is_finite() { x } else { 0.0 }
}

/// The model's XY projection as an SVG document.
pub fn svg_string(model: &Model) -> String {
    let s = &model.skeleton;
    let colour = |p: Paint| hex(model.paint_color(p));
    // Projected bounds, including stroke widths.
    let mut b = Aabb::EMPTY;
    for bone in &s.bones {
        let r = 0.5 * bone.width_base.max(bone.width_tip).max(0.0);
        for p in [bone.base, bone.tip] {
            b.add(Vec3::new(p.x - r, p.y - r, 0.0));
            b.add(Vec3::new(p.x + r, p.y + r, 0.0));
        }
    }
    for p in &s.polygon_vertices {
        b.add(Vec3::new(p.x, p.y, 0.0));
    }
    let (min, size) = if b.is_empty() {
        (Vec3::ZERO, Vec3::ONE)
    } else {
        let size = b.size().max(Vec3::splat(1e-6));
        let margin = 0.02 * size.x.max(size.y);
        (
            b.min - Vec3::splat(margin),
            size + Vec3::splat(2.0 * margin),
        )
    };
    // SVG's y points down: a point (x, y) is drawn at (x, -y).
    let (vx, vy, vw, vh) = (min.x, -(min.y + size.y), size.x, size.y);
    let px = 800.0 / vw.max(vh);
    let mut out = String::with_capacity(256 + s.bones.len() * 96);
    out.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        out,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"{} {} {} {}\" width=\"{}\" height=\"{}\">",
        num(vx),
        num(vy),
        num(vw),
        num(vh),
        num((vw * px).round().max(1.0)),
        num((vh * px).round().max(1.0)),
    );
    if !s.polygons.is_empty() {
        out.push_str("<g stroke=\"none\">\n");
        for poly in &s.polygons {
            let vs = s.vertices(poly);
            let _ = write!(out, "<path fill=\"{}\" d=\"", colour(poly.paint));
            for (i, p) in vs.iter().enumerate() {
                let _ = write!(
                    out,
                    "{}{} {} ",
                    if i == 0 { "M" } else { "L" },
                    num(p.x),
                    num(-p.y)
                );
            }
            out.push_str("Z\"/>\n");
        }
        out.push_str("</g>\n");
    }
    if !s.bones.is_empty() {
        out.push_str("<g fill=\"none\" stroke-linecap=\"round\">\n");
        for bone in &s.bones {
            let w = 0.5 * (bone.width_base + bone.width_tip);
            let _ = write!(
                out,
                "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{}\" ",
                num(bone.base.x),
                num(-bone.base.y),
                num(bone.tip.x),
                num(-bone.tip.y),
                colour(bone.paint)
            );
            if w > 0.0 && w.is_finite() {
                let _ = writeln!(out, "stroke-width=\"{w}\"/>");
            } else {
                out.push_str("stroke-width=\"1\" vector-effect=\"non-scaling-stroke\"/>\n");
            }
        }
        out.push_str("</g>\n");
    }
    out.push_str("</svg>\n");
    out
}
