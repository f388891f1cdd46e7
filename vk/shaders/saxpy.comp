#version 450
// y[i] = a * x[i] + y[i]. Works with Groups::folded_2d (one item per invocation) and with
// Groups::grid_stride (each invocation loops): the index folds y into x and strides by the whole grid.
layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    float a;
    uint n;
} pc;

layout(std430, set = 0, binding = 0) readonly buffer X { float x[]; };
layout(std430, set = 0, binding = 1) buffer Y { float y[]; };

void main() {
    uint width = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint stride = width * gl_NumWorkGroups.y;
    for (uint i = gl_GlobalInvocationID.y * width + gl_GlobalInvocationID.x; i < pc.n; i += stride) {
        y[i] = pc.a * x[i] + y[i];
    }
}
