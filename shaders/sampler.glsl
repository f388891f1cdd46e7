// The counter-based sampler. Rust twin: psdr/src/render/sampler.rs (pcg4d, Jarzynski & Olano 2020).
#ifndef PSDR_SAMPLER_GLSL
#define PSDR_SAMPLER_GLSL

uvec4 pcg4d(uvec4 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    v ^= v >> 16u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    return v;
}

float sample_1d(uint seed, uint pixel, uint sample_, uint dim) {
    uvec4 h = pcg4d(uvec4(pixel, sample_, dim, seed));
    return float(h.x >> 8u) * (1.0 / 16777216.0);
}

const uint DIM_PIXEL_X = 0u;
const uint DIM_PIXEL_Y = 1u;
const uint DIM_BOUNCE_BASE = 2u;
const uint DIMS_PER_BOUNCE = 8u;
const uint DIM_LIGHT_SELECT = 0u;
const uint DIM_LIGHT_U = 1u;
const uint DIM_LIGHT_V = 2u;
const uint DIM_LOBE = 3u;
const uint DIM_BSDF_U = 4u;
const uint DIM_BSDF_V = 5u;
const uint DIM_ROULETTE = 6u;

struct Sampler {
    uint seed;
    uint pixel;
    uint sample_;
};

float sampler_get(Sampler s, uint dim) {
    return sample_1d(s.seed, s.pixel, s.sample_, dim);
}

float sampler_bounce(Sampler s, uint bounce, uint which) {
    return sampler_get(s, DIM_BOUNCE_BASE + bounce * DIMS_PER_BOUNCE + which);
}

#endif
