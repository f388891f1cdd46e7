// Normal mapping in dual numbers: the tangent frame follows a moving triangle and the map value slides with the
// uv; the turn of a shading normal toward the viewer, as render/shading.glsl's surface_point does; and the
// reverse mode of a vertex's BSDF terms through the mapping to the map's channels and the uv transform.
// Rust twin: psdr/src/grad/interior/normal_map.rs (map_normal_dual, turn_toward_viewer, MapInputs::at,
// normal_map_jacobian, normal_map_uv_tangents, bsdf_normal_adjoint).
// GLSL only: map_inputs_frame (MapInputs::frame for a transform given as the uv rows and their derivative).
#ifndef PSDR_NORMAL_MAP_GLSL
#define PSDR_NORMAL_MAP_GLSL
#include "render/shading.glsl"
#include "render/texture.glsl"
#include "grad/ad/dual.glsl"
#include "grad/ad/bsdf_dual.glsl"
#include "grad/ad/dual_texture.glsl"

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

// What map_normal_dual needs at a hit on a normal-mapped triangle, rebuilt as surface_point builds it.
struct MapInputs {
    SurfacePoint sp;
    MaterialGpu mat;
    TextureGpu map;
    D3 e1;
    D3 e2;
    // The unmapped shading normal and the geometric one, both flipped toward the incoming ray.
    D3 ns;
    vec3 ng;
    vec2 uv0;
    vec2 uv1;
    vec2 uv2;
    vec2 uv_hit;
    vec2 uvt;
    bool has_uvs;
    vec3 dir;
};

bool map_inputs_at(uint ti, float u, float v, vec3 incoming, out MapInputs h) {
    TriangleGeom tri = triangles[ti];
    MaterialGpu mat = materials[tri.material];
    if (mat.normal_tex == NONE) {
        return false;
    }
    TriangleShading sh = shading[ti];
    vec3 ng;
    vec3 ns;
    bool front;
    facing_normals(ti, u, v, incoming, ng, ns, front);
    float w = 1.0 - u - v;
    bool has_uvs = (sh.flags & SHADING_HAS_UVS) != 0u;
    vec2 uv_hit = has_uvs ? sh.uv0 * w + sh.uv1 * u + sh.uv2 * v : vec2(u, v);
    h = MapInputs(surface_point(ti, u, v, incoming), mat, textures[mat.normal_tex], d3_c(tri.e1), d3_c(tri.e2), d3_c(ns),
                  ng, sh.uv0, sh.uv1, sh.uv2, uv_hit, apply_uv_transform(mat, uv_hit), has_uvs, incoming);
    return true;
}

// The uv frame with corner uvs transformed by the material's uv rows and, as tangents, by dm (columns dm0, dm1).
UvFrame map_inputs_frame(MapInputs h, vec2 dm0, vec2 dm1) {
    vec2 q0 = apply_uv_transform(h.mat, h.uv0);
    vec2 q1 = apply_uv_transform(h.mat, h.uv1);
    vec2 q2 = apply_uv_transform(h.mat, h.uv2);
    vec2 d0 = dm0 * h.uv0.x + dm1 * h.uv0.y;
    vec2 d1 = dm0 * h.uv1.x + dm1 * h.uv1.y;
    vec2 d2 = dm0 * h.uv2.x + dm1 * h.uv2.y;
    D duv1[2] = D[2](d_sub(D(q1.x, d1.x), D(q0.x, d0.x)), d_sub(D(q1.y, d1.y), D(q0.y, d0.y)));
    D duv2[2] = D[2](d_sub(D(q2.x, d2.x), D(q0.x, d0.x)), d_sub(D(q2.y, d2.y), D(q0.y, d0.y)));
    return UvFrame(duv1, duv2, h.has_uvs);
}

