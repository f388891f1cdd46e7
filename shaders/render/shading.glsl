// From a ray hit to everything shading needs: position, normals (two-sided, normal-mapped), uv and the
// material's parameters at that point. Rust twin: psdr/src/render/shading.rs.
#ifndef PSDR_SHADING_GLSL
#define PSDR_SHADING_GLSL
#include "scene_buffers.glsl"
#include "vec_math.glsl"
#include "bsdf.glsl"
#include "texture.glsl"

struct SurfacePoint {
    vec3 p;
    vec3 ng;
    vec3 ns;
    vec3 tangent;
    vec3 bitangent;
    bool front;
    BsdfParams bsdf;
    vec2 uv;
    uint object;
    uint triangle;
};

vec3 to_local(SurfacePoint sp, vec3 v) {
    return vec3(dot3(v, sp.tangent), dot3(v, sp.bitangent), dot3(v, sp.ns));
}

vec3 to_world(SurfacePoint sp, vec3 v) {
    return sp.tangent * v.x + sp.bitangent * v.y + sp.ns * v.z;
}

// Any unit vector orthogonal to n (Duff et al. 2017 branchless basis).
vec3 orthogonal(vec3 n) {
    float sign_ = copysign(1.0, n.z);
    float a = -1.0 / (sign_ + n.z);
    float b = n.x * n.y * a;
    return vec3(1.0 + sign_ * n.x * n.x * a, sign_ * b, -sign_ * n.x);
}

vec2 apply_uv_transform(MaterialGpu m, vec2 uv) {
    return vec2(
        m.uv_row0.x * uv.x + m.uv_row0.y * uv.y + m.uv_row0.z,
        m.uv_row1.x * uv.x + m.uv_row1.y * uv.y + m.uv_row1.z);
}

// The cosine below which a viewer may not see a (normal-mapped or interpolated) shading normal.
const float TERMINATOR_COS = 0.01;

// Re-orthonormalises the tangent frame around a new shading normal, keeping the bitangent's handedness.
void reframe(vec3 ns, inout vec3 tangent, inout vec3 bitangent) {
    tangent = tangent - ns * dot3(ns, tangent);
    float tl = length3(tangent);
    tangent = tl > 1e-12 ? tangent / tl : orthogonal(ns);
    bool flip = dot3(bitangent, cross3(ns, tangent)) < 0.0;
    bitangent = cross3(ns, tangent);
    if (flip) {
        bitangent = -bitangent;
    }
}

// The geometric normal and the interpolated shading normal (before normal mapping) at barycentrics (u, v) of
// triangle ti, both flipped to the side dir arrives from, and whether that side is the front.
void facing_normals(uint ti, float u, float v, vec3 dir, out vec3 ng, out vec3 ns, out bool front) {
    TriangleShading sh = shading[ti];
    ng = sh.ng;
    float w = 1.0 - u - v;
    if ((sh.flags & SHADING_HAS_NORMALS) != 0u) {
        vec3 n = sh.n0 * w + sh.n1 * u + sh.n2 * v;
        float len = length3(n);
        ns = len > 0.0 ? n / len : ng;
    } else {
        ns = ng;
    }
    front = dot3(ng, dir) < 0.0;
    if (!front) {
        ng = -ng;
    }
    if (dot3(ns, ng) < 0.0) {
        ns = -ns;
    }
}

SurfacePoint surface_point(uint ti, float u, float v, vec3 dir) {
    TriangleGeom tri = triangles[ti];
    TriangleShading sh = shading[ti];
    MaterialGpu mat = materials[tri.material];
    vec3 e1 = tri.e1;
    vec3 e2 = tri.e2;
    vec3 p = tri.v0 + e1 * u + e2 * v;
    vec3 ng;
    vec3 ns;
    bool front;
    facing_normals(ti, u, v, dir, ng, ns, front);
    float w = 1.0 - u - v;
    vec2 uv0 = sh.uv0;
    vec2 uv1 = sh.uv1;
    vec2 uv2 = sh.uv2;
    bool has_uvs = (sh.flags & SHADING_HAS_UVS) != 0u;
    vec2 uv = has_uvs ? uv0 * w + uv1 * u + uv2 * v : vec2(u, v);
    vec2 uvt = apply_uv_transform(mat, uv);
    // The material's lookups first: they depend only on uv, so issued here their loads overlap the frame
    // arithmetic below instead of waiting behind it.
    vec3 albedo = mat.albedo_tex != NONE ? texture_sample_rgb(textures[mat.albedo_tex], uvt) : mat.albedo;
    float roughness = mat.roughness_tex != NONE ? texture_sample(textures[mat.roughness_tex], uvt, 0u) : mat.roughness;
    float specular = mat.specular_tex != NONE ? texture_sample(textures[mat.specular_tex], uvt, 0u) : mat.specular;
    vec3 normal_texel = mat.normal_tex != NONE ? texture_sample_rgb(textures[mat.normal_tex], uvt) : vec3(0.0);
    // Tangent along dp/du' of the transformed uv, so normal maps follow texture rotation.
    bool has_tangent = (sh.flags & SHADING_HAS_TANGENT) != 0u;
    vec3 tangent;
    if (has_tangent) {
        tangent = sh.dpdu;
    } else {
        tangent = orthogonal(ns);
    }
    tangent = tangent - ns * dot3(ns, tangent);
    float tl = length3(tangent);
    tangent = tl > 1e-12 ? tangent / tl : orthogonal(ns);
    vec3 bitangent = cross3(ns, tangent);
    if (has_tangent && dot3(bitangent, sh.dpdv) < 0.0) {
        bitangent = -bitangent;
    }
    bool bent = (sh.flags & SHADING_HAS_NORMALS) != 0u;
    if (mat.normal_tex != NONE) {
        vec3 m = normal_texel * 2.0 - vec3(1.0);
        vec3 n = tangent * m.x + bitangent * m.y + ns * m.z;
        float len = length3(n);
        if (len > 0.0 && dot3(n, ng) > 0.0) {
            ns = n / len;
            reframe(ns, tangent, bitangent);
            bent = true;
        }
    }
    // A shading normal that differs from the geometric one can face away from the viewer (normal maps,
    // interpolated normals near silhouettes); it is turned toward the viewer until seen at cosine
    // TERMINATOR_COS. The BSDF then stays continuous in the view direction: no black terminator in images,
    // and no discontinuity that gradients would need a boundary term for.
    float c = dot3(ns, -dir);
    if (bent && c < TERMINATOR_COS) {
        ns = normalize3(ns - dir * (TERMINATOR_COS - c));
        reframe(ns, tangent, bitangent);
    }
    BsdfParams bsdf = BsdfParams(
        vmin3(vmax3(albedo, vec3(0.0)), vec3(1.0)),
        clamp(roughness, 0.0, 1.0),
        clamp(specular, 0.0, 1.0));
    return SurfacePoint(p, ng, ns, tangent, bitangent, front, bsdf, uvt, tri.object, ti);
}

// Ray origin offset off the surface to avoid self-intersection, scaled with the coordinates' magnitude.
vec3 offset_origin(vec3 p, vec3 ng, vec3 toward) {
    float eps = 2e-5 * (1.0 + max_element(abs(p)));
    return dot3(ng, toward) >= 0.0 ? p + ng * eps : p - ng * eps;
}

#endif
