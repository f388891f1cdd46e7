// Primary boundary: silhouette edges projected to the image, sampled by projected length (the edge list and the
// CDF of their lengths are built on the host, PrimaryEdges::build), and one edge sample's contribution to the
// pose gradient. The including kernel declares, before including this file: the buffers edge_words (uint,
// EDGE_WORDS per edge), edge_cdf (float), pose_words (uint, POSE_WORDS per pose entry) and grad_rows (float);
// the push constants edge_count, total_length and pose_entry_count; and the function
//     float weighted_jump(uint pixel, vec2 y, vec2 n, Sampler s)
// (Σ_outputs adjoint(pixel) · [f(y − εn) − f(y + εn)], the closure the Rust twin takes).
// Rust twin: psdr/src/grad/boundary/primary.rs (project_velocity, point_on_edge, PrimaryEdges::sample,
// primary_boundary_sample).
// GLSL only: image_edge, pose_entry, words_vec3, pose_vec3 (unpack one edge and one pose entry from their words).
#ifndef PSDR_PRIMARY_GLSL
#define PSDR_PRIMARY_GLSL
#include "render/layout.glsl"
#include "render/vec_math.glsl"
#include "render/camera.glsl"
#include "render/sampler.glsl"
#include "grad/path/velocity.glsl"

// Offset of the two side rays from a silhouette, in pixels (SIDE_EPS), and the seed tweak of edge samples.
const float SIDE_EPS = 1e-3;
const uint EDGE_SEED = 0x6a09e667u;
// Words per edge: a (3 floats), object, b (3), unused, pa (2), pb (2).
const uint EDGE_WORDS = 12u;
// Words per pose entry: object, gradient offset, a (3 floats), G's columns (9), t (3).
const uint POSE_WORDS = 17u;

// A silhouette edge clipped to the front of the camera: world and image endpoints.
struct ImageEdge {
    vec3 a;
    vec3 b;
    vec2 pa;
    vec2 pb;
    uint object;
};

// A point sampled on the silhouette set (see the Rust twin).
struct EdgeSample {
    uint edge;
    vec2 y;
    vec2 n;
    vec3 x;
    float pdf;
};

// One differentiable pose component: its object, its offset in the gradient and its velocity field.
struct PoseEntry {
    uint object;
    uint at;
    AffineVelocity field;
};

vec3 words_vec3(uint at) {
    return vec3(uintBitsToFloat(edge_words[at]), uintBitsToFloat(edge_words[at + 1u]), uintBitsToFloat(edge_words[at + 2u]));
}

ImageEdge image_edge(uint k) {
    uint w = k * EDGE_WORDS;
    return ImageEdge(words_vec3(w), words_vec3(w + 4u),
                     vec2(uintBitsToFloat(edge_words[w + 8u]), uintBitsToFloat(edge_words[w + 9u])),
                     vec2(uintBitsToFloat(edge_words[w + 10u]), uintBitsToFloat(edge_words[w + 11u])),
                     edge_words[w + 3u]);
}

vec3 pose_vec3(uint at) {
    return vec3(uintBitsToFloat(pose_words[at]), uintBitsToFloat(pose_words[at + 1u]), uintBitsToFloat(pose_words[at + 2u]));
}

PoseEntry pose_entry(uint e) {
    uint w = e * POSE_WORDS;
    AffineVelocity f = AffineVelocity(pose_vec3(w + 2u), mat3(pose_vec3(w + 5u), pose_vec3(w + 8u), pose_vec3(w + 11u)),
                                      pose_vec3(w + 14u));
    return PoseEntry(pose_words[w], pose_words[w + 1u], f);
}

// ∂(pixel x, pixel y)/∂x of the projection at world point x, applied to a velocity u.
vec2 project_velocity(CameraGpu c, vec3 x, vec3 u) {
    vec3 r = x - c.origin;
    float z = dot3(r, c.forward);
    float dz = dot3(u, c.forward);
    float sx = 0.5 * float(c.width) / (c.tan_half_fov * c.aspect);
    float sy = -0.5 * float(c.height) / c.tan_half_fov;
    return vec2(sx * (dot3(u, c.right) * z - dot3(r, c.right) * dz) / (z * z),
                sy * (dot3(u, c.up) * z - dot3(r, c.up) * dz) / (z * z));
}

// The point of the edge's 3D segment whose projection is y (closest point between the camera ray through y and
// the edge's line); false when the edge points at the camera.
bool point_on_edge(CameraGpu cam, ImageEdge e, vec2 y, out vec3 x) {
    vec3 o = cam.origin;
    vec3 d = camera_ray(cam, y.x, y.y);
    vec3 ab = e.b - e.a;
    vec3 w = e.a - o;
    float a11 = dot3(ab, ab);
    float a12 = dot3(ab, d);
    float a22 = dot3(d, d);
    float b1 = -dot3(w, ab);
    float b2 = dot3(w, d);
    float det = a11 * a22 - a12 * a12;
    if (abs(det) <= 1e-12 * a11 * a22) {
        return false;
    }
    float t = clamp((b1 * a22 + a12 * b2) / det, 0.0, 1.0);
    x = e.a + ab * t;
    return true;
}

// A point uniformly distributed over the total projected length, from two uniform numbers.
bool primary_edges_sample(CameraGpu cam, float u_edge, float u_along, out EdgeSample es) {
    if (total_length <= 0.0) {
        return false;
    }
    float target = u_edge * total_length;
    // The first edge whose running length exceeds the target (partition_point).
    uint lo = 0u;
    uint hi = edge_count;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (edge_cdf[mid] <= target) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    uint k = min(lo, edge_count - 1u);
    ImageEdge e = image_edge(k);
    float dx = e.pb.x - e.pa.x;
    float dy = e.pb.y - e.pa.y;
    float len = sqrt(dx * dx + dy * dy);
    if (len <= 0.0) {
        return false;
    }
    vec2 y = vec2(e.pa.x + dx * u_along, e.pa.y + dy * u_along);
    vec3 x;
    if (!point_on_edge(cam, e, y, x)) {
        return false;
    }
    es = EdgeSample(k, y, vec2(-dy / len, dx / len), x, 1.0 / total_length);
    return true;
}

float weighted_jump(uint pixel, vec2 y, vec2 n, Sampler s);

// Edge sample k of the primary boundary term, added to the row at `row`.
void primary_boundary_sample(uint seed, uint edge_samples, uint k, uint row) {
    CameraGpu cam = camera[0];
    float w = float(cam.width);
    float h = float(cam.height);
    Sampler s = Sampler(seed ^ EDGE_SEED, k, 0u);
    EdgeSample es;
    if (!primary_edges_sample(cam, sampler_get(s, 0u), sampler_get(s, 1u), es)) {
        return;
    }
    float x = es.y.x;
    float y = es.y.y;
    if (!(x >= 0.0 && y >= 0.0 && x < w && y < h)) {
        return;
    }
    uint pixel = uint(y) * cam.width + uint(x);
    float jump = weighted_jump(pixel, es.y, es.n, s);
    if (jump == 0.0) {
        return;
    }
    ImageEdge edge = image_edge(es.edge);
    float weight = jump / (es.pdf * float(edge_samples));
    for (uint e = 0u; e < pose_entry_count; e++) {
        PoseEntry p = pose_entry(e);
        if (p.object != edge.object) {
            continue;
        }
        vec2 v = project_velocity(cam, es.x, affine_velocity_at(p.field, es.x));
        grad_rows[row + p.at] += weight * (v.x * es.n.x + v.y * es.n.y);
    }
}

#endif
