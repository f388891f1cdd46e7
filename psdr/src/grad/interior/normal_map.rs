//! Reverse mode for normal-map texels: how the BSDF terms of a recorded vertex change with its shading normal,
//! chained through `render::shading::surface_point`'s normal mapping
//!     n_s = normalize(T m.x + B m.y + n₀ m.z),   m = 2 c − 1,   c = bilinear lookup of the map,
//! where (T, B, n₀) is the frame before mapping. The inputs are rebuilt as `surface_point` builds them and the
//! mapping runs in duals (`map_normal_dual`, shared with the pose replay); a test checks the mapped normal
//! against `surface_point`'s.

use crate::grad::ad::bsdf_dual::{bsdf_eval_dual, BsdfParamsD};
use crate::grad::ad::dual::{D, D3};
use crate::grad::ad::dual_texture::dual_texture;
use crate::render::layout::{MaterialGpu, TextureGpu, NONE, SHADING_HAS_UVS};
use crate::render::shading::{
    apply_uv_transform, facing_normals, orthogonal, surface_point, SurfacePoint, TERMINATOR_COS,
};
use crate::render::texture::texture_sample_rgb;
use crate::render::SceneData;
use glam::{Mat3, Vec2, Vec3};

/// The shading point and ∂n_s/∂c (columns: map channels r, g, b) at a hit, or None where the map is not
/// applied (no map, or the mapped normal fell below the surface and `surface_point` kept the unmapped one).
pub fn normal_map_jacobian(d: &SceneData, ti: u32, u: f32, v: f32, incoming: Vec3) -> Option<(SurfacePoint, Mat3)> {
    let h = MapInputs::at(d, ti, u, v, incoming)?;
    let frame = h.frame(|x| {
        let q = apply_uv_transform(h.mat, x);
        [D::c(q.x), D::c(q.y)]
    });
    let texel = texture_sample_rgb(&d.texels, h.map, h.uvt);
    // None where the map was not applied: n_s does not depend on it.
    let column = |axis: Vec3| {
        map_normal_dual(h.e1, h.e2, h.ns, h.ng, &frame, D3 { v: texel, d: axis }).map(|n| turn_toward_viewer(n, h.dir))
    };
    let (r, g, b) = (column(Vec3::X)?, column(Vec3::Y)?, column(Vec3::Z)?);
    debug_assert!((r.v - h.sp.ns).length() < 1e-5, "the rebuilt mapping must reproduce surface_point's");
    Some((h.sp, Mat3::from_cols(r.d, g.d, b.d)))
}

/// What `map_normal_dual` needs at a hit on a normal-mapped triangle, rebuilt as `surface_point` builds it.
struct MapInputs<'a> {
    sp: SurfacePoint,
    mat: &'a MaterialGpu,
    map: &'a TextureGpu,
    e1: D3,
    e2: D3,
    /// The unmapped shading normal and the geometric one, both flipped toward the incoming ray.
    ns: D3,
    ng: Vec3,
    uv: [Vec2; 3],
    uv_hit: Vec2,
    uvt: Vec2,
    has_uvs: bool,
    /// The incoming ray's direction.
    dir: Vec3,
}

impl<'a> MapInputs<'a> {
    fn at(d: &'a SceneData, ti: u32, u: f32, v: f32, incoming: Vec3) -> Option<MapInputs<'a>> {
        let tri = &d.triangles[ti as usize];
        let mat = &d.materials[tri.material as usize];
        if mat.normal_tex == NONE {
            return None;
        }
        let sh = &d.shading[ti as usize];
        let (e1, e2) = (Vec3::from(tri.e1), Vec3::from(tri.e2));
        let (ng, ns, _) = facing_normals(d, ti, u, v, incoming);
        let w = 1.0 - u - v;
        let has_uvs = sh.flags & SHADING_HAS_UVS != 0;
        let uv = [Vec2::from(sh.uv0), Vec2::from(sh.uv1), Vec2::from(sh.uv2)];
        let uv_hit = if has_uvs { uv[0] * w + uv[1] * u + uv[2] * v } else { Vec2::new(u, v) };
        Some(MapInputs {
            sp: surface_point(d, ti, u, v, incoming),
            mat,
            map: &d.textures[mat.normal_tex as usize],
            e1: D3::c(e1),
            e2: D3::c(e2),
            ns: D3::c(ns),
            ng,
            uv,
            uv_hit,
            uvt: apply_uv_transform(mat, uv_hit),
            has_uvs,
            dir: incoming,
        })
    }
}

impl MapInputs<'_> {
    /// The uv frame with corner uvs transformed by `transform` (duals when uv parameters move).
    fn frame(&self, transform: impl Fn(Vec2) -> [D; 2]) -> UvFrame {
        let [q0, q1, q2] = self.uv.map(transform);
        UvFrame { duv1: [q1[0] - q0[0], q1[1] - q0[1]], duv2: [q2[0] - q0[0], q2[1] - q0[1]], has_uvs: self.has_uvs }
    }
}

/// The uv differences of a triangle's corners after the uv transform (duals: they move with uv parameters),
/// and whether the mesh has uvs at all.
pub struct UvFrame {
    pub duv1: [D; 2],
    pub duv2: [D; 2],
    pub has_uvs: bool,
}

