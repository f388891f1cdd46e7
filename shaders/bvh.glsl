// Ray-scene intersection: stack-based BVH2 traversal and Moller-Trumbore triangles.
// Rust twin: psdr/src/render/bvh.rs (same function names, same order of operations).
#ifndef PSDR_BVH_GLSL
#define PSDR_BVH_GLSL
#include "scene_buffers.glsl"
#include "vec_math.glsl"

const uint BVH_STACK_SIZE = 64u;
const float MIN_DIR = 1e-12;

struct Hit {
    float t;
    float u;
    float v;
    uint triangle;
};

float safe_inverse_1(float x) {
    return abs(x) < MIN_DIR ? 1.0 / copysign(MIN_DIR, x) : 1.0 / x;
}

vec3 safe_inverse(vec3 d) {
    return vec3(safe_inverse_1(d.x), safe_inverse_1(d.y), safe_inverse_1(d.z));
}

float intersect_aabb(BvhNode node, vec3 origin, vec3 inv_dir, float t_max) {
    vec3 t1 = (node.min_ - origin) * inv_dir;
    vec3 t2 = (node.max_ - origin) * inv_dir;
    float t_near = max(max_element(vmin3(t1, t2)), 0.0);
    float t_far = min(min_element(vmax3(t1, t2)), t_max);
    if (t_near <= t_far) {
        return t_near;
    } else {
        return INFINITY;
    }
}

// Returns false on a miss; (t, u, v) otherwise. Both faces are hit.
bool intersect_triangle(TriangleGeom tri, vec3 origin, vec3 dir, out vec3 tuv) {
    vec3 e1 = tri.e1;
    vec3 e2 = tri.e2;
    vec3 p = cross3(dir, e2);
    float det = dot3(e1, p);
    float inv_det = 1.0 / det;
    vec3 s = origin - tri.v0;
    float u = dot3(s, p) * inv_det;
    vec3 q = cross3(s, e1);
    float v = dot3(dir, q) * inv_det;
    float t = dot3(e2, q) * inv_det;
    // The early-outs, evaluated together (one hard-to-predict branch instead of four on the CPU twin).
    bool ok = (det != 0.0) && !isinf(det) && !isnan(det) && (u >= 0.0 && u <= 1.0) && !(v < 0.0) && !(u + v > 1.0);
    tuv = vec3(t, u, v);
    return ok;
}

// Closest hit with t in (0, t_max); best.triangle == NONE on a miss.
Hit trace_closest(vec3 origin, vec3 dir, float t_max) {
    vec3 inv_dir = safe_inverse(dir);
    Hit best = Hit(t_max, 0.0, 0.0, NONE);
    if (intersect_aabb(nodes[0], origin, inv_dir, best.t) == INFINITY) {
        return best;
    }
    // Each stack entry keeps the entry distance of its box, computed when its parent was visited: a popped
    // node is skipped when a hit found since then is nearer (the same test as re-intersecting its box).
    // The nearer child of an inner node is visited next without a round trip through the stack (its entry
    // distance is at most best.t, so the pop test would pass).
    uint stack[BVH_STACK_SIZE];
    float stack_t[BVH_STACK_SIZE];
    uint sp = 0u;
    uint node_index = 0u;
    while (true) {
        BvhNode node = nodes[node_index];
        if (node.prim_count > 0u) {
            for (uint i = node.first_index; i < node.first_index + node.prim_count; i++) {
                vec3 tuv;
                if (intersect_triangle(triangles[i], origin, dir, tuv)) {
                    if (tuv.x > 0.0 && tuv.x < best.t) {
                        best = Hit(tuv.x, tuv.y, tuv.z, i);
                    }
                }
            }
        } else {
            // Visit the nearer child first, the farther one after it (from the stack).
            uint l = node.first_index;
            uint r = l + 1u;
            float tl = intersect_aabb(nodes[l], origin, inv_dir, best.t);
            float tr = intersect_aabb(nodes[r], origin, inv_dir, best.t);
            uint near_ = tl <= tr ? l : r;
            uint far_ = tl <= tr ? r : l;
            float t_near = tl <= tr ? tl : tr;
            float t_far = tl <= tr ? tr : tl;
            if (t_far != INFINITY) {
                stack[sp] = far_;
                stack_t[sp] = t_far;
                sp += 1u;
            }
            if (t_near != INFINITY) {
                node_index = near_;
                continue;
            }
        }
        // Pop the next node that a hit found since it was pushed does not rule out.
        bool popped = false;
        while (sp > 0u) {
            sp -= 1u;
            if (stack_t[sp] <= best.t) {
                node_index = stack[sp];
                popped = true;
                break;
            }
        }
        if (!popped) {
            return best;
        }
    }
    return best;
}

// True when anything blocks the segment (0, t_max).
bool trace_occluded(vec3 origin, vec3 dir, float t_max) {
    vec3 inv_dir = safe_inverse(dir);
    if (intersect_aabb(nodes[0], origin, inv_dir, t_max) == INFINITY) {
        return false;
    }
    // Only nodes whose box the segment enters are visited or pushed, so a popped node needs no second box test.
    uint stack[BVH_STACK_SIZE];
    uint sp = 0u;
    uint node_index = 0u;
    while (true) {
        BvhNode node = nodes[node_index];
        if (node.prim_count > 0u) {
            for (uint i = node.first_index; i < node.first_index + node.prim_count; i++) {
                vec3 tuv;
                if (intersect_triangle(triangles[i], origin, dir, tuv)) {
                    if (tuv.x > 0.0 && tuv.x < t_max) {
                        return true;
                    }
                }
            }
        } else {
            // Test both child boxes here; visit the left one next if the segment enters it, push the right one
            // if it enters that too (any order finds a blocker).
            uint l = node.first_index;
            float tl = intersect_aabb(nodes[l], origin, inv_dir, t_max);
            float tr = intersect_aabb(nodes[l + 1u], origin, inv_dir, t_max);
            if (tl != INFINITY) {
                if (tr != INFINITY) {
                    stack[sp] = l + 1u;
                    sp += 1u;
                }
                node_index = l;
                continue;
            }
            if (tr != INFINITY) {
                node_index = l + 1u;
                continue;
            }
        }
        if (sp == 0u) {
            return false;
        }
        sp -= 1u;
        node_index = stack[sp];
    }
    return false;
}

#endif
