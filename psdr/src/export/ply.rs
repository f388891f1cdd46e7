//! Binary little-endian PLY writer for triangle meshes (positions, optional normals and uvs).

use crate::error::{Error, Result};
use crate::output::write_atomically;
use glam::{Vec2, Vec3};
use std::io::Write;
use std::path::Path;

pub fn write_ply(path: &Path, p: &[Vec3], n: Option<&[Vec3]>, uv: Option<&[Vec2]>, tris: &[[u32; 3]]) -> Result<()> {
    let mut buf: Vec<u8> = Vec::new();
    let mut header = format!("ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n", p.len());
    if n.is_some() {
        header += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    if uv.is_some() {
        header += "property float u\nproperty float v\n";
    }
    header += &format!("element face {}\nproperty list uchar int vertex_indices\nend_header\n", tris.len());
    buf.extend_from_slice(header.as_bytes());
    for i in 0..p.len() {
        let mut vals = p[i].to_array().to_vec();
        if let Some(n) = n {
            vals.extend_from_slice(&n[i].to_array());
        }
        if let Some(uv) = uv {
            vals.extend_from_slice(&uv[i].to_array());
        }
        for v in vals {
            buf.extend_from_slice(&v.to_le_bytes());
        }
    }
    for t in tris {
        buf.push(3);
        for &i in t {
            buf.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    write_atomically(path, |tmp| {
        let mut f = std::fs::File::create(tmp).map_err(|e| Error::io(path, e))?;
        f.write_all(&buf).map_err(|e| Error::io(path, e))
    })
}
