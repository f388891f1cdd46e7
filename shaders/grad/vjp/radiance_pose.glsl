// The body of the radiance-pose kernels (radiance_pose.comp; radiance_pose_secondary.comp defines WITH_SECONDARY
// and adds the secondary boundary, which needs shaderFloat64). Reverse mode of the radiance image with respect to
// object poses:
// mode PRIMARY: the primary boundary, silhouettes and creases seen by the camera, sampled by projected length
// (grad/boundary/primary.glsl), the radiance difference across an edge taken from two paths of the integrator
// that share their random numbers; one invocation per edge sample.
// mode INTERIOR: the ray-form interior term, each sample's path recorded and replayed in dual numbers along
// every pose component that moves a triangle of the path (grad/interior/geometry.glsl), and WITH_SECONDARY the
// secondary boundary of the path (grad/boundary/secondary.glsl); one invocation per pixel.
// Each invocation writes its own row of grad_len floats; the host sums the rows in order.
// Rust twin: psdr/src/grad/vjp/radiance_pose.rs (radiance_pose_vjp, radiance_primary_boundary).
// GLSL only: weighted_jump, path_touches (the closure radiance_primary_boundary passes to primary_boundary; the
// test entries_touching makes per object).
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
    uint mode;
    uint secondary_samples;
    uint moving_root;
    uint static_root;
    uint moving_edges;
    uint moving_emits;
};

const uint PRIMARY = 0u;
const uint INTERIOR = 1u;

layout(std430, set = 0, binding = 9) readonly buffer PoseWords { uint pose_words[]; };
layout(std430, set = 0, binding = 10) readonly buffer EdgeWords { uint edge_words[]; };
layout(std430, set = 0, binding = 11) readonly buffer EdgeCdf { float edge_cdf[]; };
// dLoss/d(radiance), 3 per pixel.
layout(std430, set = 0, binding = 12) readonly buffer Adjoint { float adjoint[]; };
layout(std430, set = 0, binding = 13) buffer GradRows { float grad_rows[]; };
#ifdef WITH_SECONDARY
// The secondary edges and their trees (SecondaryEdges::gpu_words).
layout(std430, set = 0, binding = 14) readonly buffer SecEdgeWords { uint sec_edge_words[]; };
layout(std430, set = 0, binding = 15) readonly buffer TreeWords { uint tree_words[]; };
layout(std430, set = 0, binding = 16) readonly buffer EdgeOrder { uint edge_order[]; };
// The welded vertex ids of each triangle's corners (when vertices are parameters), after the secondary buffers.
layout(std430, set = 0, binding = 17) readonly buffer CornerIds { uint corner_ids[]; };
#else
layout(std430, set = 0, binding = 14) readonly buffer CornerIds { uint corner_ids[]; };
#endif

#include "grad/path/record.glsl"
#include "render/path_trace.glsl"
#include "grad/boundary/primary.glsl"
#include "grad/interior/geometry.glsl"
#ifdef WITH_SECONDARY
#include "grad/boundary/secondary.glsl"
#endif

float weighted_jump(uint pixel, vec2 y, vec2 n, Sampler s) {
    vec3 delta = vec3(adjoint[3u * pixel], adjoint[3u * pixel + 1u], adjoint[3u * pixel + 2u]);
    if (delta == vec3(0.0)) {
        return 0.0;
    }
    CameraGpu cam = camera[0];
    vec3 inner = trace_from(fp, s, cam.origin, camera_ray(cam, y.x - n.x * SIDE_EPS, y.y - n.y * SIDE_EPS)).radiance;
    vec3 outer = trace_from(fp, s, cam.origin, camera_ray(cam, y.x + n.x * SIDE_EPS, y.y + n.y * SIDE_EPS)).radiance;
    return dot3(delta, inner - outer);
}

