// The edge tree as the GPU reads it (built on the host, EdgeTree::append_gpu_words): culling of whole subtrees
// that cannot hold a silhouette or crease seen from x, importance (total edge length over distance) and the
// stochastic descent that draws one edge in the tree's depth. The descent rescales one uniform number per
// level, in double precision as the twin does (the device must support shaderFloat64). The including kernel
// declares the buffers tree_words (uint, NODE_WORDS a node) and edge_order (uint), and the function
//     float edge_weight(uint e, vec3 x, vec3 ng)
// (the exact weight of edge e from x, the closure the Rust twin takes).
// Rust twin: psdr/src/grad/boundary/edge_tree.rs (max_dot, min_dot, EdgeTree::culled, EdgeTree::importance,
// EdgeTree::root_importance, EdgeTree::sample).
// GLSL only: edge_node, tree_vec3 (unpack a node from its words).
#ifndef PSDR_EDGE_TREE_GLSL
#define PSDR_EDGE_TREE_GLSL
#include "render/layout.glsl"
#include "render/vec_math.glsl"

const uint NODE_WORDS = 16u;
// The most edges in one leaf.
const uint LEAF_EDGES = 8u;

struct EdgeNode {
    vec3 lo;
    uint first;
    vec3 hi;
    uint prim_count;
    vec3 axis;
    float spread;
    bool boundary;
    bool crease;
    float length_;
};

vec3 tree_vec3(uint at) {
    return vec3(uintBitsToFloat(tree_words[at]), uintBitsToFloat(tree_words[at + 1u]), uintBitsToFloat(tree_words[at + 2u]));
}

EdgeNode edge_node(uint i) {
    uint w = i * NODE_WORDS;
    uint flags = tree_words[w + 12u];
    return EdgeNode(tree_vec3(w), tree_words[w + 3u], tree_vec3(w + 4u), tree_words[w + 7u], tree_vec3(w + 8u),
                    uintBitsToFloat(tree_words[w + 11u]), (flags & 1u) != 0u, (flags & 2u) != 0u,
                    uintBitsToFloat(tree_words[w + 13u]));
}

// max over the box of a·p.
float max_dot(vec3 a, vec3 lo, vec3 hi) {
    vec3 m = max(a * lo, a * hi);
    return m.x + m.y + m.z;
}

// min over the box of a·p.
float min_dot(vec3 a, vec3 lo, vec3 hi) {
    vec3 m = min(a * lo, a * hi);
    return m.x + m.y + m.z;
}

bool edge_tree_culled(uint i, vec3 x, vec3 ng) {
    EdgeNode n = edge_node(i);
    float slack = 1e-5 * (1.0 + max_element(abs(x)));
    if (dot3(ng, x) > max_dot(ng, n.lo, n.hi) + slack) {
        return true;
    }
    float reach = length3(max(abs(x - n.lo), abs(x - n.hi))) * n.spread;
    float lower = dot3(n.axis, x) - max_dot(n.axis, n.lo, n.hi);
    float upper = dot3(n.axis, x) - min_dot(n.axis, n.lo, n.hi);
    bool all_back = upper + reach < -slack;
    bool all_front = lower - reach > slack;
    return (all_back && !n.boundary) || (all_front && !n.boundary && !n.crease);
}

float edge_tree_importance(uint i, vec3 x, vec3 ng) {
    if (edge_tree_culled(i, x, ng)) {
        return 0.0;
    }
    EdgeNode n = edge_node(i);
    float outside = length3(max(max(n.lo - x, x - n.hi), vec3(0.0)));
    return n.length_ / max(max(outside, 0.25 * length3(n.hi - n.lo)), 1e-6);
}

float edge_tree_root_importance(uint root, vec3 x, vec3 ng) {
    return root == NONE ? 0.0 : edge_tree_importance(root, x, ng);
}

float edge_weight(uint e, vec3 x, vec3 ng);

// One edge drawn from the tree at `root` with probability `prob` (children by importance, the leaf's edges by
// edge_weight); false when nothing can be drawn.
bool edge_tree_sample(uint root, vec3 x, vec3 ng, double u, out uint edge, out float prob) {
    if (root == NONE) {
        return false;
    }
    uint i = root;
    double p = 1.0LF;
    while (true) {
        EdgeNode n = edge_node(i);
        if (n.prim_count > 0u) {
            // Each edge's weight once (the weight is the costly part of a draw).
            double w[LEAF_EDGES];
            double total = 0.0LF;
            for (uint j = 0u; j < n.prim_count; j++) {
                w[j] = double(edge_weight(edge_order[n.first + j], x, ng));
                total += w[j];
            }
            if (isnan(total) || total <= 0.0LF) {
                return false;
            }
            double acc = 0.0LF;
            bool found = false;
            uint last_e = 0u;
            double last_w = 0.0LF;
            for (uint j = 0u; j < n.prim_count; j++) {
                if (w[j] <= 0.0LF) {
                    continue;
                }
                found = true;
                last_e = edge_order[n.first + j];
                last_w = w[j];
                acc += w[j];
                if (u * total < acc) {
                    break;
                }
            }
            if (!found) {
                return false;
            }
            edge = last_e;
            prob = float(p * last_w / total);
            return true;
        }
        uint l = n.first;
        uint r = n.first + 1u;
        double wl = double(edge_tree_importance(l, x, ng));
        double wr = double(edge_tree_importance(r, x, ng));
        if (isnan(wl + wr) || wl + wr <= 0.0LF) {
            return false;
        }
        double pl = wl / (wl + wr);
        if (u < pl) {
            i = l;
            p = p * pl;
            u = u / pl;
        } else {
            i = r;
            p = p * (1.0LF - pl);
            u = min((u - pl) / (1.0LF - pl), 1.0LF - 2.220446049250313e-16LF);
        }
    }
    return false;
}

#endif
