#version 450
// Reverse mode of the radiance image for light radiances, material albedo, roughness and specular constants,
// and (through the host) texels, procedural albedo maps and uv transforms (the interior term; these parameters
// create no discontinuities): every sample's path is recorded by the integrator
// (grad/path/record.glsl) and a backward sweep distributes the pixel's adjoint onto the parameters, with
// vertex k's throughput T_k, MIS-weighted emission e_k, next-event term n_k and continuation weight β_k:
//     ∂L/∂θ = Σ_k T_k (∂n_k/∂θ + ∂β_k/∂θ R_{k+1} + ∂e_k/∂θ),   R_k = e_k + n_k + β_k R_{k+1}.
// Deterministic accumulation: each invocation (one pixel) writes only its own row of the gradient buffer
// (grad_len floats), and the host sums the rows in pixel order; no atomics, so the result never depends on
// scheduling. The sweep itself is grad/interior/material_light.glsl.
// Rust twin: psdr/src/grad/interior/material_light.rs (radiance_vjp).
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
};

// dLoss/d(radiance), 3 per pixel of the whole image.
layout(std430, set = 0, binding = 9) readonly buffer Adjoint { float adjoint[]; };

#include "grad/path/record.glsl"
#include "render/path_trace.glsl"
#include "grad/interior/material_light.glsl"

// The kernel body (Rust twin: radiance_vjp): one pixel of the pass, all its samples.
void main() {
    uint i = gl_GlobalInvocationID.y * (gl_NumWorkGroups.x * 64u) + gl_GlobalInvocationID.x;
    if (i >= pixel_count) {
        return;
    }
    uint p = pixel_begin + i;
    CameraGpu cam = camera[0];
    uint row = i * grad_len;
    for (uint k = 0u; k < grad_len; k++) {
        grad_rows[row + k] = 0.0;
    }
    vec3 delta = vec3(adjoint[3u * p], adjoint[3u * p + 1u], adjoint[3u * p + 2u]) / float(fp.spp);
    uint reads_stride = READS_PER_PATH * TEXTURE_READ_FLOATS;
    if (delta == vec3(0.0)) {
        for (uint sample_ = 0u; texture_reads != 0u && sample_ < fp.spp; sample_++) {
            texture_reads_out[(i * fp.spp + sample_) * reads_stride] = NONE;
        }
        return;
    }
    for (uint sample_ = 0u; sample_ < fp.spp; sample_++) {
        rec_count = 0u;
        trace_path(p % cam.width, p / cam.width, sample_);
        recorder_flush();
        uint path_reads = (i * fp.spp + sample_) * reads_stride;
        reads_end(path_reads, normal_map_sweep(delta, backward_sweep(delta, row, path_reads)));
    }
}
