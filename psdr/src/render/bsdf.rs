//! The BSDF: Lambertian diffuse + GGX microfacet specular layer, evaluated in the local shading frame
//! (z = shading normal). GLSL twin: shaders/render/bsdf.glsl.
//!
//!   f(wi, wo) = albedo/pi * (1 - F(cos_i)) * (1 - F(cos_o))          diffuse, energy taken by the coat
//!             + D(h) G1(wi) G1(wo) F(wi.h) / (4 cos_i cos_o)          GGX specular (Smith, separable)
//!
//! F is the exact dielectric Fresnel term with F0 = 0.08 * specular (IOR from F0), alpha = roughness^2.
//! Symmetric in (wi, wo) (reciprocal) and energy conserving (tests/tests/bsdf.rs checks both numerically).
//! All functions return values multiplied by cos(theta_o), as in Mitsuba 3.

use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

/// Smallest GGX alpha: below this the lobe is a near-delta that f32 cannot integrate.
pub const MIN_ALPHA: f32 = 1e-3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfParams {
    pub albedo: Vec3,
    pub roughness: f32,
    pub specular: f32,
}

/// Index of refraction whose normal-incidence reflectance is 0.08 * specular (1 when specular = 0).
#[inline(always)]
pub fn specular_to_eta(specular: f32) -> f32 {
    let s = (0.08 * specular.clamp(0.0, 1.0)).sqrt();
    (1.0 + s) / (1.0 - s)
}

/// Unpolarized Fresnel reflectance of a dielectric interface (outside -> inside, eta = n_in / n_out).
#[inline(always)]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

#[inline(always)]
pub fn ggx_alpha(roughness: f32) -> f32 {
    (roughness * roughness).max(MIN_ALPHA)
}

/// GGX normal distribution D(h) for h in the local frame.
#[inline(always)]
pub fn ggx_d(h: Vec3, alpha: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let c2 = h.z * h.z;
    let d = (h.x * h.x + h.y * h.y) + c2 * a2;
    a2 / (PI * d * d)
}

/// Smith masking G1 for GGX.
#[inline(always)]
pub fn ggx_g1(w: Vec3, alpha: f32) -> f32 {
    let c2 = w.z * w.z;
    if c2 <= 0.0 {
        return 0.0;
    }
    let tan2 = (1.0 - c2).max(0.0) / c2;
    2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// Probability of choosing the specular lobe for a given incident direction (a pure function of wi).
#[inline(always)]
pub fn specular_probability(p: &BsdfParams, eta: f32, cos_i: f32) -> f32 {
    if eta <= 1.0 {
        return 0.0;
    }
    specular_probability_from_fresnel(p, fresnel_dielectric(cos_i, eta))
}

/// `specular_probability` for eta > 1 given fs = fresnel_dielectric(cos_i, eta).
#[inline(always)]
pub fn specular_probability_from_fresnel(p: &BsdfParams, fs: f32) -> f32 {
    let fd = (1.0 - fs) * (p.albedo.x + p.albedo.y + p.albedo.z) * (1.0 / 3.0);
    if fd <= 0.0 {
        return 1.0;
    }
    (fs / (fs + fd)).clamp(0.1, 0.9)
}

/// f(wi, wo) * cos_o. Zero when either direction is below the surface.
#[inline(always)]
pub fn bsdf_eval(p: &BsdfParams, wi: Vec3, wo: Vec3) -> Vec3 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return Vec3::ZERO;
    }
    let eta = specular_to_eta(p.specular);
    let f_i = fresnel_dielectric(wi.z, eta);
    let f_o = fresnel_dielectric(wo.z, eta);
    let diffuse = p.albedo * (FRAC_1_PI * (1.0 - f_i) * (1.0 - f_o) * wo.z);
    if eta <= 1.0 {
        return diffuse;
    }
    let alpha = ggx_alpha(p.roughness);
    let h = (wi + wo).normalize();
    let f_h = fresnel_dielectric(wi.dot(h), eta);
    let spec = ggx_d(h, alpha) * ggx_g1(wi, alpha) * ggx_g1(wo, alpha) * f_h / (4.0 * wi.z);
    diffuse + Vec3::splat(spec)
}

