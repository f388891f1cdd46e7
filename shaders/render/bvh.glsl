// Ray-scene intersection: a compressed wide BVH (8 children per node, Ylitie et al. 2017, built by obvhs) and
// Moller-Trumbore triangles. Rust twin: psdr/src/render/bvh.rs (same function names, same order of operations;
// the Rust twin's `Traversal` methods are the traversal_* functions here, on invocation-private globals).
// GLSL only: safe_inverse_1 (Rust inverts the three lanes at once), node_byte (Rust indexes its [u8; 8] fields).
#ifndef PSDR_BVH_GLSL
#define PSDR_BVH_GLSL
#include "scene_buffers.glsl"
#include "vec_math.glsl"

const uint BVH_STACK_SIZE = 32u;
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

// 7 minus the ray's octant in every byte: XORed with a child's slot it gives the child's traversal priority.
uint octant_inv4(vec3 dir) {
    return (dir.x < 0.0 ? 0u : 0x04040404u) | (dir.y < 0.0 ? 0u : 0x02020202u) | (dir.z < 0.0 ? 0u : 0x01010101u);
}

// Index of the highest set bit (x != 0).
uint find_msb(uint x) {
    return uint(findMSB(x));
}

struct NodeRay {
    vec3 origin;
    vec3 inv_dir;
    uint oct_inv4;
};

NodeRay node_ray(vec3 origin, vec3 dir) {
    return NodeRay(origin, safe_inverse(dir), octant_inv4(dir));
}

// Byte i of an [u8; 8] field (little endian, as Rust stores it).
uint node_byte(uvec2 v, uint i) {
    return (v[i >> 2u] >> ((i & 3u) * 8u)) & 0xffu;
}

// The node's grid: child box corner = p + q * scale per axis, scale = 2^(e - 127) (exact power of two).
vec3 node_scale(BvhNode node) {
    return vec3(uintBitsToFloat((node.e_imask & 0xffu) << 23u), uintBitsToFloat(((node.e_imask >> 8u) & 0xffu) << 23u),
                uintBitsToFloat(((node.e_imask >> 16u) & 0xffu) << 23u));
}

// The hit-mask bits of a child slot the ray enters: one bit at 24 + priority for an inner child, the leaf's
// triangles (unary count at their offset) for a leaf, nothing for an empty slot.
uint child_hit_bits(uint meta, uint oct_inv4) {
    bool inner = (meta & (meta << 1u) & 0x10u) != 0u; // inner children are 0b001_11sss (24 + slot)
    uint bit_index = inner ? ((meta ^ (oct_inv4 & 0xffu)) & 0x1fu) : (meta & 0x1fu);
    return ((meta >> 5u) & 0x7u) << bit_index;
}

// Slab test of child slot i: entry <= exit within [0, t_max), on the node's grid.
bool child_entered(BvhNode node, uint i, vec3 grid_inv, vec3 grid_origin, float t_max) {
    vec3 lo = vec3(float(node_byte(node.child_min_x, i)), float(node_byte(node.child_min_y, i)),
                   float(node_byte(node.child_min_z, i)));
    vec3 hi = vec3(float(node_byte(node.child_max_x, i)), float(node_byte(node.child_max_y, i)),
                   float(node_byte(node.child_max_z, i)));
    vec3 t1 = lo * grid_inv + grid_origin;
    vec3 t2 = hi * grid_inv + grid_origin;
    float t_near = max(max_element(vmin3(t1, t2)), 0.0);
    float t_far = min(min_element(vmax3(t1, t2)), t_max);
    return t_near <= t_far;
}

