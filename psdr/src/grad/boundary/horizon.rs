//! The horizon boundary: at a path vertex x whose surface turns, the geometric tangent plane sweeps through the
//! fixed (ray-form) directions around x. Rays leaving below that plane start inside the surface, so the
//! scattering integrand h = f · cos · L_in jumps there unless the shading normal equals the geometric one (with
//! normal maps or interpolated normals it does not: f · cos is measured from the shading normal). With n_g the
//! geometric normal and ω on the horizon circle {ω : n_g · ω = 0}, the circle moves along n_g with speed
//! −(dn_g/dθ · ω), and
//!     d/dθ ∫ h dω  ∋  ∫_circle [h(ω⁻) − h(ω⁺)] (−dn_g/dθ · ω) dφ,
//! where ω± lie just above and below the plane. φ is sampled uniformly, both sides share their random numbers.

use crate::grad::path::velocity::{PoseComponent, PoseLayout};
use crate::render::bsdf::bsdf_eval;
use crate::render::layout::{FrameParams, NONE, SHADING_HAS_NORMALS};
use crate::render::path_trace::trace_from;
use crate::render::sampler::Sampler;
use crate::render::shading::{offset_origin, orthogonal, SurfacePoint};
use crate::render::SceneData;
use glam::Vec3;

/// Angular offset of the two side directions from the horizon (radians).
const SIDE_EPS: f32 = 1e-4;

/// True when the shading normal at points of triangle `ti` can differ from its geometric normal (only then does
/// the integrand jump at the horizon).
pub fn has_horizon_jump(d: &SceneData, ti: u32) -> bool {
    let tri = &d.triangles[ti as usize];
    d.materials[tri.material as usize].normal_tex != NONE || d.shading[ti as usize].flags & SHADING_HAS_NORMALS != 0
}

/// dn/dθ of the unit normal of triangle `ti` (as flipped in `sp_ng`) for pose entry `e`, from its corners'
/// velocities (exact for every component: all move the corners and the triangle stays flat).
pub fn face_normal_velocity(d: &SceneData, pose: &PoseLayout, ti: u32, e: usize, sp_ng: Vec3) -> Vec3 {
    let tri = &d.triangles[ti as usize];
    let (o, c, _) = pose.entries[e];
    if tri.object != o || matches!(c, PoseComponent::Translation(_)) {
        return Vec3::ZERO;
    }
    let ids = pose.corners(d, ti);
    let (v0, e1, e2) = (Vec3::from(tri.v0), Vec3::from(tri.e1), Vec3::from(tri.e2));
    let u = |k: usize, x: Vec3| pose.velocity(o, c, x, &[(ids[k], 1.0)]);
    let u0 = u(0, v0);
    let (de1, de2) = (u(1, v0 + e1) - u0, u(2, v0 + e2) - u0);
    let cr = e1.cross(e2);
    let len = cr.length();
    if len.is_nan() || len <= 0.0 {
        return Vec3::ZERO;
    }
    let n = cr / len;
    let dc = de1.cross(e2) + e1.cross(de2);
    let dn = (dc - n * n.dot(dc)) / len;
    if n.dot(sp_ng) < 0.0 {
        -dn
    } else {
        dn
    }
}

/// One path vertex's horizon samples.
pub struct HorizonVertex<'a> {
    pub sp: &'a SurfacePoint,
    /// Incoming direction in the shading frame.
    pub wi: Vec3,
    /// dn_g/dθ per entry, with the entry's gradient offset; only turning entries.
    pub turning: &'a [(usize, Vec3)],
    /// The pixel's adjoint times the path throughput up to this vertex.
    pub adjoint: Vec3,
}

/// Adds `count` horizon samples of one vertex to `grad`. `sampler` is this vertex's own stream; `sub_fp` the
/// frame parameters of the rest of the path.
pub fn horizon_boundary(
    d: &SceneData,
    sub_fp: &FrameParams,
    v: &HorizonVertex,
    sampler: impl Fn(u32) -> Sampler,
    count: u32,
    grad: &mut [f64],
) {
    let sp = v.sp;
    let t1 = orthogonal(sp.ng);
    let t2 = sp.ng.cross(t1);
    for j in 0..count {
        let s = sampler(j);
        let phi = std::f32::consts::TAU * s.get(0);
        let (sin, cos) = phi.sin_cos();
        let om = t1 * cos + t2 * sin;
        let side = |sign: f32| {
            let w = (om + sp.ng * (sign * SIDE_EPS)).normalize();
            let f = bsdf_eval(&sp.bsdf, v.wi, sp.to_local(w));
            if f == Vec3::ZERO {
                return Vec3::ZERO;
            }
            f * trace_from(d, sub_fp, &s, offset_origin(sp.p, sp.ng, w), w, &mut ()).radiance
        };
        let jump = side(-1.0) - side(1.0);
        if jump == Vec3::ZERO {
            continue;
        }
        let scale = v.adjoint.dot(jump) * std::f32::consts::TAU / count as f32;
        for &(at, dng) in v.turning {
            grad[at] += (scale * -dng.dot(om)) as f64;
        }
    }
}
