// Texture lookup: bilinear filtering with wrap; uv (0,0) is the bottom-left, texel row 0 the top row.
// Rust twin: psdr/src/render/texture.rs.
#ifndef PSDR_TEXTURE_GLSL
#define PSDR_TEXTURE_GLSL
#include "scene_buffers.glsl"

int wrap(int i, int n) {
    return ((i % n) + n) % n;
}

float texel(TextureGpu t, int x, int y, uint c) {
    int w = int(t.width);
    int h = int(t.height);
    uint idx = uint(wrap(y, h) * w + wrap(x, w)) * t.channels + min(c, t.channels - 1u);
    return texels[t.offset + idx];
}

float texture_sample(TextureGpu t, vec2 uv, uint c) {
    float x = uv.x * float(t.width) - 0.5;
    float y = (1.0 - uv.y) * float(t.height) - 0.5;
    float x0 = floor(x);
    float y0 = floor(y);
    float fx = x - x0;
    float fy = y - y0;
    int ix = int(x0);
    int iy = int(y0);
    float a = texel(t, ix, iy, c);
    float b = texel(t, ix + 1, iy, c);
    float d = texel(t, ix, iy + 1, c);
    float e = texel(t, ix + 1, iy + 1, c);
    return (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (d * (1.0 - fx) + e * fx) * fy;
}

vec3 texture_sample_rgb(TextureGpu t, vec2 uv) {
    return vec3(texture_sample(t, uv, 0u), texture_sample(t, uv, 1u), texture_sample(t, uv, 2u));
}

#endif
