// Secondary boundary terms at the vertices of a recorded camera path (see the Rust twin for the estimator): at
// each scattering vertex, `count` edges drawn from the edge trees (the moving edges' and, when the vertex itself
// moves, the static edges'), a point along each, the scattered radiance on both sides from two sub-paths that
// share their random numbers, and the relative motion of edge point and vertex. Vertices on turning surfaces
// also get horizon samples (grad/boundary/horizon.glsl). The including kernel provides the recorded path, the
// pose entries (grad/boundary/primary.glsl), the active entries and their replayed vertex velocities
// (grad/interior/geometry.glsl), the edge and tree buffers, grad_rows and the push constants moving_root,
// static_root, moving_edges and moving_emits.
// Rust twin: psdr/src/grad/boundary/secondary.rs (light_side_vertex, secondary_boundary).
// GLSL only: edge_weight, active_slot, active_tangent, edge_sample_share (the closure secondary_boundary gives the
// tree; an entry's place among the active ones, its tangent; the body of its loop over moving entries).
#ifndef PSDR_SECONDARY_GLSL
#define PSDR_SECONDARY_GLSL
#include "render/shading.glsl"
#include "render/bsdf.glsl"
#include "grad/boundary/mesh_edges.glsl"
#include "grad/boundary/edge_tree.glsl"

// Angular offset of the two side directions from an edge (radians), the clear part of the way to an edge point,
// and the seed tweaks of secondary edge and horizon samples.
const float SECONDARY_SIDE_EPS = 1e-4;
const float HIDDEN_MARGIN = 1e-3;
const uint SECONDARY_SEED = 0xbb67ae85u;
const uint HORIZON_SEED = 0x3c6ef372u;

// The turning entries of the vertex being sampled (horizon_boundary reads them).
uint turn_at[MAX_ACTIVE];
vec3 turn_dn[MAX_ACTIVE];

#include "grad/boundary/horizon.glsl"

// The exact weight of an edge seen from x above the plane of ng: its approximate arc length on the sphere around
// x times its strength, zero unless it can be a silhouette or a crease seen from x.
float edge_weight(uint i, vec3 x, vec3 ng) {
    MeshEdge e = mesh_edge(i);
    bool above = dot3(ng, e.a - x) > 0.0 || dot3(ng, e.b - x) > 0.0;
    bool creased = e.crease && dot3(e.n1, x - e.a) > 0.0 && dot3(e.n2, x - e.a) > 0.0;
    bool silhouette = mesh_edge_is_silhouette_from(e, x);
    if (!(above && (silhouette || creased))) {
        return 0.0;
    }
    vec3 mid = 0.5 * (e.a + e.b) - x;
    float r = length3(mid);
    vec3 om = mid / r;
    vec3 ab = e.b - e.a;
    float strength = silhouette ? 1.0 : e.strength;
    float w = length3(ab - om * dot3(om, ab)) / r * strength;
    return (isnan(w) || isinf(w)) ? 0.0 : w;
}

// The place of pose entry e (for a vertex block: its vertex and axis) among the path's active entries, or NONE.
uint active_slot(uint e, uint vertex, uint axis) {
    for (uint j = 0u; j < active_count; j++) {
        if (active_entries[j] == e && active_vertex[j] == vertex && active_axis[j] == axis) {
            return j;
        }
    }
    return NONE;
}

// The tangent and gradient offset of active slot j.
Tangent active_tangent(uint j, out uint at) {
    PoseEntry entry = pose_entry(active_entries[j]);
    uint vertex = active_vertex[j];
    if (vertex == NONE) {
        at = entry.at;
        return Tangent(entry.object, entry.field, NONE, vec3(0.0));
    }
    at = entry.at + 3u * vertex + active_axis[j];
    return Tangent(entry.object & ~VERTEX_BLOCK, entry.field, vertex, vertex_axis(entry, active_axis[j]));
}

