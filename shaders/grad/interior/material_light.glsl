// The backward sweep of material and light parameters over one recorded path (grad/path/record.glsl), shared
// by the adjoint kernels material_light.comp (two passes: primal, then adjoint) and fused_l2.comp (one pass, two
// halves). The including kernel declares the push constants material_count, emitter_count and texture_reads
// before including this file; it binds the slot table, the gradient rows and the texture reads at 10, 11, 12.
// Rust twin: psdr/src/grad/interior/material_light.rs (add3, backward_sweep, normal_map_sweep).
// GLSL only: texture_read_out, reads_end (hand a vertex's texture_read_adjoint or normal_read_adjoint arguments to
// the host, which calls the Rust function itself: whole-texture gradients do not fit a row per pixel; close a
// path's records).
#ifndef PSDR_MATERIAL_LIGHT_GLSL
#define PSDR_MATERIAL_LIGHT_GLSL
#include "render/layout.glsl"
#include "grad/path/record.glsl"
#include "grad/ad/bsdf_grad.glsl"
#include "grad/interior/normal_map.glsl"

// Gradient offsets (NONE for none): per material its albedo's, per emitter its radiance's, per material its
// roughness's, per material its specular's; then per material the BSDF derivatives wanted (WANTED_*), its
// reads (READS_TEXTURE | READS_NORMAL_MAP), and its uv transform's scale x, scale y and rotation in degrees (float
// bits).
layout(std430, set = 0, binding = 10) readonly buffer Slots { uint slots[]; };
// One row of grad_len per pixel of this pass.
layout(std430, set = 0, binding = 11) buffer GradRows { float grad_rows[]; };
// Texture-space adjoints, when some material's are wanted (texture_reads != 0): per path of this pass (pixel,
// sample) READS_PER_PATH records of TEXTURE_READ_FLOATS in sweep order, ended by a material of NONE unless full:
// (material, uv, d_albedo, d_rough) from backward_sweep, then (material | NORMAL_READ, uv, d_c, d_uv) from
// normal_map_sweep, floats as their bits. The host carries them into texels, whole maps and uv transforms with the
// CPU's own texture_read_adjoint and normal_read_adjoint, in pixel, sample and sweep order.
layout(std430, set = 0, binding = 12) buffer TextureReads { uint texture_reads_out[]; };

const uint WANTED_NOTHING = 0u;
const uint WANTED_ALBEDO = 1u;
const uint WANTED_ALL = 2u;
const uint TEXTURE_READ_FLOATS = 12u;
const uint READS_PER_PATH = 2u * MAX_RECORD_DEPTH;
const uint READS_TEXTURE = 1u;
const uint READS_NORMAL_MAP = 2u;
const uint NORMAL_READ = 0x80000000u;


void add3(uint row, uint slot, vec3 v) {
    if (slot != NONE) {
        grad_rows[row + slot] += v.x;
        grad_rows[row + slot + 1u] += v.y;
        grad_rows[row + slot + 2u] += v.z;
    }
}

// Stores one vertex's texture-space adjoint for the host (texture_read_adjoint, or normal_read_adjoint for a
// material tagged NORMAL_READ).
void texture_read_out(uint at, uint material, vec2 uv, vec3 x, vec3 y) {
    texture_reads_out[at] = material;
    texture_reads_out[at + 1u] = floatBitsToUint(uv.x);
    texture_reads_out[at + 2u] = floatBitsToUint(uv.y);
    texture_reads_out[at + 3u] = floatBitsToUint(x.x);
    texture_reads_out[at + 4u] = floatBitsToUint(x.y);
    texture_reads_out[at + 5u] = floatBitsToUint(x.z);
    texture_reads_out[at + 6u] = floatBitsToUint(y.x);
    texture_reads_out[at + 7u] = floatBitsToUint(y.y);
    texture_reads_out[at + 8u] = floatBitsToUint(y.z);
}

// Ends a path's records begun at path_reads (when not full).
void reads_end(uint path_reads, uint reads_at) {
    if (texture_reads != 0u && reads_at < path_reads + READS_PER_PATH * TEXTURE_READ_FLOATS) {
        texture_reads_out[reads_at] = NONE;
    }
}

