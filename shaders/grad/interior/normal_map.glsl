// Normal mapping in dual numbers: the tangent frame follows a moving triangle and the map value slides with the
// uv; and the turn of a shading normal toward the viewer, as render/shading.glsl's surface_point does.
// Rust twin: psdr/src/grad/interior/normal_map.rs (map_normal_dual, turn_toward_viewer).
#ifndef PSDR_NORMAL_MAP_GLSL
#define PSDR_NORMAL_MAP_GLSL
#include "render/shading.glsl"
#include "grad/ad/dual.glsl"

// The uv differences along the triangle's edges (constant per triangle).
struct UvFrame {
    D duv1[2];
    D duv2[2];
    bool has_uvs;
};

// The mapped shading normal from the tangent-space texel; false (no normal) where the map would turn the normal
// below the geometric one.
bool map_normal_dual(D3 e1, D3 e2, D3 ns, vec3 ng, UvFrame f, D3 texel, out D3 mapped) {
    D u1 = f.duv1[0];
    D v1 = f.duv1[1];
    D u2 = f.duv2[0];
    D v2 = f.duv2[1];
    D det = d_sub(d_mul(u1, v2), d_mul(v1, u2));
    bool framed = det.v != 0.0 && f.has_uvs;
    D3 tangent = framed ? d3_mul(d3_sub(d3_mul(e1, v2), d3_mul(e2, v1)), d_div(d_c(1.0), det)) : d3_c(orthogonal(ns.v));
    tangent = d3_sub(tangent, d3_mul(ns, d3_dot(ns, tangent)));
    tangent = length3(tangent.v) > 1e-12 ? d3_normalize(tangent) : d3_c(orthogonal(ns.v));
    D3 bitangent = d3_cross(ns, tangent);
    if (framed) {
        vec3 dpdv = (e2.v * u1.v - e1.v * u2.v) * (1.0 / det.v);
        if (dot3(bitangent.v, dpdv) < 0.0) {
            bitangent = d3_neg(bitangent);
        }
    }
    D3 m = d3_sub(d3_mul_c(texel, vec3(2.0)), d3_c(vec3(1.0)));
    D3 n = d3_add(d3_add(d3_mul(tangent, D(m.v.x, m.d.x)), d3_mul(bitangent, D(m.v.y, m.d.y))), d3_mul(ns, D(m.v.z, m.d.z)));
    if (length3(n.v) > 0.0 && dot3(n.v, ng) > 0.0) {
        mapped = d3_normalize(n);
        return true;
    }
    return false;
}

D3 turn_toward_viewer(D3 ns, vec3 dir) {
    D c = d3_dot(ns, d3_c(-dir));
    if (c.v < TERMINATOR_COS) {
        return d3_normalize(d3_sub(ns, d3_mul(d3_c(dir), d_sub(d_c(TERMINATOR_COS), c))));
    }
    return ns;
}

#endif
