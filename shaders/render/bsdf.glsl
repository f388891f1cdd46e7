// The BSDF: Lambertian diffuse + GGX microfacet specular layer in the local shading frame (z = normal).
// Rust twin: psdr/src/render/bsdf.rs (same functions, same order of operations).
#ifndef PSDR_BSDF_GLSL
#define PSDR_BSDF_GLSL
#include "vec_math.glsl"

const float PI = 3.14159265358979;
const float FRAC_1_PI = 0.318309886183791;
const float MIN_ALPHA = 1e-3;

struct BsdfParams {
    vec3 albedo;
    float roughness;
    float specular;
};

float specular_to_eta(float specular) {
    float s = sqrt(0.08 * clamp(specular, 0.0, 1.0));
    return (1.0 + s) / (1.0 - s);
}

float fresnel_dielectric(float cos_i_, float eta) {
    float cos_i = clamp(cos_i_, 0.0, 1.0);
    float sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0) {
        return 1.0;
    }
    float cos_t = sqrt(1.0 - sin2_t);
    float rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    float rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

float ggx_alpha(float roughness) {
    return max(roughness * roughness, MIN_ALPHA);
}

float ggx_d(vec3 h, float alpha) {
    if (h.z <= 0.0) {
        return 0.0;
    }
    float a2 = alpha * alpha;
    float c2 = h.z * h.z;
    float d = (h.x * h.x + h.y * h.y) + c2 * a2;
    return a2 / (PI * d * d);
}

float ggx_g1(vec3 w, float alpha) {
    float c2 = w.z * w.z;
    if (c2 <= 0.0) {
        return 0.0;
    }
    float tan2 = max(1.0 - c2, 0.0) / c2;
    return 2.0 / (1.0 + sqrt(1.0 + alpha * alpha * tan2));
}

// specular_probability for eta > 1 given fs = fresnel_dielectric(cos_i, eta).
float specular_probability_from_fresnel(BsdfParams p, float fs) {
    float fd = (1.0 - fs) * (p.albedo.x + p.albedo.y + p.albedo.z) * (1.0 / 3.0);
    if (fd <= 0.0) {
        return 1.0;
    }
    return clamp(fs / (fs + fd), 0.1, 0.9);
}

float specular_probability(BsdfParams p, float eta, float cos_i) {
    if (eta <= 1.0) {
        return 0.0;
    }
    return specular_probability_from_fresnel(p, fresnel_dielectric(cos_i, eta));
}

vec3 bsdf_eval(BsdfParams p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) {
        return vec3(0.0);
    }
    float eta = specular_to_eta(p.specular);
    float f_i = fresnel_dielectric(wi.z, eta);
    float f_o = fresnel_dielectric(wo.z, eta);
    vec3 diffuse = p.albedo * (FRAC_1_PI * (1.0 - f_i) * (1.0 - f_o) * wo.z);
    if (eta <= 1.0) {
        return diffuse;
    }
    float alpha = ggx_alpha(p.roughness);
    vec3 h = normalize3(wi + wo);
    float f_h = fresnel_dielectric(dot3(wi, h), eta);
    float spec = ggx_d(h, alpha) * ggx_g1(wi, alpha) * ggx_g1(wo, alpha) * f_h / (4.0 * wi.z);
    return diffuse + vec3(spec);
}

float bsdf_pdf(BsdfParams p, vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) {
        return 0.0;
    }
    float eta = specular_to_eta(p.specular);
    float ps = specular_probability(p, eta, wi.z);
    float pdf_diffuse = wo.z * FRAC_1_PI;
    if (ps <= 0.0) {
        return pdf_diffuse;
    }
    float alpha = ggx_alpha(p.roughness);
    vec3 h = normalize3(wi + wo);
    float pdf_spec = ggx_g1(wi, alpha) * ggx_d(h, alpha) / (4.0 * wi.z);
    return ps * pdf_spec + (1.0 - ps) * pdf_diffuse;
}

vec3 sample_ggx_vndf(vec3 wi, float alpha, float u1, float u2) {
    vec3 vh = normalize3(vec3(alpha * wi.x, alpha * wi.y, wi.z));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = lensq > 0.0 ? vec3(-vh.y, vh.x, 0.0) * (1.0 / sqrt(lensq)) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross3(vh, t1);
    float r = sqrt(u1);
    float phi = 2.0 * PI * u2;
    float p1 = r * cos(phi);
    float s = 0.5 * (1.0 + vh.z);
    float p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * (r * sin(phi));
    vec3 nh = t1 * p1 + t2 * p2 + vh * sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0));
    return normalize3(vec3(alpha * nh.x, alpha * nh.y, max(nh.z, 0.0)));
}

