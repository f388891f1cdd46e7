// The counter-based sampler. Rust twin: psdr/src/render/sampler.rs (pcg4d, Jarzynski & Olano 2020; pairs of
// dimensions are shuffled, Owen-scrambled 2-D Sobol sequences over a pixel's samples, Burley 2020; bounces from
// STRATIFIED_BOUNCES on draw independent hashes).
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

uint lk_hash(uint x, uint seed) {
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16u) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

uint owen_scramble(uint x, uint seed) {
    return bitfieldReverse(lk_hash(bitfieldReverse(x), seed));
}

uint sobol1_reversed(uint i) {
    i ^= (i & 0xaaaaaaaau) >> 1u;
    i ^= (i & 0xccccccccu) >> 2u;
    i ^= (i & 0xf0f0f0f0u) >> 4u;
    i ^= (i & 0xff00ff00u) >> 8u;
    i ^= (i & 0xffff0000u) >> 16u;
    return i;
}

float sample_1d(uint seed, uint pixel, uint sample_, uint dim) {
    uvec4 h = pcg4d(uvec4(pixel, dim >> 1u, seed, 0u));
    uint index = owen_scramble(sample_, h.x);
    uint reversed = (dim & 1u) == 0u ? index : sobol1_reversed(index);
    uint bits = bitfieldReverse(lk_hash(reversed, (dim & 1u) == 0u ? h.y : h.z));
    return float(bits >> 8u) * (1.0 / 16777216.0);
}

vec2 sample_2d(uint seed, uint pixel, uint sample_, uint dim) {
    uvec4 h = pcg4d(uvec4(pixel, dim >> 1u, seed, 0u));
    uint index = owen_scramble(sample_, h.x);
    uint x = bitfieldReverse(lk_hash(index, h.y));
    uint y = bitfieldReverse(lk_hash(sobol1_reversed(index), h.z));
    return vec2(float(x >> 8u), float(y >> 8u)) * (1.0 / 16777216.0);
}

// Independent uniform draws for the pair (dim, dim + 1), dim even: one pcg4d hash, no stratification.
vec2 independent_2d(uint seed, uint pixel, uint sample_, uint dim) {
    uvec4 h = pcg4d(uvec4(pixel, dim, seed, sample_));
    return vec2(float(h.x >> 8u), float(h.y >> 8u)) * (1.0 / 16777216.0);
}

const uint DIM_PIXEL_X = 0u;
const uint DIM_PIXEL_Y = 1u;
const uint DIM_BOUNCE_BASE = 2u;
const uint DIMS_PER_BOUNCE = 8u;
const uint DIM_LIGHT_U = 0u;
const uint DIM_LIGHT_V = 1u;
const uint DIM_BSDF_U = 2u;
const uint DIM_BSDF_V = 3u;
const uint DIM_LIGHT_SELECT = 4u;
const uint DIM_LOBE = 5u;
const uint DIM_ROULETTE = 6u;
// Bounces whose draws are stratified; deeper bounces draw independent_2d numbers (see the Rust twin for why).
const uint STRATIFIED_BOUNCES = 1u;

struct Sampler {
    uint seed;
    uint pixel;
    uint sample_;
};

float sampler_get(Sampler s, uint dim) {
    return sample_1d(s.seed, s.pixel, s.sample_, dim);
}

vec2 sampler_get2(Sampler s, uint dim) {
    return sample_2d(s.seed, s.pixel, s.sample_, dim);
}

float sampler_bounce(Sampler s, uint bounce, uint which) {
    uint dim = DIM_BOUNCE_BASE + bounce * DIMS_PER_BOUNCE + which;
    if (bounce < STRATIFIED_BOUNCES) {
        return sampler_get(s, dim);
    } else {
        // Coordinate dim & 1 of the pair, as for stratified draws (a pair draw equals two single draws).
        vec2 xy = independent_2d(s.seed, s.pixel, s.sample_, dim & ~1u);
        if ((dim & 1u) == 0u) {
            return xy.x;
        } else {
            return xy.y;
        }
    }
}

// The pair (which, which + 1) of bounce `bounce`; which must be even.
vec2 sampler_bounce2(Sampler s, uint bounce, uint which) {
    uint dim = DIM_BOUNCE_BASE + bounce * DIMS_PER_BOUNCE + which;
    if (bounce < STRATIFIED_BOUNCES) {
        return sampler_get2(s, dim);
    } else {
        return independent_2d(s.seed, s.pixel, s.sample_, dim);
    }
}

#endif
