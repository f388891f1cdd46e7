#version 450
// The primary boundary term of radiance with respect to object poses: silhouettes and creases seen by the
// camera, sampled by projected length (grad/boundary/primary.glsl), the radiance difference across an edge
// taken from two paths of the integrator that share their random numbers. One invocation per edge sample writes
// its own row of grad_len floats; the host sums the rows in sample order.
// Rust twin: psdr/src/grad/vjp/radiance_pose.rs (radiance_primary_boundary).
// GLSL only: weighted_jump (the closure radiance_primary_boundary passes to primary_boundary).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

#include "render/layout.glsl"
#include "render/scene_buffers.glsl"

layout(push_constant) uniform Push {
    FrameParams fp;
    uint grad_len;
    uint begin;
    uint count;
    uint pose_entry_count;
    uint edge_count;
    float total_length;
    uint edge_samples;
};

layout(std430, set = 0, binding = 9) readonly buffer PoseWords { uint pose_words[]; };
layout(std430, set = 0, binding = 10) readonly buffer EdgeWords { uint edge_words[]; };
layout(std430, set = 0, binding = 11) readonly buffer EdgeCdf { float edge_cdf[]; };
// dLoss/d(radiance), 3 per pixel.
layout(std430, set = 0, binding = 12) readonly buffer Adjoint { float adjoint[]; };
layout(std430, set = 0, binding = 13) buffer GradRows { float grad_rows[]; };

#include "render/path_trace.glsl"
#include "grad/boundary/primary.glsl"

float weighted_jump(uint pixel, vec2 y, vec2 n, Sampler s) {
    vec3 delta = vec3(adjoint[3u * pixel], adjoint[3u * pixel + 1u], adjoint[3u * pixel + 2u]);
    if (delta == vec3(0.0)) {
        return 0.0;
    }
    CameraGpu cam = camera[0];
    vec3 inner = trace_from(s, cam.origin, camera_ray(cam, y.x - n.x * SIDE_EPS, y.y - n.y * SIDE_EPS)).radiance;
    vec3 outer = trace_from(s, cam.origin, camera_ray(cam, y.x + n.x * SIDE_EPS, y.y + n.y * SIDE_EPS)).radiance;
    return dot3(delta, inner - outer);
}

void main() {
    uint i = gl_GlobalInvocationID.y * (gl_NumWorkGroups.x * 64u) + gl_GlobalInvocationID.x;
    if (i >= count) {
        return;
    }
    uint row = i * grad_len;
    for (uint k = 0u; k < grad_len; k++) {
        grad_rows[row + k] = 0.0;
    }
    primary_boundary_sample(fp.seed, edge_samples, begin + i, row);
}
