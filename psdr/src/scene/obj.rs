//! OBJ loading (tobj): one `MeshPart` per material group, so parts can carry different materials.

use super::{drop_unseen_triangles, MeshPart};
use crate::error::{Error, Result};
use glam::{Vec2, Vec3};
use std::path::Path;

/// A material as described by the OBJ's MTL file (used when the scene does not override it).
#[derive(Clone, Debug, PartialEq)]
pub struct MtlMaterial {
    pub name: String,
    pub diffuse: Option<Vec3>,
    pub diffuse_texture: Option<String>,
}

pub struct ObjMesh {
    pub parts: Vec<MeshPart>,
    /// For each part, the MTL material it used (if the MTL file was found).
    pub part_mtl: Vec<Option<MtlMaterial>>,
    /// Triangles left out: zero-area ones and repeats of an earlier triangle of the file
    /// (`drop_unseen_triangles`).
    pub dropped: usize,
}

pub fn load_obj(path: &Path) -> Result<ObjMesh> {
    let opts = tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
    let (models, mtls) = match tobj::load_obj(path, &opts) {
        Err(
            tobj::LoadError::FaceVertexOutOfBounds
            | tobj::LoadError::FaceTexCoordOutOfBounds
            | tobj::LoadError::FaceNormalOutOfBounds,
        ) => load_forward_references(path, &opts)?,
        other => other.map_err(|e| Error::io(path, format!("cannot load OBJ: {e}")))?,
    };
    // A missing or broken MTL file is not fatal: parts are then grouped by OBJ group name.
    let mtls = mtls.unwrap_or_default();
    let mut parts: Vec<MeshPart> = Vec::new();
    let mut part_mtl: Vec<Option<MtlMaterial>> = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        if mesh.indices.is_empty() {
            continue;
        }
        let mtl = mesh.material_id.and_then(|id| mtls.get(id));
        let key = mtl.map(|m| m.name.clone()).unwrap_or_else(|| model.name.clone());
        let (has_normals, has_uvs) = attributes(mesh);
        // Groups of one material merge into one part when they carry the same vertex attributes; a group
        // without uvs or normals beside one with them becomes a part of its own (same name), so neither loses
        // what it has and the renderer treats each as its file says.
        let same = |p: &MeshPart| p.name == key && p.uvs.is_some() == has_uvs && p.normals.is_some() == has_normals;
        let idx = match parts.iter().position(same) {
            Some(i) => i,
            None => {
                parts.push(MeshPart {
                    name: key.clone(),
                    normals: has_normals.then(Vec::new),
                    uvs: has_uvs.then(Vec::new),
                    ..Default::default()
                });
                part_mtl.push(mtl.map(|m| MtlMaterial {
                    name: m.name.clone(),
                    diffuse: m.diffuse.map(Vec3::from),
                    diffuse_texture: m.diffuse_texture.clone(),
                }));
                parts.len() - 1
            }
        };
        append_mesh(&mut parts[idx], mesh, path, &model.name)?;
    }
    let kept = drop_unseen_triangles(&mut parts);
    let dropped = kept.dropped;
    let mut keep = kept.parts_kept.iter();
    part_mtl.retain(|_| *keep.next().unwrap_or(&true));
    if parts.is_empty() {
        let why = if dropped > 0 { format!(" ({dropped} flat or repeated ones left out)") } else { String::new() };
        return Err(Error::io(path, format!("OBJ file contains no triangle with an area{why}")));
    }
    Ok(ObjMesh { parts, part_mtl, dropped })
}

/// What tobj reads: the models and the MTL file's materials (or why they could not be read).
type TobjModels = (Vec<tobj::Model>, std::result::Result<Vec<tobj::Material>, tobj::LoadError>);

/// Reads an OBJ whose faces name vertices, texture coordinates or normals defined further down the file
/// (Sweet Home 3D's own reader allows it, and its truck model does it): every `v`, `vt` and `vn` line moved
/// before the first face, which is what such a file means when no index is relative. A file with relative
/// (negative) indices or a real out-of-range index still fails, with the reader's reason.
fn load_forward_references(path: &Path, opts: &tobj::LoadOptions) -> Result<TobjModels> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let is_attribute =
        |l: &str| ["v ", "vt ", "vn ", "v\t", "vt\t", "vn\t"].iter().any(|p| l.trim_start().starts_with(p));
    let relative =
        text.lines().filter(|l| l.trim_start().starts_with("f ")).any(|l| l.contains(" -") || l.contains("/-"));
    let (attributes, rest): (Vec<&str>, Vec<&str>) = text.lines().partition(|l| is_attribute(l));
    let hoisted = attributes.into_iter().chain(rest).collect::<Vec<_>>().join("\n");
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let loaded = tobj::load_obj_buf(&mut hoisted.as_bytes(), opts, |mtl| tobj::load_mtl(dir.join(mtl)));
    match loaded {
        Ok(r) if !relative => Ok(r),
        Ok(_) => Err(Error::io(path, "cannot load OBJ: a face index is out of range (relative indices)")),
        Err(e) => Err(Error::io(path, format!("cannot load OBJ: {e}"))),
    }
}

/// Whether a group's vertices all carry normals and uvs. tobj gives a group whose faces mix corners with and
/// without them shorter arrays than its positions, which cannot be matched to vertices: then none are used.
fn attributes(mesh: &tobj::Mesh) -> (bool, bool) {
    let n = mesh.positions.len() / 3;
    (n > 0 && mesh.normals.len() == 3 * n, n > 0 && mesh.texcoords.len() == 2 * n)
}

fn append_mesh(part: &mut MeshPart, mesh: &tobj::Mesh, path: &Path, model: &str) -> Result<()> {
    let n = mesh.positions.len() / 3;
    let base = part.positions.len() as u32;
    part.positions.extend(mesh.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])));
    if let Some(ns) = part.normals.as_mut() {
        ns.extend(mesh.normals.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2]).normalize_or_zero()));
    }
    if let Some(uvs) = part.uvs.as_mut() {
        uvs.extend(mesh.texcoords.chunks_exact(2).map(|p| Vec2::new(p[0], p[1])));
    }
    for (k, t) in mesh.indices.chunks_exact(3).enumerate() {
        if t.iter().any(|&i| i as usize >= n) {
            return Err(Error::io(path, format!("group '{model}': face {k} indexes a missing vertex")));
        }
        part.indices.push([base + t[0], base + t[1], base + t[2]]);
    }
    if let Some(bad) = part.positions.iter().position(|p| !p.is_finite()) {
        return Err(Error::io(path, format!("vertex {bad} is not finite")));
    }
    if let Some(bad) = part.uvs.iter().flatten().position(|t| !t.is_finite()) {
        return Err(Error::io(path, format!("texture coordinate {bad} is not finite")));
    }
    Ok(())
}