// True when some vertex or light sample of the recorded path lies on `object`: the pose components of other
// objects leave the path's value unchanged in the interior term.
bool path_touches(uint object) {
    for (uint k = 0u; k < rec_count; k++) {
        if (triangles[rec_vertices[k].triangle].object == object) {
            return true;
        }
        if (rec_vertices[k].has_nee && triangles[rec_vertices[k].nee_triangle].object == object) {
            return true;
        }
    }
    return false;
}

// The interior term at pixel p: every sample's path, replayed along every pose entry whose object it touches;
// WITH_SECONDARY, the secondary boundary of the same path, fed by the replay's vertex velocities.
void radiance_pose_vjp(uint p, uint row) {
    CameraGpu cam = camera[0];
    vec3 delta = vec3(adjoint[3u * p], adjoint[3u * p + 1u], adjoint[3u * p + 2u]) / float(fp.spp);
    if (delta == vec3(0.0)) {
        return;
    }
    for (uint sample_ = 0u; sample_ < fp.spp; sample_++) {
        rec_count = 0u;
        trace_path(p % cam.width, p / cam.width, sample_);
        recorder_flush();
        active_count = 0u;
        for (uint e = 0u; e < pose_entry_count; e++) {
            PoseEntry entry = pose_entry(e);
            if (!path_touches(entry.object)) {
                continue;
            }
            // (The host keeps the entries within MAX_ACTIVE where the slots are read, WITH_SECONDARY.)
            if (active_count < MAX_ACTIVE) {
                active_entries[active_count] = e;
                active_vertex[active_count] = NONE;
                active_axis[active_count] = 0u;
            }
            vec3 dl = replay_radiance(Tangent(entry.object, entry.field, NONE, vec3(0.0)), min(active_count, MAX_ACTIVE - 1u));
            active_count += 1u;
            grad_rows[row + entry.at] += dot3(delta, dl);
        }
        // Vertex blocks: every welded vertex at a corner of a triangle the path touches, once, each axis.
        for (uint e = 0u; e < pose_entry_count; e++) {
            PoseEntry entry = pose_entry(e);
            if ((entry.object & VERTEX_BLOCK) == 0u) {
                continue;
            }
            uint object = entry.object & ~VERTEX_BLOCK;
            uint seen[6u * MAX_RECORD_DEPTH];
            uint n_seen = 0u;
            for (uint k = 0u; k < rec_count; k++) {
                for (uint which = 0u; which < 2u; which++) {
                    uint ti = which == 0u ? rec_vertices[k].triangle : (rec_vertices[k].has_nee ? rec_vertices[k].nee_triangle : NONE);
                    if (ti == NONE || triangles[ti].object != object) {
                        continue;
                    }
                    for (uint c = 0u; c < 3u; c++) {
                        uint id = corner_ids[3u * ti + c];
                        bool known = false;
                        for (uint q = 0u; q < n_seen; q++) {
                            known = known || seen[q] == id;
                        }
                        if (!known) {
                            seen[n_seen] = id;
                            n_seen += 1u;
                        }
                    }
                }
            }
            for (uint q = 0u; q < n_seen; q++) {
                for (uint axis = 0u; axis < 3u; axis++) {
                    if (active_count < MAX_ACTIVE) {
                        active_entries[active_count] = e;
                        active_vertex[active_count] = seen[q];
                        active_axis[active_count] = axis;
                    }
                    Tangent tg = Tangent(object, entry.field, seen[q], vertex_axis(entry, axis));
                    vec3 dl = replay_radiance(tg, min(active_count, MAX_ACTIVE - 1u));
                    active_count += 1u;
                    grad_rows[row + entry.at + 3u * seen[q] + axis] += dot3(delta, dl);
                }
            }
        }
#ifdef WITH_SECONDARY
        if (secondary_samples > 0u) {
            secondary_boundary(delta, fp.seed, p, sample_, secondary_samples, row);
        }
#endif
    }
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
    if (mode == INTERIOR) {
        radiance_pose_vjp(begin + i, row);
    } else {
        primary_boundary_sample(fp.seed, edge_samples, begin + i, row);
    }
}
