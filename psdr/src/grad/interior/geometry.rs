//! Interior term of radiance with respect to object poses and mesh vertices, in ray form: a recorded path is
//! replayed in dual numbers along one parameter component. Every sampled direction stays fixed (the camera ray,
//! each continuation and each next-event direction), and every vertex slides along its ray as the surface it
//! lies on moves (the hit's distance and barycentrics in dual numbers), so normals, texture lookups, cosines
//! and BSDF values change with it, while sampling densities, light selection, MIS weights and roulette stay
//! detached. Visibility changes are the boundary terms' job (boundary/).

use crate::grad::ad::bsdf_dual::{bsdf_eval_dual, BsdfParamsD};
use crate::grad::ad::dual::{D, D3};
use crate::grad::ad::dual_texture::dual_texture;
use crate::grad::interior::normal_map::{map_normal_dual, turn_toward_viewer, UvFrame};
use crate::grad::path::record::PathRecord;
use crate::grad::path::velocity::{PoseComponent, PoseLayout};
use crate::render::layout::{MaterialGpu, TriangleShading, NONE, SHADING_HAS_NORMALS, SHADING_HAS_UVS};
use crate::render::shading::apply_uv_transform;
use crate::render::SceneData;
use glam::{Vec2, Vec3};

/// A triangle whose vertices move with one pose component.
struct DualTriangle {
    v0: D3,
    e1: D3,
    e2: D3,
    object: u32,
}

/// The moving geometric component being differentiated.
#[derive(Clone, Copy)]
pub struct Tangent<'a> {
    pub pose: &'a PoseLayout,
    pub object: u32,
    pub component: PoseComponent,
}

impl<'a> Tangent<'a> {
    /// The tangent of entry `e` of `pose`.
    pub fn of(pose: &'a PoseLayout, e: usize) -> Tangent<'a> {
        let (object, component, _) = pose.entries[e];
        Tangent { pose, object, component }
    }
}

impl Tangent<'_> {
    fn moves(&self, object: u32) -> bool {
        object == self.object
    }
    /// A mesh vertex of `object` at world position x with welded id `id`.
    fn corner(&self, object: u32, id: u32, x: Vec3) -> D3 {
        let d =
            if self.moves(object) { self.pose.velocity(object, self.component, x, &[(id, 1.0)]) } else { Vec3::ZERO };
        D3 { v: x, d }
    }
    fn normal(&self, object: u32, n: Vec3) -> D3 {
        D3 {
            v: n,
            d: if self.moves(object) { self.pose.normal_velocity(object, self.component, n) } else { Vec3::ZERO },
        }
    }
}

fn triangle(d: &SceneData, t: &Tangent, ti: u32) -> DualTriangle {
    let tri = &d.triangles[ti as usize];
    let v0 = Vec3::from(tri.v0);
    let (e1, e2) = (Vec3::from(tri.e1), Vec3::from(tri.e2));
    let c = t.pose.corners(d, ti);
    let p0 = t.corner(tri.object, c[0], v0);
    let (p1, p2) = (t.corner(tri.object, c[1], v0 + e1), t.corner(tri.object, c[2], v0 + e2));
    // Keep the primal edge vectors bit-exact; only tangents come from the velocity field.
    DualTriangle { v0: p0, e1: D3 { v: e1, d: p1.d - p0.d }, e2: D3 { v: e2, d: p2.d - p0.d }, object: tri.object }
}

impl DualTriangle {
    fn point(&self, u: D, v: D) -> D3 {
        self.v0 + self.e1 * u + self.e2 * v
    }
    fn normal(&self) -> D3 {
        self.e1.cross(self.e2).normalize()
    }
    /// Möller–Trumbore for the ray from a (possibly moving) origin along a fixed direction: (t, u, v).
    fn intersect(&self, o: D3, dir: Vec3) -> (D, D, D) {
        let dir = D3::c(dir);
        let p = dir.cross(self.e2);
        let inv_det = D::c(1.0) / self.e1.dot(p);
        let s = o - self.v0;
        let u = s.dot(p) * inv_det;
        let q = s.cross(self.e1);
        (self.e2.dot(q) * inv_det, u, dir.dot(q) * inv_det)
    }
}

