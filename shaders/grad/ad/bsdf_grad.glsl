// Derivatives of bsdf_eval (f · cos_o) with respect to the material constants, in closed form: the albedo part
// (the roughness and specular parts, which run through dual numbers, are not on the GPU yet).
// Rust twin: psdr/src/grad/ad/bsdf_grad.rs (albedo_factor, bsdf_albedo_grad).
#ifndef PSDR_BSDF_GRAD_GLSL
#define PSDR_BSDF_GRAD_GLSL
#include "render/bsdf.glsl"

// ∂(f · cos_o)/∂albedo_c: the diffuse lobe without its albedo.
float albedo_factor(float eta, vec3 wi, vec3 wo) {
    return FRAC_1_PI * (1.0 - fresnel_dielectric(wi.z, eta)) * (1.0 - fresnel_dielectric(wo.z, eta)) * wo.z;
}

// The albedo derivative of bsdf_eval at (wi, wo) (the Jacobian is diagonal with this value).
float bsdf_albedo_grad(BsdfParams p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) {
        return 0.0;
    }
    return albedo_factor(specular_to_eta(p.specular), wi, wo);
}

#endif
