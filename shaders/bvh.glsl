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
    if (det == 0.0 || isinf(det) || isnan(det)) {
        return false;
    }
    float inv_det = 1.0 / det;
    vec3 s = origin - tri.v0;
    float u = dot3(s, p) * inv_det;
    if (!(u >= 0.0 && u <= 1.0)) {
        return false;
    }
    vec3 q = cross3(s, e1);
    float v = dot3(dir, q) * inv_det;
    if (v < 0.0 || u + v > 1.0) {
        return false;
    }
    float t = dot3(e2, q) * inv_det;
    tuv = vec3(t, u, v);
    return true;
}

// Closest hit with t in (0, t_max); best.triangle == NONE on a miss.
Hit trace_closest(vec3 origin, vec3 dir, float t_max) {
    vec3 inv_dir = safe_inverse(dir);
    Hit best = Hit(t_max, 0.0, 0.0, NONE);
    // Each stack entry keeps the entry distance of its box, computed when its parent was visited: a popped
    // node is skipped when a hit found since then is nearer (the same test as re-intersecting its box).
    uint stack[BVH_STACK_SIZE];
    float stack_t[BVH_STACK_SIZE];
    uint sp = 1u;
    stack[0] = 0u;
    stack_t[0] = intersect_aabb(nodes[0], origin, inv_dir, best.t);
    if (stack_t[0] == INFINITY) {
        return best;
    }
    while (sp > 0u) {
        sp -= 1u;
        if (stack_t[sp] > best.t) {
            continue;
        }
        BvhNode node = nodes[stack[sp]];
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
            // Visit the nearer child first: push it last.
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
                stack[sp] = near_;
                stack_t[sp] = t_near;
                sp += 1u;
            }
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
    // Only nodes whose box the segment enters are pushed, so a popped node needs no second box test.
    uint stack[BVH_STACK_SIZE];
    uint sp = 1u;
    stack[0] = 0u;
    while (sp > 0u) {
        sp -= 1u;
        BvhNode node = nodes[stack[sp]];
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
            // Test both child boxes here and push only those the segment enters (any order finds a blocker).
            uint l = node.first_index;
            if (intersect_aabb(nodes[l], origin, inv_dir, t_max) != INFINITY) {
                stack[sp] = l;
                sp += 1u;
            }
            if (intersect_aabb(nodes[l + 1u], origin, inv_dir, t_max) != INFINITY) {
                stack[sp] = l + 1u;
                sp += 1u;
            }
        }
    }
    return false;
}

#endif
