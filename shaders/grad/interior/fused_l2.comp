#version 450
// The fused primal-adjoint estimator of an L2 radiance loss's gradient w.r.t. material and light parameters:
// each pixel's samples split into halves A (seed fp.seed) and B (seed_b) drawn independently, and
//     G_p = ½ [ δ(I_A) · ∂I_B + δ(I_B) · ∂I_A ],   δ(I) = scale (I − target),
// each a product of independent estimates (unbiased; see the Rust twin). The CPU keeps half A's records while
// it traces half B; a GPU invocation cannot hold spp/2 records, so it traces half A once for I_A and again
// (the same paths, bit for bit) for its sweep. Writes the pixel's row of gradients, its texture reads (B's
// paths, then A's, as the CPU sweeps them) and its rendered value (all spp samples).
// Rust twin: psdr/src/grad/interior/fused_l2.rs (radiance_vjp_cross).
// GLSL only: record_half (records sample k of a half: trace_path with that half's seed).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

#include "render/layout.glsl"
#include "render/scene_buffers.glsl"

layout(push_constant) uniform Push {
    FrameParams fp;
    uint grad_len;
    uint pixel_begin;
    uint pixel_count;
    uint material_count;
    uint emitter_count;
    uint texture_reads;
    uint seed_b;
    float scale;
};

// The loss's target image, 3 per pixel of the whole image.
layout(std430, set = 0, binding = 9) readonly buffer Target { float target[]; };
// The rendered image, 3 per pixel of the whole image.
layout(std430, set = 0, binding = 13) buffer Image { float image[]; };

#include "grad/path/record.glsl"
#include "render/path_trace.glsl"
#include "grad/interior/material_light.glsl"

void record_half(uint seed, uint px, uint py, uint k) {
    CameraGpu cam = camera[0];
    Sampler s = Sampler(seed, py * cam.width + px, k);
    vec2 jitter = sampler_get2(s, DIM_PIXEL_X);
    rec_count = 0u;
    trace_from(fp, s, cam.origin, camera_ray(cam, float(px) + jitter.x, float(py) + jitter.y));
    recorder_flush();
}

void main() {
    uint i = gl_GlobalInvocationID.y * (gl_NumWorkGroups.x * 64u) + gl_GlobalInvocationID.x;
    if (i >= pixel_count) {
        return;
    }
    uint p = pixel_begin + i;
    CameraGpu cam = camera[0];
    uint px = p % cam.width;
    uint py = p / cam.width;
    uint row = i * grad_len;
    for (uint k = 0u; k < grad_len; k++) {
        grad_rows[row + k] = 0.0;
    }
    uint n_a = fp.spp / 2u;
    uint n_b = fp.spp - fp.spp / 2u;
    uint reads_stride = READS_PER_PATH * TEXTURE_READ_FLOATS;
    vec3 t = vec3(target[3u * p], target[3u * p + 1u], target[3u * p + 2u]);
    vec3 i_a = vec3(0.0);
    for (uint k = 0u; k < n_a; k++) {
        record_half(fp.seed, px, py, k);
        i_a += path_record_radiance();
    }
    i_a /= float(n_a);
    // Half B's paths carry δ(I_A) as they are traced; half A's, traced again, carry δ(I_B) afterwards.
    vec3 delta_b = (i_a - t) * scale * (0.5 / float(n_b));
    vec3 i_b = vec3(0.0);
    for (uint k = 0u; k < n_b; k++) {
        record_half(seed_b, px, py, k);
        i_b += path_record_radiance();
        uint reads_at = (i * fp.spp + k) * reads_stride;
        if (delta_b != vec3(0.0)) {
            reads_end(reads_at, normal_map_sweep(delta_b, backward_sweep(delta_b, row, reads_at)));
        } else if (texture_reads != 0u) {
            texture_reads_out[reads_at] = NONE;
        }
    }
    i_b /= float(n_b);
    vec3 delta_a = (i_b - t) * scale * (0.5 / float(n_a));
    for (uint k = 0u; k < n_a; k++) {
        uint reads_at = (i * fp.spp + n_b + k) * reads_stride;
        if (delta_a != vec3(0.0)) {
            record_half(fp.seed, px, py, k);
            reads_end(reads_at, normal_map_sweep(delta_a, backward_sweep(delta_a, row, reads_at)));
        } else if (texture_reads != 0u) {
            texture_reads_out[reads_at] = NONE;
        }
    }
    vec3 value = (i_a * float(n_a) + i_b * float(n_b)) / float(fp.spp);
    image[3u * p] = value.x;
    image[3u * p + 1u] = value.y;
    image[3u * p + 2u] = value.z;
}
