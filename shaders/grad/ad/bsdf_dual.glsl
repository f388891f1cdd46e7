// render/bsdf.glsl's bsdf_eval in dual numbers: the same terms in the same order, with world-space directions
// and the shading normal (overloads of the primal's functions on dual arguments).
// Rust twin: psdr/src/grad/ad/bsdf_dual.rs.
#ifndef PSDR_BSDF_DUAL_GLSL
#define PSDR_BSDF_DUAL_GLSL
#include "render/vec_math.glsl"
#include "render/bsdf.glsl"
#include "grad/ad/dual.glsl"

// Material parameters at a shading point, possibly varying with θ.
struct BsdfParamsD {
    D3 albedo;
    D roughness;
    D specular;
};

D specular_to_eta(D specular) {
    D s = d_sqrt(d_mul(d_clamp_c(specular, 0.0, 1.0), 0.08));
    return d_div(d_add(s, 1.0), d_sub(1.0, s));
}

D fresnel_dielectric(D cos_i_, D eta) {
    D cos_i = d_clamp_c(cos_i_, 0.0, 1.0);
    D sin2_t = d_div(d_sub(1.0, d_mul(cos_i, cos_i)), d_mul(eta, eta));
    if (sin2_t.v >= 1.0) {
        return d_c(1.0);
    }
    D cos_t = d_sqrt(d_sub(1.0, sin2_t));
    D rs = d_div(d_sub(cos_i, d_mul(eta, cos_t)), d_add(cos_i, d_mul(eta, cos_t)));
    D rp = d_div(d_sub(d_mul(eta, cos_i), cos_t), d_add(d_mul(eta, cos_i), cos_t));
    return d_mul(d_add(d_mul(rs, rs), d_mul(rp, rp)), 0.5);
}

D ggx_alpha(D roughness) {
    return d_max_c(d_mul(roughness, roughness), MIN_ALPHA);
}

// GGX D(h) from cos(h, n) and sin²(h, n).
D ggx_d(D cos_h, D sin2_h, D alpha) {
    if (cos_h.v <= 0.0) {
        return d_c(0.0);
    }
    D a2 = d_mul(alpha, alpha);
    D d = d_add(sin2_h, d_mul(d_mul(cos_h, cos_h), a2));
    return d_div(a2, d_mul(d_mul(d, d), PI));
}

// Smith G1 from cos(w, n).
D ggx_g1(D cos_w, D alpha) {
    D c2 = d_mul(cos_w, cos_w);
    if (c2.v <= 0.0) {
        return d_c(0.0);
    }
    D tan2 = d_div(d_max_c(d_sub(1.0, c2), 0.0), c2);
    return d_div(d_c(2.0), d_add(d_sqrt(d_add(d_mul(d_mul(alpha, alpha), tan2), 1.0)), 1.0));
}

// f(wi, wo) · cos_o for world-space unit directions and the unit shading normal n.
D3 bsdf_eval_dual(BsdfParamsD p, D3 n, D3 wi, D3 wo) {
    D cos_i = d3_dot(wi, n);
    D cos_o = d3_dot(wo, n);
    if (cos_i.v <= 0.0 || cos_o.v <= 0.0) {
        return D3(vec3(0.0), vec3(0.0));
    }
    D eta = specular_to_eta(p.specular);
    D f_i = fresnel_dielectric(cos_i, eta);
    D f_o = fresnel_dielectric(cos_o, eta);
    D3 diffuse = d3_mul(p.albedo, d_mul(d_mul(d_mul(d_sub(1.0, f_i), d_sub(1.0, f_o)), cos_o), FRAC_1_PI));
    if (eta.v <= 1.0) {
        return diffuse;
    }
    D alpha = ggx_alpha(p.roughness);
    D3 h = d3_normalize(d3_add(wi, wo));
    D f_h = fresnel_dielectric(d3_dot(wi, h), eta);
    D cos_h = d3_dot(h, n);
    D3 h_t = d3_sub(h, d3_mul(n, cos_h));
    D spec = d_div(d_mul(d_mul(d_mul(ggx_d(cos_h, d3_dot(h_t, h_t), alpha), ggx_g1(cos_i, alpha)), ggx_g1(cos_o, alpha)), f_h),
                   d_mul(cos_i, 4.0));
    return d3_add(diffuse, D3(vec3(spec.v), vec3(spec.d)));
}

#endif