// The node's hit mask for a ray within [0, t_max): bits 24-31 the inner children it enters (by priority),
// bits 0-23 the triangles of the leaf children it enters.
uint intersect_node(BvhNode node, NodeRay ray, float t_max) {
    vec3 grid_inv = node_scale(node) * ray.inv_dir;
    vec3 grid_origin = (node.p - ray.origin) * ray.inv_dir;
    uint mask = 0u;
    for (uint i = 0u; i < 8u; i++) {
        if (child_entered(node, i, grid_inv, grid_origin, t_max)) {
            mask |= child_hit_bits(node_byte(node.child_meta, i), ray.oct_inv4);
        }
    }
    return mask;
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

// Traversal state (the Rust twin's `Traversal`): the group being expanded, the triangles still to test, and the
// stack of pending groups. A group is (index of the node's first child node, hit bits: inner children in 24-31,
// imask in 0-7); a triangle group is (first triangle, bits 0-23). Invocation-private: one traversal at a time.
uvec2 traversal_stack[BVH_STACK_SIZE];
uint traversal_sp;
uvec2 traversal_node_group;
uvec2 traversal_triangle_group;

void traversal_new() {
    // The root is the only child (slot 0 of a virtual parent whose first child is node 0).
    traversal_sp = 0u;
    traversal_node_group = uvec2(0u, 0x80000000u);
    traversal_triangle_group = uvec2(0u);
}

// Expands the next inner child of the current group: its node's hit mask becomes the new node and triangle
// groups (the rest of the old group waits on the stack). Returns false when traversal is over.
bool traversal_step(NodeRay ray, float t_max) {
    if ((traversal_node_group.y & 0xff000000u) != 0u) {
        uint hits = traversal_node_group.y;
        uint child_bit = find_msb(hits);
        traversal_node_group.y &= ~(1u << child_bit);
        if ((traversal_node_group.y & 0xff000000u) != 0u) {
            traversal_stack[traversal_sp] = traversal_node_group;
            traversal_sp += 1u;
        }
        // Priority back to slot, then the slot's rank among the inner slots (they are stored in slot order).
        uint slot = (child_bit - 24u) ^ (ray.oct_inv4 & 0xffu);
        uint rank = uint(bitCount(hits & ~(0xffffffffu << slot)));
        BvhNode node = nodes[traversal_node_group.x + rank];
        uint mask = intersect_node(node, ray, t_max);
        traversal_node_group = uvec2(node.child_base_idx, (mask & 0xff000000u) | (node.e_imask >> 24u));
        traversal_triangle_group = uvec2(node.primitive_base_idx, mask & 0x00ffffffu);
    } else {
        traversal_node_group = uvec2(0u);
    }
    if (traversal_triangle_group.y == 0u && (traversal_node_group.y & 0xff000000u) == 0u) {
        if (traversal_sp == 0u) {
            return false;
        }
        traversal_sp -= 1u;
        traversal_node_group = traversal_stack[traversal_sp];
    }
    return true;
}

// The next triangle to test, if the current triangle group has one.
bool traversal_next_triangle(out uint ti) {
    if (traversal_triangle_group.y == 0u) {
        return false;
    }
    uint k = find_msb(traversal_triangle_group.y);
    traversal_triangle_group.y &= ~(1u << k);
    ti = traversal_triangle_group.x + k;
    return true;
}

// Closest hit with t in (0, t_max); best.triangle == NONE on a miss.
Hit trace_closest(vec3 origin, vec3 dir, float t_max) {
    NodeRay ray = node_ray(origin, dir);
    Hit best = Hit(t_max, 0.0, 0.0, NONE);
    traversal_new();
    while (true) {
        uint ti;
        while (traversal_next_triangle(ti)) {
            vec3 tuv;
            if (intersect_triangle(triangles[ti], origin, dir, tuv)) {
                if (tuv.x > 0.0 && tuv.x < best.t) {
                    best = Hit(tuv.x, tuv.y, tuv.z, ti);
                }
            }
        }
        if (!traversal_step(ray, best.t)) {
            return best;
        }
    }
    return best;
}

// True when anything blocks the segment (0, t_max).
bool trace_occluded(vec3 origin, vec3 dir, float t_max) {
    NodeRay ray = node_ray(origin, dir);
    traversal_new();
    while (true) {
        uint ti;
        while (traversal_next_triangle(ti)) {
            vec3 tuv;
            if (intersect_triangle(triangles[ti], origin, dir, tuv)) {
                if (tuv.x > 0.0 && tuv.x < t_max) {
                    return true;
                }
            }
        }
        if (!traversal_step(ray, t_max)) {
            return false;
        }
    }
    return false;
}

#endif
