//! Reverse mode for normal-map texels: how the BSDF terms of a recorded vertex change with its shading normal,
//! chained through `render::shading::surface_point`'s normal mapping
//!     n_s = normalize(T m.x + B m.y + n₀ m.z),   m = 2 c − 1,   c = bilinear lookup of the map,
//! where (T, B, n₀) is the frame before mapping. The frame is rebuilt here in plain f32, line by line as
//! `surface_point` builds it; a test checks the mapped normal against `surface_point`'s.

use super::bsdf_dual::{bsdf_eval_dual, BsdfParamsD};
use super::dual::{D, D3};
use crate::render::layout::{NONE, SHADING_HAS_NORMALS, SHADING_HAS_UVS};
use crate::render::shading::{apply_uv_transform, orthogonal, surface_point, SurfacePoint};
use crate::render::texture::texture_sample_rgb;
use crate::render::SceneData;
use glam::{Mat3, Vec2, Vec3};

/// The shading point and ∂n_s/∂c (columns: map channels r, g, b) at a hit, or None where the map is not
/// applied (no map, or the mapped normal fell below the surface and `surface_point` kept the unmapped one).
pub fn normal_map_jacobian(d: &SceneData, ti: u32, u: f32, v: f32, incoming: Vec3) -> Option<(SurfacePoint, Mat3)> {
    let tri = &d.triangles[ti as usize];
    let mat = &d.materials[tri.material as usize];
    if mat.normal_tex == NONE {
        return None;
    }
    let sh = &d.shading[ti as usize];
    let (e1, e2) = (Vec3::from(tri.e1), Vec3::from(tri.e2));
    let mut ng = e1.cross(e2).normalize();
    let w = 1.0 - u - v;
    let mut ns = if sh.flags & SHADING_HAS_NORMALS != 0 {
        let n = Vec3::from(sh.n0) * w + Vec3::from(sh.n1) * u + Vec3::from(sh.n2) * v;
        let len = n.length();
        if len > 0.0 {
            n / len
        } else {
            ng
        }
    } else {
        ng
    };
    if ng.dot(incoming) >= 0.0 {
        ng = -ng;
    }
    if ns.dot(ng) < 0.0 {
        ns = -ns;
    }
    let (uv0, uv1, uv2) = (Vec2::from(sh.uv0), Vec2::from(sh.uv1), Vec2::from(sh.uv2));
    let has_uvs = sh.flags & SHADING_HAS_UVS != 0;
    let uv = if has_uvs { uv0 * w + uv1 * u + uv2 * v } else { Vec2::new(u, v) };
    let uvt = apply_uv_transform(mat, uv);
    let duv1 = apply_uv_transform(mat, uv1) - apply_uv_transform(mat, uv0);
    let duv2 = apply_uv_transform(mat, uv2) - apply_uv_transform(mat, uv0);
    let det = duv1.x * duv2.y - duv1.y * duv2.x;
    let mut tangent = if det != 0.0 && has_uvs { (e1 * duv2.y - e2 * duv1.y) * (1.0 / det) } else { orthogonal(ns) };
    tangent = tangent - ns * ns.dot(tangent);
    let tl = tangent.length();
    tangent = if tl > 1e-12 { tangent / tl } else { orthogonal(ns) };
    let mut bitangent = ns.cross(tangent);
    if det != 0.0 && has_uvs {
        let dpdv = (e2 * duv1.x - e1 * duv2.x) * (1.0 / det);
        if bitangent.dot(dpdv) < 0.0 {
            bitangent = -bitangent;
        }
    }
    let m = texture_sample_rgb(&d.texels, &d.textures[mat.normal_tex as usize], uvt) * 2.0 - Vec3::ONE;
    let n = tangent * m.x + bitangent * m.y + ns * m.z;
    let len = n.length();
    if !(len > 0.0 && n.dot(ng) > 0.0) {
        return None;
    }
    let mapped = n / len;
    // ∂normalize(n)/∂n = (I − n̂ n̂ᵀ)/|n|, ∂n/∂m = [T B n₀], ∂m/∂c = 2.
    let project = (Mat3::IDENTITY - outer(mapped, mapped)) * (1.0 / len);
    let jacobian = project * Mat3::from_cols(tangent, bitangent, ns) * 2.0;
    Some((surface_point(d, ti, u, v, incoming), jacobian))
}

fn outer(a: Vec3, b: Vec3) -> Mat3 {
    Mat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// ∂(a · f(wi, wo))/∂n_s for the BSDF at `sp` (world directions; a weights the colour channels).
pub fn bsdf_normal_adjoint(sp: &SurfacePoint, wi: Vec3, wo: Vec3, a: Vec3) -> Vec3 {
    let p = BsdfParamsD {
        albedo: D3::c(sp.bsdf.albedo),
        roughness: D::c(sp.bsdf.roughness),
        specular: D::c(sp.bsdf.specular),
    };
    let along = |axis: Vec3| a.dot(bsdf_eval_dual(&p, D3 { v: sp.ns, d: axis }, D3::c(wi), D3::c(wo)).d);
    Vec3::new(along(Vec3::X), along(Vec3::Y), along(Vec3::Z))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{load_scene, Scene};

    fn room() -> Scene {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/room/scene.json");
        load_scene(std::path::Path::new(path)).unwrap()
    }

    /// The rebuilt frame maps to exactly the normal `surface_point` shades with, at hits on the example room's
    /// normal-mapped floor, and the Jacobian's columns are tangent to the unit sphere at n_s (the end-to-end
    /// check against finite differences is tests/tests/grad_interior.rs).
    #[test]
    fn rebuilt_frame_agrees_with_surface_point() {
        let d = SceneData::build(&room()).unwrap();
        let mut checked = 0;
        for ti in 0..d.triangles.len() as u32 {
            for (u, v) in [(0.2, 0.3), (0.6, 0.1), (0.25, 0.7)] {
                let incoming = Vec3::new(0.3, -0.8, -0.5).normalize();
                let Some((sp, jac)) = normal_map_jacobian(&d, ti, u, v, incoming) else { continue };
                let reference = surface_point(&d, ti, u, v, incoming);
                assert!((sp.ns - reference.ns).length() < 1e-6);
                let cols = jac.to_cols_array_2d();
                assert!(cols.iter().flatten().all(|x| x.is_finite()));
                // n_s stays unit: every column is orthogonal to it.
                for col in cols {
                    assert!(Vec3::from(col).dot(sp.ns).abs() < 1e-4);
                }
                checked += 1;
            }
        }
        assert!(checked > 0, "the example room has a normal-mapped floor");
    }
}
