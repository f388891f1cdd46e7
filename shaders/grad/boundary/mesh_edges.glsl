// Welded mesh edges as the GPU reads them (SecondaryEdges::gpu_words, MESH_EDGE_WORDS an edge): endpoints,
// object, whether two faces meet there, whether that is a shading crease and whether its shadows' emitted part
// belongs to the light-side estimator, the faces' normals, the edge's
// strength (precomputed on the host) and the welded ids of its ends. The including kernel declares the buffer sec_edge_words (uint).
// Rust twin: psdr/src/grad/boundary/mesh_edges.rs (MeshEdge::is_silhouette_from).
// GLSL only: mesh_edge, edge_vec3 (unpack an edge from its words).
#ifndef PSDR_MESH_EDGES_GLSL
#define PSDR_MESH_EDGES_GLSL
#include "render/vec_math.glsl"

const uint MESH_EDGE_WORDS = 20u;

struct MeshEdge {
    vec3 a;
    uint object;
    vec3 b;
    bool two_faces;
    bool crease;
    vec3 n1;
    float strength;
    vec3 n2;
    // The welded ids of the edge's ends.
    uint end0;
    uint end1;
    // Seen from vertices light_side_vertex accepts, the emitted part of its jump is the light-side shadow estimator's
    // (SecondaryEdges::leaves_emission).
    bool light_side;
};

vec3 edge_vec3(uint at) {
    return vec3(uintBitsToFloat(sec_edge_words[at]), uintBitsToFloat(sec_edge_words[at + 1u]),
                uintBitsToFloat(sec_edge_words[at + 2u]));
}

MeshEdge mesh_edge(uint i) {
    uint w = i * MESH_EDGE_WORDS;
    uint flags = sec_edge_words[w + 7u];
    return MeshEdge(edge_vec3(w), sec_edge_words[w + 3u], edge_vec3(w + 4u), (flags & 1u) != 0u, (flags & 2u) != 0u,
                    edge_vec3(w + 8u), uintBitsToFloat(sec_edge_words[w + 11u]), edge_vec3(w + 12u),
                    sec_edge_words[w + 15u], sec_edge_words[w + 16u], (flags & 4u) != 0u);
}

// One face (a border) or several (non-manifold): always a silhouette; two: when they face x differently.
bool mesh_edge_is_silhouette_from(MeshEdge e, vec3 x) {
    if (!e.two_faces) {
        return true;
    }
    return (dot3(e.n1, x - e.a) > 0.0) != (dot3(e.n2, x - e.a) > 0.0);
}

#endif