/// Shading point in duals: the shading normal (flipped toward the incoming ray as
/// `render::shading::surface_point` flips it) and material parameters.
struct DualPoint {
    ns: D3,
    bsdf: BsdfParamsD,
}

fn dual_point(d: &SceneData, tg: &Tangent, ti: u32, tri: &DualTriangle, u: D, v: D, incoming: Vec3) -> DualPoint {
    let sh = &d.shading[ti as usize];
    let mat = &d.materials[d.triangles[ti as usize].material as usize];
    let mut ng = tri.normal();
    let w = 1.0 - u - v;
    let mut ns = if sh.flags & SHADING_HAS_NORMALS != 0 {
        let n = tg.normal(tri.object, Vec3::from(sh.n0)) * w
            + tg.normal(tri.object, Vec3::from(sh.n1)) * u
            + tg.normal(tri.object, Vec3::from(sh.n2)) * v;
        if n.v.length() > 0.0 {
            n.normalize()
        } else {
            ng
        }
    } else {
        ng
    };
    if ng.v.dot(incoming) >= 0.0 {
        ng = -ng;
    }
    if ns.v.dot(ng.v) < 0.0 {
        ns = -ns;
    }
    // Texture coordinates slide only where the barycentrics do (the primary vertex on a moving object).
    let (uv, duv) = if sh.flags & SHADING_HAS_UVS != 0 {
        let (uv0, uv1, uv2) = (Vec2::from(sh.uv0), Vec2::from(sh.uv1), Vec2::from(sh.uv2));
        (uv0 * w.v + uv1 * u.v + uv2 * v.v, uv0 * w.d + uv1 * u.d + uv2 * v.d)
    } else {
        (Vec2::new(u.v, v.v), Vec2::new(u.d, v.d))
    };
    let row = |r: [f32; 4], uv: Vec2, lin: bool| r[0] * uv.x + r[1] * uv.y + if lin { 0.0 } else { r[2] };
    let uvt = Vec2::new(row(mat.uv_row0, uv, false), row(mat.uv_row1, uv, false));
    let duvt = Vec2::new(row(mat.uv_row0, duv, true), row(mat.uv_row1, duv, true));
    let scalar = |tex: u32, constant: f32| {
        if tex != NONE {
            dual_texture(d, &d.textures[tex as usize], uvt, duvt, 0)
        } else {
            D::c(constant)
        }
    };
    let rgb = |tex: u32| {
        let t = &d.textures[tex as usize];
        let c = |k| dual_texture(d, t, uvt, duvt, k);
        let (r, g, b) = (c(0), c(1), c(2));
        D3 { v: Vec3::new(r.v, g.v, b.v), d: Vec3::new(r.d, g.d, b.d) }
    };
    let mut bent = sh.flags & SHADING_HAS_NORMALS != 0;
    if mat.normal_tex != NONE {
        if let Some(n) = normal_mapped(mat, sh, tri, ns, ng, rgb(mat.normal_tex)) {
            (ns, bent) = (n, true);
        }
    }
    if bent {
        ns = turn_toward_viewer(ns, incoming);
    }
    let albedo = if mat.albedo_tex != NONE { rgb(mat.albedo_tex) } else { D3::c(Vec3::from(mat.albedo)) };
    // The primal clamps to [0, 1]; clamped channels do not move.
    let clamp3 = |a: D3| D3 {
        v: a.v.clamp(Vec3::ZERO, Vec3::ONE),
        d: Vec3::select(a.v.cmplt(Vec3::ZERO) | a.v.cmpgt(Vec3::ONE), Vec3::ZERO, a.d),
    };
    let bsdf = BsdfParamsD {
        albedo: clamp3(albedo),
        roughness: scalar(mat.roughness_tex, mat.roughness).clamp_c(0.0, 1.0),
        specular: scalar(mat.specular_tex, mat.specular).clamp_c(0.0, 1.0),
    };
    DualPoint { ns, bsdf }
}

