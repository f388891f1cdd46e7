#version 450
// Reverse mode of the radiance image for light radiances and material albedo constants (the interior term;
// these parameters create no discontinuities): every sample's path is recorded by the integrator
// (grad/path/record.glsl) and a backward sweep distributes the pixel's adjoint onto the parameters, with
// vertex k's throughput T_k, MIS-weighted emission e_k, next-event term n_k and continuation weight β_k:
//     ∂L/∂θ = Σ_k T_k (∂n_k/∂θ + ∂β_k/∂θ R_{k+1} + ∂e_k/∂θ),   R_k = e_k + n_k + β_k R_{k+1}.
// Deterministic accumulation: each invocation (one pixel) writes only its own row of the gradient buffer
// (grad_len floats), and the host sums the rows in pixel order; no atomics, so the result never depends on
// scheduling. Rust twin: psdr/src/grad/interior/material_light.rs (radiance_vjp, backward_sweep).
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
};

// dLoss/d(radiance), 3 per pixel of the whole image.
layout(std430, set = 0, binding = 9) readonly buffer Adjoint { float adjoint[]; };
// Gradient offsets: per material its albedo's, then per emitter its radiance's (NONE for none).
layout(std430, set = 0, binding = 10) readonly buffer Slots { uint slots[]; };
// One row of grad_len per pixel of this pass.
layout(std430, set = 0, binding = 11) buffer GradRows { float grad_rows[]; };

#include "grad/path/record.glsl"
#include "render/path_trace.glsl"
#include "grad/ad/bsdf_grad.glsl"

void add3(uint row, uint slot, vec3 v) {
    if (slot != NONE) {
        grad_rows[row + slot] += v.x;
        grad_rows[row + slot + 1u] += v.y;
        grad_rows[row + slot + 2u] += v.z;
    }
}

// Distributes one recorded path's adjoint delta (already divided by spp) onto the row.
void backward_sweep(vec3 delta, uint row) {
    vec3 r_next = vec3(0.0); // R_{k+1}
    for (uint j = rec_count; j > 0u; j--) {
        RecordedVertex v = rec_vertices[j - 1u];
        vec3 a = delta * v.throughput;
        if (v.emitter != NONE) {
            add3(row, slots[material_count + v.emitter], a * v.emission_mis);
        }
        uint albedo = slots[v.material];
        vec3 d_albedo = vec3(0.0);
        if (v.has_nee) {
            add3(row, slots[material_count + v.nee_emitter], a * v.nee_f * v.nee_w_over_pdf);
            if (albedo != NONE) {
                vec3 via_nee = a * v.nee_radiance * v.nee_w_over_pdf;
                d_albedo += via_nee * bsdf_albedo_grad(v.bsdf, v.wi_local, v.nee_wo_local);
            }
        }
        vec3 beta = v.has_next ? v.next_beta : vec3(0.0);
        if (v.has_next && albedo != NONE) {
            vec3 via_path = a * r_next;
            float beta_grad = bsdf_albedo_grad(v.bsdf, v.wi_local, v.next_wo_local) * (1.0 / (v.next_pdf * v.next_q));
            d_albedo += via_path * beta_grad;
        }
        add3(row, albedo, d_albedo);
        r_next = v.local + beta * r_next;
    }
}

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
    if (delta == vec3(0.0)) {
        return;
    }
    for (uint sample_ = 0u; sample_ < fp.spp; sample_++) {
        rec_count = 0u;
        trace_path(p % cam.width, p / cam.width, sample_);
        recorder_flush();
        backward_sweep(delta, row);
    }
}
