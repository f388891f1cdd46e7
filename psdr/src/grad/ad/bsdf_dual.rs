//! `render::bsdf::bsdf_eval` in dual numbers: the same terms in the same order, written with world-space
//! directions and the shading normal, so geometric replays differentiate the BSDF through directions, normals
//! and texture lookups.

use crate::grad::ad::dual::{D, D3};
use crate::render::bsdf::MIN_ALPHA;
use std::f32::consts::{FRAC_1_PI, PI};

/// Material parameters at a shading point, possibly varying with θ (textures read at a sliding uv).
#[derive(Clone, Copy, Debug)]
pub struct BsdfParamsD {
    pub albedo: D3,
    pub roughness: D,
    pub specular: D,
}

fn specular_to_eta(specular: D) -> D {
    let s = (specular.clamp_c(0.0, 1.0) * 0.08).sqrt();
    (s + 1.0) / (1.0 - s)
}

fn fresnel_dielectric(cos_i: D, eta: D) -> D {
    let cos_i = cos_i.clamp_c(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t.v >= 1.0 {
        return D::c(1.0);
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (rs * rs + rp * rp) * 0.5
}

fn ggx_alpha(roughness: D) -> D {
    (roughness * roughness).max_c(MIN_ALPHA)
}

/// GGX D(h) from cos(h, n) and sin²(h, n) (the sine form, as render::bsdf::ggx_d, keeps f32 digits).
fn ggx_d(cos_h: D, sin2_h: D, alpha: D) -> D {
    if cos_h.v <= 0.0 {
        return D::c(0.0);
    }
    let a2 = alpha * alpha;
    let d = sin2_h + cos_h * cos_h * a2;
    a2 / (d * d * PI)
}

/// Smith G1 from cos(w, n).
fn ggx_g1(cos_w: D, alpha: D) -> D {
    let c2 = cos_w * cos_w;
    if c2.v <= 0.0 {
        return D::c(0.0);
    }
    let tan2 = (1.0 - c2).max_c(0.0) / c2;
    D::c(2.0) / ((alpha * alpha * tan2 + 1.0).sqrt() + 1.0)
}

/// f(wi, wo) · cos_o for world-space unit directions and the unit shading normal `n`. The BSDF is isotropic,
/// so it depends on the frame only through n: this equals `bsdf_eval` in any tangent frame.
pub fn bsdf_eval_dual(p: &BsdfParamsD, n: D3, wi: D3, wo: D3) -> D3 {
    let (cos_i, cos_o) = (wi.dot(n), wo.dot(n));
    if cos_i.v <= 0.0 || cos_o.v <= 0.0 {
        return D3::default();
    }
    let eta = specular_to_eta(p.specular);
    let f_i = fresnel_dielectric(cos_i, eta);
    let f_o = fresnel_dielectric(cos_o, eta);
    let diffuse = p.albedo * ((1.0 - f_i) * (1.0 - f_o) * cos_o * FRAC_1_PI);
    if eta.v <= 1.0 {
        return diffuse;
    }
    let alpha = ggx_alpha(p.roughness);
    let h = (wi + wo).normalize();
    let f_h = fresnel_dielectric(wi.dot(h), eta);
    let cos_h = h.dot(n);
    let h_t = h - n * cos_h;
    let spec = ggx_d(cos_h, h_t.dot(h_t), alpha) * ggx_g1(cos_i, alpha) * ggx_g1(cos_o, alpha) * f_h / (cos_i * 4.0);
    diffuse + D3 { v: glam::Vec3::splat(spec.v), d: glam::Vec3::splat(spec.d) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::bsdf::{bsdf_eval, BsdfParams};
    use glam::Vec3;

    /// Values equal `bsdf_eval` to rounding, derivatives along a direction change match central differences.
    #[test]
    fn dual_bsdf_matches_the_primal_and_finite_differences() {
        for k in 0..200u32 {
            let r = |m: u32| ((k * 7919 + m * 104729) % 997) as f32 / 997.0;
            let dir = |a: f32, b: f32| {
                let (z, phi) = (0.1 + 0.9 * a, std::f32::consts::TAU * b);
                let s = (1.0 - z * z).sqrt();
                Vec3::new(s * phi.cos(), s * phi.sin(), z)
            };
            let (wi, wo) = (dir(r(1), r(2)), dir(r(3), r(4)));
            let dwo = Vec3::new(r(5) - 0.5, r(6) - 0.5, 0.0);
            let p = BsdfParams { albedo: Vec3::new(0.6, 0.4, 0.2), roughness: 0.2 + 0.7 * r(7), specular: r(8) };
            let pd = BsdfParamsD { albedo: D3::c(p.albedo), roughness: D::c(p.roughness), specular: D::c(p.specular) };
            let f = |t: f32| bsdf_eval(&p, wi, (wo + dwo * t).normalize());
            let wo_d = D3 { v: wo, d: dwo }.normalize();
            let fd_dual = bsdf_eval_dual(&pd, D3::c(Vec3::Z), D3::c(wi), wo_d);
            let primal = f(0.0);
            assert!((fd_dual.v - primal).length() <= 1e-5 * (1.0 + primal.length()), "{k}: value");
            let h = 1e-3;
            let fd = (f(h) - f(-h)) / (2.0 * h);
            let scale = 1e-2 * (1.0 + fd.length() + primal.length());
            assert!((fd_dual.d - fd).length() <= scale, "{k}: dual {} vs FD {fd}", fd_dual.d);
        }
    }
}