// The shading point and ∂n_s/∂c (columns: map channels r, g, b) at a hit; false where the map is not applied.
bool normal_map_jacobian(uint ti, float u, float v, vec3 incoming, out SurfacePoint sp, out mat3 jacobian) {
    MapInputs h;
    if (!map_inputs_at(ti, u, v, incoming, h)) {
        return false;
    }
    UvFrame frame = map_inputs_frame(h, vec2(0.0), vec2(0.0));
    vec3 texel = texture_sample_rgb(h.map, h.uvt);
    D3 r;
    D3 g;
    D3 b;
    if (!map_normal_dual(h.e1, h.e2, h.ns, h.ng, frame, D3(texel, vec3(1.0, 0.0, 0.0)), r)
        || !map_normal_dual(h.e1, h.e2, h.ns, h.ng, frame, D3(texel, vec3(0.0, 1.0, 0.0)), g)
        || !map_normal_dual(h.e1, h.e2, h.ns, h.ng, frame, D3(texel, vec3(0.0, 0.0, 1.0)), b)) {
        return false;
    }
    r = turn_toward_viewer(r, h.dir);
    g = turn_toward_viewer(g, h.dir);
    b = turn_toward_viewer(b, h.dir);
    sp = h.sp;
    jacobian = mat3(r.d, g.d, b.d);
    return true;
}

// ∂n_s/∂(uv scale x, uv scale y, uv rotation in degrees) at a hit on a normal-mapped surface.
void normal_map_uv_tangents(uint ti, float u, float v, vec3 incoming, vec2 scale, float rotation_deg, out vec3 dn[3]) {
    dn = vec3[3](vec3(0.0), vec3(0.0), vec3(0.0));
    MapInputs h;
    if (!map_inputs_at(ti, u, v, incoming, h)) {
        return;
    }
    float phi = rotation_deg * 0.017453292;
    float s = sin(phi);
    float c = cos(phi);
    float k = 0.017453292;
    // uv' = M uv + o with M = R(φ) diag(sx, sy); the columns of ∂M per parameter.
    vec2 col0[3] = vec2[3](vec2(c, s), vec2(0.0), vec2(-s * scale.x, c * scale.x) * k);
    vec2 col1[3] = vec2[3](vec2(0.0), vec2(-s, c), vec2(-c * scale.y, -s * scale.y) * k);
    for (int i = 0; i < 3; i++) {
        UvFrame frame = map_inputs_frame(h, col0[i], col1[i]);
        vec2 duvt = col0[i] * h.uv_hit.x + col1[i] * h.uv_hit.y;
        D r = dual_texture(h.map, h.uvt, duvt, 0u);
        D g = dual_texture(h.map, h.uvt, duvt, 1u);
        D b = dual_texture(h.map, h.uvt, duvt, 2u);
        D3 n;
        if (map_normal_dual(h.e1, h.e2, h.ns, h.ng, frame, D3(vec3(r.v, g.v, b.v), vec3(r.d, g.d, b.d)), n)) {
            dn[i] = turn_toward_viewer(n, h.dir).d;
        }
    }
}

// ∂(a · f(wi, wo))/∂n_s for the BSDF at sp (world directions; a weights the colour channels).
vec3 bsdf_normal_adjoint(SurfacePoint sp, vec3 wi, vec3 wo, vec3 a) {
    BsdfParamsD p = BsdfParamsD(d3_c(sp.bsdf.albedo), d_c(sp.bsdf.roughness), d_c(sp.bsdf.specular));
    return vec3(dot3(a, bsdf_eval_dual(p, D3(sp.ns, vec3(1.0, 0.0, 0.0)), d3_c(wi), d3_c(wo)).d),
                dot3(a, bsdf_eval_dual(p, D3(sp.ns, vec3(0.0, 1.0, 0.0)), d3_c(wi), d3_c(wo)).d),
                dot3(a, bsdf_eval_dual(p, D3(sp.ns, vec3(0.0, 0.0, 1.0)), d3_c(wi), d3_c(wo)).d));
}

#endif