vec3 sample_cosine_hemisphere(float u1, float u2) {
    float r = sqrt(u1);
    float phi = 2.0 * PI * u2;
    return vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u1, 0.0)));
}

struct BsdfSample {
    vec3 wo;
    vec3 weight;
    float pdf;
};

// Returns false when no direction is produced.
bool bsdf_sample(BsdfParams p, vec3 wi, float u_lobe, float u1, float u2, out BsdfSample bs) {
    if (wi.z <= 0.0) {
        return false;
    }
    float eta = specular_to_eta(p.specular);
    float ps = specular_probability(p, eta, wi.z);
    vec3 wo;
    if (u_lobe < ps) {
        vec3 h = sample_ggx_vndf(wi, ggx_alpha(p.roughness), u1, u2);
        wo = 2.0 * dot3(wi, h) * h - wi;
    } else {
        wo = sample_cosine_hemisphere(u1, u2);
    }
    float pdf = bsdf_pdf(p, wi, wo);
    if (wo.z <= 0.0 || pdf <= 0.0 || isinf(pdf) || isnan(pdf)) {
        return false;
    }
    vec3 f = bsdf_eval(p, wi, wo);
    bs = BsdfSample(wo, f / pdf, pdf);
    return true;
}

// The BSDF at one shading point for one incident direction wi: the terms that depend on wi only, computed once
// per path vertex and shared by next-event estimation (bsdf_eval_pdf toward the light) and BSDF sampling
// (bsdf_sample_at). Every value equals what bsdf_eval, bsdf_pdf and bsdf_sample compute (same operations, same
// order).
struct BsdfAt {
    BsdfParams p;
    vec3 wi;
    float eta;
    float alpha;
    float f_i;
    float ps;
    float g1_i;
};

BsdfAt bsdf_at(BsdfParams p, vec3 wi) {
    float eta = specular_to_eta(p.specular);
    float alpha = ggx_alpha(p.roughness);
    float f_i = fresnel_dielectric(wi.z, eta);
    float ps = 0.0;
    float g1_i = 0.0;
    if (!(eta <= 1.0)) {
        ps = specular_probability_from_fresnel(p, f_i);
        g1_i = ggx_g1(wi, alpha);
    }
    return BsdfAt(p, wi, eta, alpha, f_i, ps, g1_i);
}

// (bsdf_eval(p, wi, wo), bsdf_pdf(p, wi, wo)) for the wi of b; the pdf goes to `pdf`.
vec3 bsdf_eval_pdf(BsdfAt b, vec3 wo, out float pdf) {
    vec3 wi = b.wi;
    if (wi.z <= 0.0 || wo.z <= 0.0) {
        pdf = 0.0;
        return vec3(0.0);
    }
    float f_o = fresnel_dielectric(wo.z, b.eta);
    vec3 diffuse = b.p.albedo * (FRAC_1_PI * (1.0 - b.f_i) * (1.0 - f_o) * wo.z);
    float pdf_diffuse = wo.z * FRAC_1_PI;
    // eta <= 1 exactly when ps == 0 (specular_probability is at least 0.1 otherwise).
    if (b.eta <= 1.0) {
        pdf = pdf_diffuse;
        return diffuse;
    }
    vec3 h = normalize3(wi + wo);
    float d = ggx_d(h, b.alpha);
    float f_h = fresnel_dielectric(dot3(wi, h), b.eta);
    float spec = d * b.g1_i * ggx_g1(wo, b.alpha) * f_h / (4.0 * wi.z);
    float pdf_spec = b.g1_i * d / (4.0 * wi.z);
    pdf = b.ps * pdf_spec + (1.0 - b.ps) * pdf_diffuse;
    return diffuse + vec3(spec);
}

// bsdf_sample(p, wi, u_lobe, u1, u2, bs) for the wi of b.
bool bsdf_sample_at(BsdfAt b, float u_lobe, float u1, float u2, out BsdfSample bs) {
    vec3 wi = b.wi;
    if (wi.z <= 0.0) {
        return false;
    }
    vec3 wo;
    if (u_lobe < b.ps) {
        vec3 h = sample_ggx_vndf(wi, b.alpha, u1, u2);
        wo = 2.0 * dot3(wi, h) * h - wi;
    } else {
        wo = sample_cosine_hemisphere(u1, u2);
    }
    float pdf;
    vec3 f = bsdf_eval_pdf(b, wo, pdf);
    if (wo.z <= 0.0 || pdf <= 0.0 || isinf(pdf) || isnan(pdf)) {
        return false;
    }
    bs = BsdfSample(wo, f / pdf, pdf);
    return true;
}

#endif