// Distributes one recorded path's adjoint delta (already divided by spp) onto the row, and its texture reads
// from reads_at on; returns where the next record goes.
uint backward_sweep(vec3 delta, uint row, uint reads_at) {
    vec3 r_next = vec3(0.0); // R_{k+1}
    for (uint j = rec_count; j > 0u; j--) {
        RecordedVertex v = rec_vertices[j - 1u];
        vec3 a = delta * v.throughput;
        if (v.emitter != NONE) {
            add3(row, slots[material_count + v.emitter], a * v.emission_shape * v.emission_mis);
        }
        uint albedo = slots[v.material];
        uint roughness = slots[material_count + emitter_count + v.material];
        uint specular = slots[2u * material_count + emitter_count + v.material];
        // BSDF derivatives only where some requested parameter reads this material, the roughness and specular
        // ones (a dual evaluation) only when asked for.
        uint wanted = slots[3u * material_count + emitter_count + v.material];
        vec3 d_albedo = vec3(0.0);
        vec3 d_rough = vec3(0.0);
        vec3 d_spec = vec3(0.0);
        if (v.has_nee) {
            add3(row, slots[material_count + v.nee_emitter], a * v.nee_f * emitter_shape(v.nee_emitter, v.nee_dir) * v.nee_w_over_pdf);
            if (wanted != WANTED_NOTHING) {
                vec3 via_nee = a * v.nee_radiance * v.nee_w_over_pdf;
                BsdfGrad f_grad = wanted == WANTED_ALL ? bsdf_eval_grad(v.bsdf, v.wi_local, v.nee_wo_local)
                                      : bsdf_albedo_grad(v.bsdf, v.wi_local, v.nee_wo_local);
                d_albedo += via_nee * f_grad.albedo;
                d_rough += via_nee * f_grad.roughness;
                d_spec += via_nee * f_grad.specular;
            }
        }
        vec3 beta = v.has_next ? v.next_beta : vec3(0.0);
        if (v.has_next && wanted != WANTED_NOTHING) {
            vec3 via_path = a * r_next;
            BsdfGrad g = wanted == WANTED_ALL ? bsdf_eval_grad(v.bsdf, v.wi_local, v.next_wo_local)
                             : bsdf_albedo_grad(v.bsdf, v.wi_local, v.next_wo_local);
            BsdfGrad beta_grad = bsdf_grad_scaled(g, 1.0 / (v.next_pdf * v.next_q));
            d_albedo += via_path * beta_grad.albedo;
            d_rough += via_path * beta_grad.roughness;
            d_spec += via_path * beta_grad.specular;
        }
        add3(row, albedo, d_albedo);
        if (roughness != NONE) {
            grad_rows[row + roughness] += d_rough.x + d_rough.y + d_rough.z;
        }
        if (specular != NONE) {
            grad_rows[row + specular] += d_spec.x + d_spec.y + d_spec.z;
        }
        if ((slots[4u * material_count + emitter_count + v.material] & READS_TEXTURE) != 0u) {
            texture_read_out(reads_at, v.material, v.uv, d_albedo, vec3(d_rough.x + d_rough.y + d_rough.z, 0.0, 0.0));
            reads_at += TEXTURE_READ_FLOATS;
        }
        r_next = v.local + beta * r_next;
    }
    return reads_at;
}

// The normal-map part: at each vertex whose map (or its uv transform) is wanted, dL/dn_s from its next-event and
// continuation terms (R_{k+1} as in backward_sweep), through the mapping to the map's channels and the uv
// transform, handed to the host; returns where the next record goes.
uint normal_map_sweep(vec3 delta, uint reads_at) {
    // R_{k+1} for every k, from the back.
    vec3 r_after[MAX_RECORD_DEPTH];
    vec3 r_next = vec3(0.0);
    for (uint j = rec_count; j > 0u; j--) {
        r_after[j - 1u] = r_next;
        RecordedVertex v = rec_vertices[j - 1u];
        r_next = v.local + (v.has_next ? v.next_beta : vec3(0.0)) * r_next;
    }
    for (uint k = 0u; k < rec_count; k++) {
        RecordedVertex v = rec_vertices[k];
        uint m = v.material;
        if ((slots[4u * material_count + emitter_count + m] & READS_NORMAL_MAP) == 0u) {
            continue;
        }
        vec3 incoming = k == 0u ? rec_dir : rec_vertices[k - 1u].next_dir;
        SurfacePoint sp;
        mat3 jacobian;
        if (!normal_map_jacobian(v.triangle, v.u, v.v, incoming, sp, jacobian)) {
            continue;
        }
        vec3 a = delta * v.throughput;
        vec3 d_ns = vec3(0.0);
        if (v.has_nee) {
            d_ns += bsdf_normal_adjoint(sp, -incoming, v.nee_dir, a * v.nee_radiance * v.nee_w_over_pdf);
        }
        if (v.has_next) {
            d_ns += bsdf_normal_adjoint(sp, -incoming, v.next_dir, a * r_after[k] / (v.next_pdf * v.next_q));
        }
        vec3 d_c = vec3(dot3(jacobian[0], d_ns), dot3(jacobian[1], d_ns), dot3(jacobian[2], d_ns));
        vec3 d_uv = vec3(0.0);
        uint transform = 5u * material_count + emitter_count + 3u * m;
        vec2 scale = vec2(uintBitsToFloat(slots[transform]), uintBitsToFloat(slots[transform + 1u]));
        float rotation_deg = uintBitsToFloat(slots[transform + 2u]);
        vec3 dn[3];
        normal_map_uv_tangents(v.triangle, v.u, v.v, incoming, scale, rotation_deg, dn);
        d_uv = vec3(dot3(d_ns, dn[0]), dot3(d_ns, dn[1]), dot3(d_ns, dn[2]));
        texture_read_out(reads_at, m | NORMAL_READ, v.uv, d_c, d_uv);
        reads_at += TEXTURE_READ_FLOATS;
    }
    return reads_at;
}

#endif
