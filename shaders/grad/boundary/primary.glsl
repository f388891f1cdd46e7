// Primary boundary: silhouette edges projected to the image, sampled by projected length (the edge list and the
// CDF of their lengths are built on the host, PrimaryEdges::build), and one edge sample's contribution to the
// pose gradient. The including kernel declares, before including this file: the buffers edge_words (uint,
// EDGE_WORDS per edge), edge_cdf (float), pose_words (uint, POSE_WORDS per pose entry), corner_ids (uint, the
// welded vertex ids of each triangle's corners, when vertices are parameters) and grad_rows (float);
// the push constants edge_count, total_length and pose_entry_count; and the function
//     float weighted_jump(uint pixel, vec2 y, vec2 n, Sampler s)
// (Σ_outputs adjoint(pixel) · [f(y − εn) − f(y + εn)], the closure the Rust twin takes).
// Rust twin: psdr/src/grad/boundary/primary.rs (project_velocity, point_on_edge, PrimaryEdges::sample,
// primary_boundary_sample, ImageEdge::site).
// GLSL only: image_edge, pose_entry, words_vec3, pose_vec3, vertex_axis (unpack an edge and a pose entry from
// their words; a vertex block's ∂x/∂(v_k)_a at weight 1).
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
// Words per edge: a (3 floats), object, b (3), the first end's welded id, pa (2), pb (2), the whole mesh edge's
// first point (3), the second end's id, its second point (3), unused.
const uint EDGE_WORDS = 20u;
// Words per pose entry: object, gradient offset, a (3 floats), G's columns (9), t (3). A vertex block (an object
// whose vertices are parameters) tags its object VERTEX_BLOCK, gives the offset of vertex 0 axis 0 (vertex k
// axis a is 3k + a further) and R (e_a S) for the three axes in a, G's first and second columns.
const uint POSE_WORDS = 17u;
const uint VERTEX_BLOCK = 0x80000000u;

// A silhouette edge clipped to the front of the camera: world and image endpoints.
struct ImageEdge {
    vec3 a;
    vec3 b;
    vec2 pa;
    vec2 pb;
    uint object;
    // The whole (unclipped) mesh edge and the welded ids of its ends, for vertex velocities.
    vec3 mesh0;
    vec3 mesh1;
    uint end0;
    uint end1;
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
                     edge_words[w + 3u], words_vec3(w + 12u), words_vec3(w + 16u), edge_words[w + 7u],
                     edge_words[w + 15u]);
}

// Where x lies along the mesh edge, as the weight t of its second end (1 − t of the first).
float image_edge_site(ImageEdge e, vec3 x) {
    vec3 ab = e.mesh1 - e.mesh0;
    return clamp(dot3(x - e.mesh0, ab) / dot3(ab, ab), 0.0, 1.0);
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

vec3 vertex_axis(PoseEntry p, uint axis) {
    return axis == 0u ? p.field.a : (axis == 1u ? p.field.g[0] : p.field.g[1]);
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
    // The edge's end vertices, when they are parameters: x moves with them by their weights along the edge.
    for (uint e = 0u; e < pose_entry_count; e++) {
        PoseEntry p = pose_entry(e);
        if (p.object != (edge.object | VERTEX_BLOCK)) {
            continue;
        }
        float t = image_edge_site(edge, es.x);
        for (uint end = 0u; end < 2u; end++) {
            uint id = end == 0u ? edge.end0 : edge.end1;
            float b = end == 0u ? 1.0 - t : t;
            for (uint axis = 0u; axis < 3u; axis++) {
                vec2 v = project_velocity(cam, es.x, vertex_axis(p, axis) * b);
                grad_rows[row + p.at + 3u * id + axis] += weight * (v.x * es.n.x + v.y * es.n.y);
            }
        }
    }
}

#endif
