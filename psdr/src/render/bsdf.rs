//! The BSDF: Lambertian diffuse + GGX microfacet specular layer, evaluated in the local shading frame
//! (z = shading normal). GLSL twin: shaders/bsdf.glsl.
//!
//!   f(wi, wo) = albedo/pi * (1 - F(cos_i)) * (1 - F(cos_o))          diffuse, energy taken by the coat
//!             + D(h) G1(wi) G1(wo) F(wi.h) / (4 cos_i cos_o)          GGX specular (Smith, separable)
//!
//! F is the exact dielectric Fresnel term with F0 = 0.08 * specular (IOR from F0), alpha = roughness^2.
//! Symmetric in (wi, wo) (reciprocal) and energy conserving (tests/bsdf.rs checks both numerically).
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
    let fs = fresnel_dielectric(cos_i, eta);
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