/// `render::shading::surface_point`'s normal mapping in duals: the tangent frame from the (dual) triangle edges
/// and uv differences, orthonormalised against the (dual) unmapped normal `ns`, then the map value `texel`.
/// The frame's fallback for degenerate uvs (`orthogonal`) is held constant.
pub fn map_normal_dual(e1: D3, e2: D3, ns: D3, ng: Vec3, f: &UvFrame, texel: D3) -> Option<D3> {
    let [u1, v1] = f.duv1;
    let [u2, v2] = f.duv2;
    let det = u1 * v2 - v1 * u2;
    let framed = det.v != 0.0 && f.has_uvs;
    let mut tangent = if framed { (e1 * v2 - e2 * v1) * (D::c(1.0) / det) } else { D3::c(orthogonal(ns.v)) };
    tangent = tangent - ns * ns.dot(tangent);
    tangent = if tangent.v.length() > 1e-12 { tangent.normalize() } else { D3::c(orthogonal(ns.v)) };
    let mut bitangent = ns.cross(tangent);
    if framed {
        let dpdv = (e2.v * u1.v - e1.v * u2.v) * (1.0 / det.v);
        if bitangent.v.dot(dpdv) < 0.0 {
            bitangent = -bitangent;
        }
    }
    let m = texel.mul_c(Vec3::splat(2.0)) - D3::c(Vec3::ONE);
    let n = tangent * D { v: m.v.x, d: m.d.x } + bitangent * D { v: m.v.y, d: m.d.y } + ns * D { v: m.v.z, d: m.d.z };
    (n.v.length() > 0.0 && n.v.dot(ng) > 0.0).then(|| n.normalize())
}

/// `surface_point`'s turn of a shading normal toward a viewer who would see it below cosine TERMINATOR_COS, in
/// duals (`dir` is the incoming ray, fixed).
pub fn turn_toward_viewer(ns: D3, dir: Vec3) -> D3 {
    let c = ns.dot(D3::c(-dir));
    if c.v < TERMINATOR_COS {
        (ns - D3::c(dir) * (D::c(TERMINATOR_COS) - c)).normalize()
    } else {
        ns
    }
}

/// ∂n_s/∂(uv scale x, uv scale y, uv rotation in degrees) at a hit on a normal-mapped surface: the map is read
/// elsewhere and the tangent frame turns with the transform. `scale` and `rotation_deg` are the material's.
pub fn normal_map_uv_tangents(
    d: &SceneData,
    ti: u32,
    u: f32,
    v: f32,
    incoming: Vec3,
    scale: Vec2,
    rotation_deg: f32,
) -> [Vec3; 3] {
    let Some(h) = MapInputs::at(d, ti, u, v, incoming) else { return [Vec3::ZERO; 3] };
    let (s, c) = rotation_deg.to_radians().sin_cos();
    let k = std::f32::consts::PI / 180.0;
    // uv' = M uv + o with M = R(φ) diag(sx, sy); the columns of ∂M per parameter.
    let d_m = [
        [Vec2::new(c, s), Vec2::ZERO],
        [Vec2::ZERO, Vec2::new(-s, c)],
        [Vec2::new(-s * scale.x, c * scale.x) * k, Vec2::new(-c * scale.y, -s * scale.y) * k],
    ];
    d_m.map(|[col0, col1]| {
        let dm = |x: Vec2| col0 * x.x + col1 * x.y;
        let frame = h.frame(|x| {
            let (q, dq) = (apply_uv_transform(h.mat, x), dm(x));
            [D { v: q.x, d: dq.x }, D { v: q.y, d: dq.y }]
        });
        let duvt = dm(h.uv_hit);
        let ch = |k| dual_texture(d, h.map, h.uvt, duvt, k);
        let (r, g, b) = (ch(0), ch(1), ch(2));
        let texel = D3 { v: Vec3::new(r.v, g.v, b.v), d: Vec3::new(r.d, g.d, b.d) };
        map_normal_dual(h.e1, h.e2, h.ns, h.ng, &frame, texel).map_or(Vec3::ZERO, |n| turn_toward_viewer(n, h.dir).d)
    })
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
        let (mut checked, mut mapped) = (0, 0);
        for ti in 0..d.triangles.len() as u32 {
            let has_map = d.materials[d.triangles[ti as usize].material as usize].normal_tex != NONE;
            for (u, v) in [(0.2, 0.3), (0.6, 0.1), (0.25, 0.7)] {
                mapped += has_map as u32;
                let incoming = Vec3::new(0.3, -0.8, -0.5).normalize();
                // None unless the rebuilt mapping reproduces surface_point's normal (or the map is absent).
                let Some((sp, jac)) = normal_map_jacobian(&d, ti, u, v, incoming) else { continue };
                let cols = jac.to_cols_array_2d();
                assert!(cols.iter().flatten().all(|x| x.is_finite()));
                // n_s stays unit: every column is orthogonal to it.
                for col in cols {
                    assert!(Vec3::from(col).dot(sp.ns).abs() < 1e-4);
                }
                checked += 1;
            }
        }
        assert!(mapped > 0 && checked == mapped, "normal-mapped hits reproduced: {checked} of {mapped}");
    }
}