/// Solid-angle density of `bsdf_sample` producing wo.
#[inline(always)]
pub fn bsdf_pdf(p: &BsdfParams, wi: Vec3, wo: Vec3) -> f32 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    let eta = specular_to_eta(p.specular);
    let ps = specular_probability(p, eta, wi.z);
    let pdf_diffuse = wo.z * FRAC_1_PI;
    if ps <= 0.0 {
        return pdf_diffuse;
    }
    let alpha = ggx_alpha(p.roughness);
    let h = (wi + wo).normalize();
    // Visible-normal density D_wi(h) = G1(wi) max(0, wi.h) D(h) / cos_i, Jacobian 1 / (4 wi.h).
    let pdf_spec = ggx_g1(wi, alpha) * ggx_d(h, alpha) / (4.0 * wi.z);
    ps * pdf_spec + (1.0 - ps) * pdf_diffuse
}

/// Heitz 2018 visible-normal sampling of GGX for an isotropic alpha.
#[inline(always)]
pub fn sample_ggx_vndf(wi: Vec3, alpha: f32, u1: f32, u2: f32) -> Vec3 {
    let vh = Vec3::new(alpha * wi.x, alpha * wi.y, wi.z).normalize();
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) * (1.0 / lensq.sqrt()) } else { Vec3::X };
    let t2 = vh.cross(t1);
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * (r * phi.sin());
    let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize()
}

/// Cosine-weighted hemisphere direction (concentric-free polar mapping, identical in GLSL).
#[inline(always)]
pub fn sample_cosine_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt())
}

pub struct BsdfSample {
    pub wo: Vec3,
    /// f * cos / pdf.
    pub weight: Vec3,
    pub pdf: f32,
}

/// Samples wo for wi; `u_lobe` picks the lobe, (u1, u2) the direction. None when no direction is produced.
#[inline(always)]
pub fn bsdf_sample(p: &BsdfParams, wi: Vec3, u_lobe: f32, u1: f32, u2: f32) -> Option<BsdfSample> {
    if wi.z <= 0.0 {
        return None;
    }
    let eta = specular_to_eta(p.specular);
    let ps = specular_probability(p, eta, wi.z);
    let wo = if u_lobe < ps {
        let h = sample_ggx_vndf(wi, ggx_alpha(p.roughness), u1, u2);
        2.0 * wi.dot(h) * h - wi
    } else {
        sample_cosine_hemisphere(u1, u2)
    };
    let pdf = bsdf_pdf(p, wi, wo);
    if wo.z <= 0.0 || pdf <= 0.0 || !pdf.is_finite() {
        return None;
    }
    let f = bsdf_eval(p, wi, wo);
    Some(BsdfSample { wo, weight: f / pdf, pdf })
}

/// The BSDF at one shading point for one incident direction wi: the terms that depend on wi only, computed once
/// per path vertex and shared by next-event estimation (`bsdf_eval_pdf` toward the light) and BSDF sampling
/// (`bsdf_sample_at`). Every value equals what `bsdf_eval`, `bsdf_pdf` and `bsdf_sample` compute: the same
/// operations in the same order, without computing the IOR, Fresnel(wi), G1(wi), the half vector and D(h) up
/// to five times per vertex (the test below checks the bits).
#[derive(Clone, Copy, Debug)]
pub struct BsdfAt {
    pub p: BsdfParams,
    pub wi: Vec3,
    pub eta: f32,
    pub alpha: f32,
    /// fresnel_dielectric(wi.z, eta).
    pub f_i: f32,
    /// specular_probability(p, eta, wi.z).
    pub ps: f32,
    /// ggx_g1(wi, alpha) (0 when eta <= 1: the specular lobe is absent and never evaluated).
    pub g1_i: f32,
}

#[inline(always)]
pub fn bsdf_at(p: &BsdfParams, wi: Vec3) -> BsdfAt {
    let eta = specular_to_eta(p.specular);
    let alpha = ggx_alpha(p.roughness);
    let f_i = fresnel_dielectric(wi.z, eta);
    let (ps, g1_i) =
        if eta <= 1.0 { (0.0, 0.0) } else { (specular_probability_from_fresnel(p, f_i), ggx_g1(wi, alpha)) };
    BsdfAt { p: *p, wi, eta, alpha, f_i, ps, g1_i }
}

