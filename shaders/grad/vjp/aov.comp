#version 450
// Reverse mode of the depth and coverage-mask AOVs with respect to object poses:
//     d/dθ ∫_pixel f(y) dy = ∫_pixel ∂f/∂θ dy  +  ∫_{silhouettes ∩ pixel} (f⁻ − f⁺) (V·n) dℓ
// mode DEPTH_INTERIOR: one invocation per pixel, the depth's interior term along its camera rays; mode
// SILHOUETTES: one invocation per edge sample, the boundary term (grad/boundary/primary.glsl) with the jump of
// depth and of every read mask between the two sides. Each invocation writes its own row of grad_len floats and
// the host sums the rows in order, so the result never depends on scheduling.
// Rust twin: psdr/src/grad/vjp/aov.rs (seen_along, depth_interior, boundary).
// GLSL only: mask_adjoint, weighted_jump (an object's mask adjoint at a pixel, 0 when the loss does not read
// it; the closure that boundary passes to primary_boundary_weighted).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

#include "render/layout.glsl"
#include "render/scene_buffers.glsl"

const uint DEPTH_INTERIOR = 0u;
const uint SILHOUETTES = 1u;
// What a camera ray that hits nothing sees (a triangle of no object sees NONE).
const uint MISS = 0xfffffffeu;

layout(push_constant) uniform Push {
    uint seed;
    uint spp;
    uint mode;
    uint grad_len;
    uint begin;
    uint count;
    uint pose_entry_count;
    uint edge_count;
    float total_length;
    uint edge_samples;
    uint has_depth;
};

layout(std430, set = 0, binding = 9) readonly buffer PoseWords { uint pose_words[]; };
layout(std430, set = 0, binding = 10) readonly buffer EdgeWords { uint edge_words[]; };
layout(std430, set = 0, binding = 11) readonly buffer EdgeCdf { float edge_cdf[]; };
// dLoss/d(depth), one per pixel (unused without has_depth).
layout(std430, set = 0, binding = 12) readonly buffer DepthAdjoint { float depth_adjoint[]; };
// dLoss/d(mask) of the read masks, one image each, and per object the index of its image (NONE: not read).
layout(std430, set = 0, binding = 13) readonly buffer MaskAdjoints { float mask_adjoints[]; };
layout(std430, set = 0, binding = 14) readonly buffer MaskOfObject { uint mask_of_object[]; };
layout(std430, set = 0, binding = 15) buffer GradRows { float grad_rows[]; };
// The welded vertex ids of each triangle's corners (when vertices are parameters).
layout(std430, set = 0, binding = 16) readonly buffer CornerIds { uint corner_ids[]; };

#include "render/bvh.glsl"
#include "grad/boundary/primary.glsl"

// What the camera ray through image point (x, y) sees: its depth, and the object it hits (MISS for nothing).
float seen_along(float x, float y, out uint object) {
    CameraGpu cam = camera[0];
    vec3 dir = camera_ray(cam, x, y);
    Hit h = trace_closest(cam.origin, dir, INFINITY);
    if (h.triangle == NONE) {
        object = MISS;
        return 0.0;
    }
    object = triangles[h.triangle].object;
    return h.t * dot3(dir, cam.forward);
}

float mask_adjoint(uint object, uint pixel) {
    if (object >= uint(mask_of_object.length()) || mask_of_object[object] == NONE) {
        return 0.0;
    }
    uint pixels = camera[0].width * camera[0].height;
    return mask_adjoints[mask_of_object[object] * pixels + pixel];
}

float weighted_jump(uint pixel, vec2 y, vec2 n, Sampler s) {
    uint inner_object;
    uint outer_object;
    float inner = seen_along(y.x - n.x * SIDE_EPS, y.y - n.y * SIDE_EPS, inner_object);
    float outer = seen_along(y.x + n.x * SIDE_EPS, y.y + n.y * SIDE_EPS, outer_object);
    float jump = 0.0;
    if (has_depth != 0u) {
        jump += depth_adjoint[pixel] * (inner - outer);
    }
    // Only the masks of the objects seen on either side jump.
    if (inner_object != outer_object) {
        jump += mask_adjoint(inner_object, pixel) * 1.0;
        jump += mask_adjoint(outer_object, pixel) * -1.0;
    }
    return jump;
}

// Interior term of depth at pixel p: along a fixed camera ray the hit distance to a plane moving with velocity
// u changes by (n·u)/(n·d).
void depth_interior(uint p, uint row) {
    CameraGpu cam = camera[0];
    uint px = p % cam.width;
    uint py = p / cam.width;
    float delta = depth_adjoint[p] / float(spp);
    if (delta == 0.0) {
        return;
    }
    for (uint sample_ = 0u; sample_ < spp; sample_++) {
        Sampler s = Sampler(seed, p, sample_);
        vec2 j = sampler_get2(s, DIM_PIXEL_X);
        vec3 dir = camera_ray(cam, float(px) + j.x, float(py) + j.y);
        Hit hit = trace_closest(cam.origin, dir, INFINITY);
        if (hit.triangle == NONE) {
            continue;
        }
        TriangleGeom tri = triangles[hit.triangle];
        if (tri.object == NONE) {
            continue;
        }
        vec3 n = cross3(tri.e1, tri.e2);
        vec3 x = cam.origin + dir * hit.t;
        float nd = dot3(n, dir);
        if (nd == 0.0) {
            continue;
        }
        for (uint e = 0u; e < pose_entry_count; e++) {
            PoseEntry entry = pose_entry(e);
            if (entry.object == tri.object) {
                float dt = dot3(n, affine_velocity_at(entry.field, x)) / nd;
                grad_rows[row + entry.at] += delta * dt * dot3(dir, cam.forward);
            } else if (entry.object == (tri.object | VERTEX_BLOCK)) {
                // The hit's corner vertices move it by their barycentric weights.
                float bary[3] = float[3](1.0 - hit.u - hit.v, hit.u, hit.v);
                for (uint c = 0u; c < 3u; c++) {
                    uint id = corner_ids[3u * hit.triangle + c];
                    for (uint axis = 0u; axis < 3u; axis++) {
                        float dt = dot3(n, vertex_axis(entry, axis) * bary[c]) / nd;
                        grad_rows[row + entry.at + 3u * id + axis] += delta * dt * dot3(dir, cam.forward);
                    }
                }
            }
        }
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
    if (mode == DEPTH_INTERIOR) {
        depth_interior(begin + i, row);
    } else {
        primary_boundary_sample(seed, edge_samples, begin + i, row);
    }
}
