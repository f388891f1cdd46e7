// Derivatives of bsdf_eval (f · cos_o) with respect to the material constants: albedo and roughness in closed
// form, specular by forward mode through the dual twin of bsdf_eval (bsdf_dual.glsl).
// Rust twin: psdr/src/grad/ad/bsdf_grad.rs (BsdfGrad::scaled, ggx_d_dalpha, ggx_g1_dalpha, albedo_factor,
// bsdf_albedo_grad, bsdf_eval_grad).
#ifndef PSDR_BSDF_GRAD_GLSL
#define PSDR_BSDF_GRAD_GLSL
#include "render/bsdf.glsl"
#include "grad/ad/bsdf_dual.glsl"

// ∂(f · cos_o)/∂θ for one (wi, wo): albedo (the Jacobian is diagonal with this value), roughness (the same for
// every channel), specular (per channel).
struct BsdfGrad {
    float albedo;
    float roughness;
    vec3 specular;
};

BsdfGrad bsdf_grad_scaled(BsdfGrad g, float k) {
    return BsdfGrad(g.albedo * k, g.roughness * k, g.specular * k);
}

// dD/dα of the GGX distribution.
float ggx_d_dalpha(vec3 h, float alpha) {
    if (h.z <= 0.0) {
        return 0.0;
    }
    float a2 = alpha * alpha;
    float c2 = h.z * h.z;
    float d = (h.x * h.x + h.y * h.y) + c2 * a2;
    return (d - 2.0 * a2 * c2) / (PI * d * d * d) * 2.0 * alpha;
}

// dG1/dα of Smith's GGX masking.
float ggx_g1_dalpha(vec3 w, float alpha) {
    float c2 = w.z * w.z;
    if (c2 <= 0.0) {
        return 0.0;
    }
    float tan2 = max(1.0 - c2, 0.0) / c2;
    float s = sqrt(1.0 + alpha * alpha * tan2);
    return -2.0 / ((1.0 + s) * (1.0 + s)) * (alpha * tan2 / s);
}

// ∂(f · cos_o)/∂albedo_c: the diffuse lobe without its albedo.
float albedo_factor(float eta, vec3 wi, vec3 wo) {
    return FRAC_1_PI * (1.0 - fresnel_dielectric(wi.z, eta)) * (1.0 - fresnel_dielectric(wo.z, eta)) * wo.z;
}

// The albedo part of bsdf_eval_grad alone (the others zero), without the dual evaluation.
BsdfGrad bsdf_albedo_grad(BsdfParams p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) {
        return BsdfGrad(0.0, 0.0, vec3(0.0));
    }
    return BsdfGrad(albedo_factor(specular_to_eta(p.specular), wi, wo), 0.0, vec3(0.0));
}

BsdfGrad bsdf_eval_grad(BsdfParams p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) {
        return BsdfGrad(0.0, 0.0, vec3(0.0));
    }
    // The specular derivative runs through Fresnel and the IOR: forward mode on the dual twin of bsdf_eval.
    BsdfParamsD pd = BsdfParamsD(d3_c(p.albedo), d_c(p.roughness),
                                 D(p.specular, (p.specular >= 0.0 && p.specular < 1.0) ? 1.0 : 0.0));
    vec3 specular = bsdf_eval_dual(pd, d3_c(vec3(0.0, 0.0, 1.0)), d3_c(wi), d3_c(wo)).d;
    float eta = specular_to_eta(p.specular);
    float albedo = albedo_factor(eta, wi, wo);
    if (eta <= 1.0) {
        return BsdfGrad(albedo, 0.0, specular);
    }
    float r2 = p.roughness * p.roughness;
    // alpha = max(r², MIN_ALPHA): flat below the clamp.
    if (r2 <= MIN_ALPHA) {
        return BsdfGrad(albedo, 0.0, specular);
    }
    float alpha = r2;
    vec3 h = normalize3(wi + wo);
    float f_h = fresnel_dielectric(dot3(wi, h), eta);
    float d = ggx_d(h, alpha);
    float gi = ggx_g1(wi, alpha);
    float go = ggx_g1(wo, alpha);
    float d_alpha = ggx_d_dalpha(h, alpha) * gi * go + d * ggx_g1_dalpha(wi, alpha) * go + d * gi * ggx_g1_dalpha(wo, alpha);
    return BsdfGrad(albedo, d_alpha * f_h / (4.0 * wi.z) * 2.0 * p.roughness, specular);
}

#endif
