//! Mesh parts -> OBJ + MTL text that `load_obj` reads back to the same triangles (what every pipeline stage
//! writes for its objects, `scene::save_scene`). Each part is a group of its own with its own `usemtl`, so a part
//! keeps its name through the MTL material (`load_obj` names parts by material), and positions, texture
//! coordinates and normals are numbered separately: a part without uvs or normals beside parts with them writes
//! no `vt`/`vn` of its own and indexes only what it wrote (indexing them by vertex number wrote files that no
//! reader accepts, "face texcoord index out of bounds").

use super::MeshPart;
use glam::Vec3;
use std::fmt::Write as _;

/// The OBJ and MTL text of a list of parts, and the name each part is written under.
pub struct ObjText {
    pub obj: String,
    pub mtl: String,
    /// Per part: the name `load_obj` will give it back. The part's own name where the file can carry it, else
    /// `partK` (see `written_names`).
    pub names: Vec<String>,
}

/// Whether `load_obj` reads `name` back unchanged as an MTL material name (tobj trims it and stops at the line).
fn representable(name: &str) -> bool {
    !name.is_empty() && name.trim() == name && !name.chars().any(char::is_control)
}

/// The names parts are written under. `load_obj` merges groups of one material name that carry the same
/// attributes, so a part keeps its name unless an earlier part with that name would merge with it or has
/// another material (one name maps to one material in the scene file); then, or when the name cannot be
/// written, it becomes `partK` (K its index).
pub fn written_names(parts: &[MeshPart]) -> Vec<String> {
    let mut names: Vec<String> = vec![];
    for (k, p) in parts.iter().enumerate() {
        let clash = parts[..k].iter().zip(&names).any(|(q, n)| {
            n == &p.name
                && (q.material != p.material
                    || (q.uvs.is_some(), q.normals.is_some()) == (p.uvs.is_some(), p.normals.is_some()))
        });
        let fallback = || {
            let mut n = format!("part{k}");
            while names.contains(&n) || parts.iter().any(|q| q.name == n) {
                n.push('_');
            }
            n
        };
        names.push(if representable(&p.name) && !clash { p.name.clone() } else { fallback() });
    }
    names
}

/// OBJ text referencing `mtl_file` (a file name beside it) and that MTL's text; `diffuse(k)` is part k's
/// colour for other programs (psdr's scene file gives the materials).
pub fn obj_text(parts: &[MeshPart], mtl_file: &str, diffuse: &dyn Fn(usize) -> Vec3) -> ObjText {
    let names = written_names(parts);
    let mut obj = format!("# written by psdr\nmtllib {mtl_file}\n");
    let mut mtl = String::from("# written by psdr: the scene file's materials override these\n");
    let mut declared: Vec<&str> = vec![];
    let (mut v_base, mut vt_base, mut vn_base) = (1usize, 1usize, 1usize);
    for (k, (p, name)) in parts.iter().zip(&names).enumerate() {
        if p.indices.is_empty() {
            continue; // `load_obj` keeps no part without triangles
        }
        if !declared.contains(&name.as_str()) {
            let c = diffuse(k).clamp(Vec3::ZERO, Vec3::ONE);
            let _ = writeln!(mtl, "newmtl {name}\nKd {} {} {}", c.x, c.y, c.z);
            declared.push(name);
        }
        let _ = writeln!(obj, "o g{k}\nusemtl {name}");
        for v in &p.positions {
            let _ = writeln!(obj, "v {} {} {}", v.x, v.y, v.z);
        }
        for t in p.uvs.iter().flatten() {
            let _ = writeln!(obj, "vt {} {}", t.x, t.y);
        }
        for n in p.normals.iter().flatten() {
            let _ = writeln!(obj, "vn {} {} {}", n.x, n.y, n.z);
        }
        for tri in &p.indices {
            obj.push('f');
            for &i in tri {
                let (v, t, n) = (v_base + i as usize, vt_base + i as usize, vn_base + i as usize);
                let _ = match (p.uvs.is_some(), p.normals.is_some()) {
                    (false, false) => write!(obj, " {v}"),
                    (true, false) => write!(obj, " {v}/{t}"),
                    (false, true) => write!(obj, " {v}//{n}"),
                    (true, true) => write!(obj, " {v}/{t}/{n}"),
                };
            }
            obj.push('\n');
        }
        v_base += p.positions.len();
        vt_base += p.uvs.as_ref().map_or(0, Vec::len);
        vn_base += p.normals.as_ref().map_or(0, Vec::len);
    }
    ObjText { obj, mtl, names }
}
