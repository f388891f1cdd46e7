#version 450
#extension GL_EXT_shader_atomic_float : require
// hist[bin(v)] += v with float atomicAdd into a storage buffer: the pattern of gradient accumulation.
layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint n;
    uint bins;
} pc;

layout(std430, set = 0, binding = 0) readonly buffer Values { float values[]; };
layout(std430, set = 0, binding = 1) buffer Hist { float hist[]; };

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint i = gl_GlobalInvocationID.x; i < pc.n; i += stride) {
        float v = values[i];
        uint bin = min(uint(v * float(pc.bins)), pc.bins - 1u);
        atomicAdd(hist[bin], v);
    }
}