// Adds one moving entry's share of an edge sample: the edge point's velocity relative to x's.
void edge_sample_share(uint at, vec3 edge_velocity, vec3 x_velocity, vec3 om, float r, float scale, vec3 n_hat,
                       uint row) {
    vec3 rel = edge_velocity - x_velocity;
    if (rel == vec3(0.0)) {
        return;
    }
    vec3 v_dir = (rel - om * dot3(om, rel)) / r;
    grad_rows[row + at] += scale * dot3(v_dir, n_hat);
}

// Whether the light-side estimator (the host's shadow_boundary) samples the direct shadows of moving edges seen at
// vertex k of a camera path: the camera's own hits and the vertices after them.
bool light_side_vertex(uint k) {
    return k <= 1u;
}

void secondary_boundary(vec3 delta, uint seed, uint pixel, uint sample_, uint count, uint row) {
    if (moving_edges == 0u) {
        return;
    }
    vec3 prev_p = rec_origin;
    for (uint k = 0u; k < rec_count; k++) {
        RecordedVertex v = rec_vertices[k];
        TriangleGeom tri = triangles[v.triangle];
        vec3 p = tri.v0 + tri.e1 * v.u + tri.e2 * v.v;
        vec3 incoming = k == 0u ? rec_dir : normalize3(p - prev_p);
        prev_p = p;
        // Only vertices that scatter (the primal stops before the last allowed vertex).
        if (k + 1u >= fp.max_depth) {
            break;
        }
        SurfacePoint sp = surface_point(v.triangle, v.u, v.v, incoming);
        vec3 wi = to_local(sp, -incoming);
        FrameParams sub_fp = fp;
        sub_fp.max_depth = fp.max_depth - (k + 1u);
        sub_fp.rr_depth = fp.rr_depth > k + 1u ? fp.rr_depth - (k + 1u) : 0u;
        vec3 a = delta * v.throughput;
        if (has_horizon_jump(v.triangle)) {
            uint turn_count = 0u;
            for (uint j = 0u; j < active_count; j++) {
                uint at;
                Tangent tg = active_tangent(j, at);
                vec3 dn = face_normal_velocity(v.triangle, tg, sp.ng);
                if (dn != vec3(0.0)) {
                    turn_at[turn_count] = at;
                    turn_dn[turn_count] = dn;
                    turn_count += 1u;
                }
            }
            if (turn_count > 0u) {
                horizon_boundary(sp, wi, a, sub_fp, seed ^ HORIZON_SEED, pixel, sample_ * 4096u + k * 64u, count,
                                 turn_count, row);
            }
        }
        // A vertex moves when its triangle or any earlier vertex does (ray form); then every edge moves relative
        // to it, else only the moving ones.
        bool x_moves = false;
        for (uint j = 0u; j < active_count; j++) {
            x_moves = x_moves || replay_velocity[j * MAX_RECORD_DEPTH + k] != vec3(0.0);
        }
        // Where the side paths end at their first hits (only emission left) and the light-side estimator owns
        // what moving edges change there, only static edges are left to sample (when x moves).
        bool light_side = light_side_vertex(k);
        bool moving_left = light_side && sub_fp.max_depth <= 1u && moving_emits == 0u;
        float wm = moving_left ? 0.0 : edge_tree_root_importance(moving_root, sp.p, sp.ng);
        float ws = x_moves ? edge_tree_root_importance(static_root, sp.p, sp.ng) : 0.0;
        if (isnan(wm + ws) || wm + ws <= 0.0) {
            continue;
        }
        float p_moving = wm / (wm + ws);
        for (uint j = 0u; j < count; j++) {
            Sampler es = Sampler(seed ^ SECONDARY_SEED, pixel, sample_ * 4096u + k * 64u + j);
            double u = double(sampler_get(es, 0u));
            uint edge;
            float p_edge;
            bool drawn;
            if (u < double(p_moving)) {
                drawn = edge_tree_sample(moving_root, sp.p, sp.ng, u / double(p_moving), edge, p_edge);
                p_edge = p_edge * p_moving;
            } else {
                double um = min((u - double(p_moving)) / (1.0LF - double(p_moving)), 1.0LF - 2.220446049250313e-16LF);
                drawn = edge_tree_sample(static_root, sp.p, sp.ng, um, edge, p_edge);
                p_edge = p_edge * (1.0 - p_moving);
            }
            if (!drawn || isnan(p_edge) || p_edge <= 0.0) {
                continue;
            }
            MeshEdge e = mesh_edge(edge);
            float t = sampler_get(es, 1u);
            vec3 q = e.a + (e.b - e.a) * t;
            vec3 to = q - sp.p;
            float r = length3(to);
            if (isnan(r) || r <= 0.0) {
                continue;
            }
            vec3 om = to / r;
            vec3 ab = e.b - e.a;
            vec3 tau = (ab - om * dot3(om, ab)) / r; // dω/dt along the edge
            vec3 n_hat = cross3(om, tau);
            float n_len = length3(n_hat);
            if (isnan(n_len) || n_len <= 0.0) {
                continue;
            }
            n_hat = n_hat / n_len;
            // An edge point hidden from x has both sides see the occluder: no jump, one shadow ray.
            vec3 o = offset_origin(sp.p, sp.ng, om);
            if (trace_occluded(o, om, length3(q - o) * (1.0 - HIDDEN_MARGIN))) {
                continue;
            }
            // The emitted part of the side paths' first hits is the light-side estimator's here.
            bool leave_emission = light_side && e.light_side;
            vec3 jump = vec3(0.0);
            for (int side = 0; side < 2; side++) {
                float sign_ = side == 0 ? -1.0 : 1.0;
                vec3 w = normalize3(om + n_hat * (sign_ * SECONDARY_SIDE_EPS));
                vec3 f = bsdf_eval(sp.bsdf, wi, to_local(sp, w));
                if (f == vec3(0.0)) {
                    continue;
                }
                rec_enabled = false;
                PathSample ls = trace_from(sub_fp, es, offset_origin(sp.p, sp.ng, w), w);
                vec3 l = leave_emission ? ls.radiance - ls.first_emission : ls.radiance;
                rec_enabled = true;
                jump += (side == 0 ? 1.0 : -1.0) * (f * l);
            }
            if (jump == vec3(0.0)) {
                continue;
            }
            float scale = dot3(a, jump) * length3(tau) / (p_edge * float(count));
            // Entries that move x or the edge point: the velocity of the edge point (a material point, at weight t
            // of its second end) relative to x (a sliding ray-form vertex). First the active ones...
            for (uint j = 0u; j < active_count; j++) {
                uint at;
                Tangent tg = active_tangent(j, at);
                vec3 edge_velocity = vec3(0.0);
                if (tg.object == e.object && tg.vertex == NONE) {
                    edge_velocity = affine_velocity_at(tg.field, q);
                } else if (tg.object == e.object) {
                    float b = (e.end0 == tg.vertex ? 1.0 - t : 0.0) + (e.end1 == tg.vertex ? t : 0.0);
                    edge_velocity = b == 0.0 ? vec3(0.0) : tg.vertex_velocity * b;
                }
                edge_sample_share(at, edge_velocity, replay_velocity[j * MAX_RECORD_DEPTH + k], om, r, scale, n_hat, row);
            }
            // ...then those of the edge's object the path does not touch.
            for (uint i = 0u; i < pose_entry_count; i++) {
                PoseEntry entry = pose_entry(i);
                if (entry.object == e.object && active_slot(i, NONE, 0u) == NONE) {
                    edge_sample_share(entry.at, affine_velocity_at(entry.field, q), vec3(0.0), om, r, scale, n_hat, row);
                } else if (entry.object == (e.object | VERTEX_BLOCK)) {
                    for (uint end = 0u; end < 2u; end++) {
                        uint id = end == 0u ? e.end0 : e.end1;
                        float b = end == 0u ? 1.0 - t : t;
                        for (uint axis = 0u; axis < 3u; axis++) {
                            if (active_slot(i, id, axis) != NONE || b == 0.0) {
                                continue;
                            }
                            edge_sample_share(entry.at + 3u * id + axis, vertex_axis(entry, axis) * b, vec3(0.0), om, r,
                                              scale, n_hat, row);
                        }
                    }
                }
            }
        }
    }
}

#endif