/// (bsdf_eval(p, wi, wo), bsdf_pdf(p, wi, wo)) for the wi of `b`.
#[inline(always)]
pub fn bsdf_eval_pdf(b: &BsdfAt, wo: Vec3) -> (Vec3, f32) {
    let wi = b.wi;
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return (Vec3::ZERO, 0.0);
    }
    let f_o = fresnel_dielectric(wo.z, b.eta);
    let diffuse = b.p.albedo * (FRAC_1_PI * (1.0 - b.f_i) * (1.0 - f_o) * wo.z);
    let pdf_diffuse = wo.z * FRAC_1_PI;
    // eta <= 1 exactly when ps == 0 (specular_probability is at least 0.1 otherwise).
    if b.eta <= 1.0 {
        return (diffuse, pdf_diffuse);
    }
    let h = (wi + wo).normalize();
    let d = ggx_d(h, b.alpha);
    let f_h = fresnel_dielectric(wi.dot(h), b.eta);
    let spec = d * b.g1_i * ggx_g1(wo, b.alpha) * f_h / (4.0 * wi.z);
    let pdf_spec = b.g1_i * d / (4.0 * wi.z);
    (diffuse + Vec3::splat(spec), b.ps * pdf_spec + (1.0 - b.ps) * pdf_diffuse)
}

/// bsdf_sample(p, wi, u_lobe, u1, u2) for the wi of `b`.
#[inline(always)]
pub fn bsdf_sample_at(b: &BsdfAt, u_lobe: f32, u1: f32, u2: f32) -> Option<BsdfSample> {
    let wi = b.wi;
    if wi.z <= 0.0 {
        return None;
    }
    let wo = if u_lobe < b.ps {
        let h = sample_ggx_vndf(wi, b.alpha, u1, u2);
        2.0 * wi.dot(h) * h - wi
    } else {
        sample_cosine_hemisphere(u1, u2)
    };
    let (f, pdf) = bsdf_eval_pdf(b, wo);
    if wo.z <= 0.0 || pdf <= 0.0 || !pdf.is_finite() {
        return None;
    }
    Some(BsdfSample { wo, weight: f / pdf, pdf })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sampler::sample_1d;

    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    /// The shared-term functions give the same bits as bsdf_eval, bsdf_pdf and bsdf_sample, over random
    /// materials (including specular 0, roughness 0 and black albedo) and directions (including below the surface).
    #[test]
    fn shared_terms_give_the_same_bits_as_the_separate_functions() {
        let u = |i: u32, d: u32| sample_1d(11, i, 0, d);
        let dir = |i: u32, d: u32| {
            let v = Vec3::new(u(i, d) * 2.0 - 1.0, u(i, d + 1) * 2.0 - 1.0, u(i, d + 2) * 2.0 - 0.3);
            v.normalize()
        };
        for i in 0..200_000 {
            let pick = |x: f32, d: u32| if u(i, d) < 0.15 { x } else { u(i, d + 1) };
            let p = BsdfParams {
                albedo: Vec3::new(pick(0.0, 0), u(i, 2), u(i, 3)),
                roughness: pick(0.0, 4),
                specular: pick(0.0, 6),
            };
            let (wi, wo) = (dir(i, 8), dir(i, 11));
            let b = bsdf_at(&p, wi);
            let (f, pdf) = bsdf_eval_pdf(&b, wo);
            assert_eq!(bits(f), bits(bsdf_eval(&p, wi, wo)), "{p:?} {wi} {wo}");
            assert_eq!(pdf.to_bits(), bsdf_pdf(&p, wi, wo).to_bits(), "{p:?} {wi} {wo}");
            let (a, b1, b2) = (u(i, 14), u(i, 15), u(i, 16));
            match (bsdf_sample_at(&b, a, b1, b2), bsdf_sample(&p, wi, a, b1, b2)) {
                (None, None) => {}
                (Some(x), Some(y)) => {
                    assert_eq!(bits(x.wo), bits(y.wo));
                    assert_eq!(bits(x.weight), bits(y.weight));
                    assert_eq!(x.pdf.to_bits(), y.pdf.to_bits());
                }
                (x, y) => panic!("{p:?} {wi}: {:?} vs {:?}", x.map(|s| s.wo), y.map(|s| s.wo)),
            }
        }
    }
}
