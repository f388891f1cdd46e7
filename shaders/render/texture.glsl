// Texture lookup: bilinear filtering with wrap; uv (0,0) is the bottom-left, texel row 0 the top row.
// Rust twin: psdr/src/render/texture.rs.
#ifndef PSDR_TEXTURE_GLSL
#define PSDR_TEXTURE_GLSL
#include "scene_buffers.glsl"

// i mod n in [0, n); the common in-range case skips the two integer divisions (same value either way).
int wrap(int i, int n) {
    if (uint(i) < uint(n)) {
        return i;
    }
    return ((i % n) + n) % n;
}

// A floored texel coordinate as an index, held within 2^24 texels (where a float has no fraction left): a
// model file's corrupt uv then names some texel of the wrap instead of overflowing the index.
int texel_index(float x0) {
    return int(clamp(x0, -16777216.0, 16777216.0));
}

// The 2x2 texels around a uv (texel indices, row-major, before the channel) and the bilinear weights.
// Computed once per lookup and shared by its channels (the integer wraps are the costly part).
struct Footprint {
    uvec4 texel;
    float fx;
    float fy;
};

Footprint texture_footprint(TextureGpu t, vec2 uv) {
    float x = uv.x * float(t.width) - 0.5;
    float y = (1.0 - uv.y) * float(t.height) - 0.5;
    float x0 = floor(x);
    float y0 = floor(y);
    float fx = x - x0;
    float fy = y - y0;
    int ix = texel_index(x0);
    int iy = texel_index(y0);
    int w = int(t.width);
    int h = int(t.height);
    int xa = wrap(ix, w);
    int xb = wrap(ix + 1, w);
    int ya = wrap(iy, h) * w;
    int yb = wrap(iy + 1, h) * w;
    return Footprint(uvec4(uint(ya + xa), uint(ya + xb), uint(yb + xa), uint(yb + xb)), fx, fy);
}

// Bilinear blend of channel c (clamped to the texture's channel count) over a footprint.
float texture_blend(TextureGpu t, Footprint f, uint c_) {
    uint c = min(c_, t.channels - 1u);
    float a = texels[t.offset + f.texel.x * t.channels + c];
    float b = texels[t.offset + f.texel.y * t.channels + c];
    float d = texels[t.offset + f.texel.z * t.channels + c];
    float e = texels[t.offset + f.texel.w * t.channels + c];
    float fx = f.fx;
    float fy = f.fy;
    return (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (d * (1.0 - fx) + e * fx) * fy;
}

// Bilinear sample of channel c (clamped to the texture's channel count) at uv.
float texture_sample(TextureGpu t, vec2 uv, uint c) {
    return texture_blend(t, texture_footprint(t, uv), c);
}

vec3 texture_sample_rgb(TextureGpu t, vec2 uv) {
    Footprint f = texture_footprint(t, uv);
    return vec3(texture_blend(t, f, 0u), texture_blend(t, f, 1u), texture_blend(t, f, 2u));
}

#endif
