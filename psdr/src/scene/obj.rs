//! OBJ loading (tobj): one `MeshPart` per material group, so parts can carry different materials.

use super::MeshPart;
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
}

pub fn load_obj(path: &Path) -> Result<ObjMesh> {
    let opts = tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
    let (models, mtls) = tobj::load_obj(path, &opts).map_err(|e| Error::io(path, format!("cannot load OBJ: {e}")))?;
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
        let idx = match parts.iter().position(|p| p.name == key) {
            Some(i) => i,
            None => {
                parts.push(MeshPart { name: key.clone(), ..Default::default() });
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
    if parts.is_empty() {
        return Err(Error::io(path, "OBJ file contains no triangles"));
    }
    Ok(ObjMesh { parts, part_mtl })
}

fn append_mesh(part: &mut MeshPart, mesh: &tobj::Mesh, path: &Path, model: &str) -> Result<()> {
    let n = mesh.positions.len() / 3;
    let base = part.positions.len() as u32;
    let had_vertices = base > 0;
    let has_normals = mesh.normals.len() == mesh.positions.len();
    let has_uvs = mesh.texcoords.len() / 2 == n && n > 0;
    // Parts merged from several groups keep normals/uvs only if all groups have them.
    if !had_vertices {
        part.normals = has_normals.then(Vec::new);
        part.uvs = has_uvs.then(Vec::new);
    } else {
        if !has_normals {
            part.normals = None;
        }
        if !has_uvs {
            part.uvs = None;
        }
    }
    part.positions.extend(mesh.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])));
    if let (Some(ns), true) = (part.normals.as_mut(), has_normals) {
        ns.extend(mesh.normals.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2]).normalize_or_zero()));
    }
    if let (Some(uvs), true) = (part.uvs.as_mut(), has_uvs) {
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
    Ok(())
}