/// `render::shading::surface_point`'s normal mapping with the tangent frame following the moving triangle
/// (uvs are fixed per vertex, so the uv Jacobian is constant) and the map value `texel` sliding with the uv.
fn normal_mapped(mat: &MaterialGpu, sh: &TriangleShading, tri: &DualTriangle, ns: D3, ng: D3, texel: D3) -> Option<D3> {
    let uvt = |uv: [f32; 2]| apply_uv_transform(mat, Vec2::from(uv));
    let (duv1, duv2) = (uvt(sh.uv1) - uvt(sh.uv0), uvt(sh.uv2) - uvt(sh.uv0));
    let frame = UvFrame {
        duv1: [D::c(duv1.x), D::c(duv1.y)],
        duv2: [D::c(duv2.x), D::c(duv2.y)],
        has_uvs: sh.flags & SHADING_HAS_UVS != 0,
    };
    map_normal_dual(tri.e1, tri.e2, ns, ng.v, &frame, texel)
}

/// The entries of `pose` that move some triangle of the path (a vertex's or a light sample's), once each, in
/// `out`; all other entries leave the path's value unchanged in the interior term.
pub fn entries_touching(d: &SceneData, pose: &PoseLayout, rec: &PathRecord, out: &mut Vec<usize>) {
    out.clear();
    let mut add = |ti: u32| {
        let object = d.triangles[ti as usize].object;
        if object != NONE && pose.moves(object) {
            pose.entries_moving(object, &pose.corners(d, ti), out);
        }
    };
    for v in &rec.vertices {
        add(v.triangle);
        if let Some(n) = &v.nee {
            add(n.triangle);
        }
    }
}

/// d(path radiance)/dθ along one pose component, and the replayed radiance (equal to the recorded one).
///
/// Ray form: every sampled direction (camera ray, BSDF samples, next-event directions) is held fixed in world
/// space and each vertex is where the ray from the (possibly moved) previous vertex meets its (possibly moved)
/// triangle; densities are detached. What moves is then the vertices along their rays, normals and textures at
/// the sliding hit points. Visibility changes along fixed directions (silhouettes, creases, emitter borders)
/// are the boundary terms' part, which `secondary_edges` and the primary edges sample in the same (solid angle)
/// form.
///
/// `vertex_velocity` receives dx_k/dθ of every vertex (how the ray-form vertices slide).
pub fn replay_radiance(d: &SceneData, tg: &Tangent, rec: &PathRecord, vertex_velocity: &mut Vec<Vec3>) -> (Vec3, Vec3) {
    vertex_velocity.clear();
    let mut throughput = D3::c(Vec3::ONE);
    let mut radiance = D3::default();
    let mut origin = D3::c(rec.origin);
    let mut dir = rec.dir;
    for (k, v) in rec.vertices.iter().enumerate() {
        let tri = triangle(d, tg, v.triangle);
        let (_, u, vv) = tri.intersect(origin, dir);
        let p = tri.point(u, vv);
        vertex_velocity.push(p.d);
        let sp = dual_point(d, tg, v.triangle, &tri, u, vv, dir);
        let wi = D3::c(-dir);
        if v.emitter != NONE {
            radiance = radiance + throughput.mul_c(v.emission * v.emission_mis);
        }
        if let Some(n) = &v.nee {
            // Fixed direction toward the recorded light point; emission is constant over the light.
            let wl = D3::c(n.dir);
            let f = bsdf_eval_dual(&sp.bsdf, sp.ns, wi, wl);
            radiance = radiance + (throughput * f).mul_c(n.radiance * n.w_over_pdf);
        }
        let Some(c) = v.next else { break };
        if k + 1 >= rec.vertices.len() {
            break;
        }
        let f = bsdf_eval_dual(&sp.bsdf, sp.ns, wi, D3::c(c.dir));
        throughput = throughput * (f * D::c(1.0 / (c.pdf * c.q)));
        origin = p;
        dir = c.dir;
    }
    (radiance.d, radiance.v)
}
