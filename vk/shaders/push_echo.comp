#version 450
// Writes the push-constant block back as raw 32-bit words, to check that Rust and GLSL agree on its layout.
layout(local_size_x = 1) in;

layout(push_constant) uniform Push {
    uvec4 u;
    ivec4 i;
    vec4 f;
    vec3 v;
    float w;
    uint seed;
    uint sample_index;
    uint width;
    uint height;
} pc;

layout(std430, set = 0, binding = 0) writeonly buffer Out { uint words[]; };

void main() {
    for (int k = 0; k < 4; k++) words[k] = pc.u[k];
    for (int k = 0; k < 4; k++) words[4 + k] = uint(pc.i[k]);
    for (int k = 0; k < 4; k++) words[8 + k] = floatBitsToUint(pc.f[k]);
    for (int k = 0; k < 3; k++) words[12 + k] = floatBitsToUint(pc.v[k]);
    words[15] = floatBitsToUint(pc.w);
    words[16] = pc.seed;
    words[17] = pc.sample_index;
    words[18] = pc.width;
    words[19] = pc.height;
}
