// Texture lookups in dual numbers: render/texture.glsl's bilinear lookup and its derivative along a uv direction
// (a moving surface slides a texture under a fixed ray).
// Rust twin: psdr/src/grad/ad/dual_texture.rs.
#ifndef PSDR_DUAL_TEXTURE_GLSL
#define PSDR_DUAL_TEXTURE_GLSL
#include "render/texture.glsl"
#include "grad/ad/dual.glsl"

// Channel c of the bilinear lookup at uv and its derivative along duv (differentiated inside the texel cell; the
// four texels are read back through the lookup at their centres).
D dual_texture(TextureGpu t, vec2 uv, vec2 duv, uint c) {
    float x = uv.x * float(t.width) - 0.5;
    float y = (1.0 - uv.y) * float(t.height) - 0.5;
    float fx = x - floor(x);
    float fy = y - floor(y);
    float a = texture_sample(t, vec2((floor(x) + 0.0 + 0.5) / float(t.width), 1.0 - (floor(y) + 0.0 + 0.5) / float(t.height)), c);
    float b = texture_sample(t, vec2((floor(x) + 1.0 + 0.5) / float(t.width), 1.0 - (floor(y) + 0.0 + 0.5) / float(t.height)), c);
    float e = texture_sample(t, vec2((floor(x) + 0.0 + 0.5) / float(t.width), 1.0 - (floor(y) + 1.0 + 0.5) / float(t.height)), c);
    float f = texture_sample(t, vec2((floor(x) + 1.0 + 0.5) / float(t.width), 1.0 - (floor(y) + 1.0 + 0.5) / float(t.height)), c);
    float d_x = (1.0 - fy) * (b - a) + fy * (f - e);
    float d_y = (1.0 - fx) * (e - a) + fx * (f - b);
    return D(texture_sample(t, uv, c), d_x * duv.x * float(t.width) - d_y * duv.y * float(t.height));
}

#endif
