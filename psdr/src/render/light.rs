//! Emitters: choosing a light, sampling a point on it, and the emitted radiance / density of a hit.
//! GLSL twin: shaders/render/light.glsl.

use super::layout::*;
use super::scene_data::SceneData;
use glam::Vec3;

/// Index of the light whose cdf interval contains u (binary search over the inclusive prefix sums).
#[inline(always)]
pub fn select_light(lights: &[LightGpu], count: u32, u: f32) -> u32 {
    let (mut lo, mut hi) = (0u32, count - 1);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if u < lights[mid as usize].cdf {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo
}

pub struct LightSample {
    pub p: Vec3,
    /// Unit normal of the light triangle (its winding side).
    pub n: Vec3,
    /// The emitter's radiance before its shape (`sky_shape` with `sky_gradient` toward the point it lights).
    pub radiance: Vec3,
    pub sky_gradient: Vec3,
    pub two_sided: bool,
    /// Area density of the sampled point (selection pmf / area).
    pub pdf_area: f32,
    /// Index of the emitter (what the adjoint credits).
    pub emitter: u32,
}

/// Picks a light with `u_select` and a uniform point on its triangle with (u1, u2).
#[inline(always)]
pub fn sample_light(d: &SceneData, count: u32, u_select: f32, u1: f32, u2: f32) -> LightSample {
    sample_light_in(d, &d.lights, count, u_select, u1, u2)
}

/// `sample_light` from another selection distribution over `d`'s triangles and emitters (`unit_paths`: one
/// emitter's own, as its unit render has it).
#[inline(always)]
pub fn sample_light_in(d: &SceneData, lights: &[LightGpu], count: u32, u_select: f32, u1: f32, u2: f32) -> LightSample {
    let li = select_light(lights, count, u_select);
    let light = &lights[li as usize];
    let tri = &d.triangles[light.triangle as usize];
    let e1 = Vec3::from(tri.e1);
    let e2 = Vec3::from(tri.e2);
    let su = u1.sqrt();
    let (b1, b2) = (1.0 - su, u2 * su);
    let c = e1.cross(e2);
    let area = 0.5 * c.length();
    let em = &d.emitters[light.emitter as usize];
    LightSample {
        p: Vec3::from(tri.v0) + e1 * b1 + e2 * b2,
        n: c.normalize(),
        radiance: Vec3::from(em.radiance),
        sky_gradient: Vec3::from(em.sky_gradient),
        two_sided: em.two_sided != 0,
        pdf_area: light.pmf / area,
        emitter: light.emitter,
    }
}

/// What an emitter's radiance is multiplied by for a ray travelling in direction `dir` (unit) that reaches
/// it: 1 + g dir.y per channel (`scene::Emitter::sky_gradient`; >= 0 for |g| <= 1, which scenes are checked
/// for).
#[inline(always)]
pub fn sky_shape(g: Vec3, dir: Vec3) -> Vec3 {
    Vec3::ONE + g * dir.y
}

/// `sky_shape` of emitter `e` (an index into the scene data's emitters).
#[inline(always)]
pub fn emitter_shape(d: &SceneData, e: u32, dir: Vec3) -> Vec3 {
    sky_shape(Vec3::from(d.emitters[e as usize].sky_gradient), dir)
}

/// Radiance leaving triangle `ti` toward a viewer whose ray travels in direction `dir`; `front` says the
/// viewer is on the winding side.
#[inline(always)]
pub fn emitted_radiance(d: &SceneData, ti: u32, front: bool, dir: Vec3) -> Vec3 {
    let e = d.shading[ti as usize].emitter;
    if e == NONE {
        return Vec3::ZERO;
    }
    let em = &d.emitters[e as usize];
    if em.two_sided != 0 || front {
        Vec3::from(em.radiance) * sky_shape(Vec3::from(em.sky_gradient), dir)
    } else {
        Vec3::ZERO
    }
}

/// Area density with which `sample_light` would have produced a point on triangle `ti` (0 if it never does).
#[inline(always)]
pub fn light_pdf_area(d: &SceneData, ti: u32) -> f32 {
    let tri = &d.triangles[ti as usize];
    light_pdf_area_in(&d.lights, tri.light, tri)
}

/// `light_pdf_area` in another selection distribution, `entry` the triangle's place in it (or NONE).
#[inline(always)]
pub fn light_pdf_area_in(lights: &[LightGpu], entry: u32, tri: &TriangleGeom) -> f32 {
    if entry == NONE {
        return 0.0;
    }
    let area = 0.5 * Vec3::from(tri.e1).cross(Vec3::from(tri.e2)).length();
    lights[entry as usize].pmf / area
}

/// Power heuristic (beta = 2) weight of a strategy with density `a` against one with density `b`.
#[inline(always)]
pub fn mis_power(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && (a2 + b2).is_finite() {
        a2 / (a2 + b2)
    } else if a.is_infinite() {
        1.0
    } else {
        0.0
    }
}
