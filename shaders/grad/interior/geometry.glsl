// Interior term of radiance with respect to object poses, in ray form: a recorded path (grad/path/record.glsl)
// is replayed in dual numbers along one pose component. Every sampled direction stays fixed and every vertex
// slides along its ray as the surface it lies on moves, so normals, texture lookups, cosines and BSDF values
// change with it, while densities, light selection, MIS weights and roulette stay detached. Pose components
// only (affine velocity fields); vertex parameters stay on the CPU.
// Rust twin: psdr/src/grad/interior/geometry.rs (Tangent::corner, Tangent::normal, triangle,
// DualTriangle::point, DualTriangle::normal, DualTriangle::intersect, dual_point, normal_mapped, replay_radiance).
// GLSL only: dual_scalar, dual_rgb, dual_clamp3 (dual_point's closures scalar, rgb and clamp3).
#ifndef PSDR_GEOMETRY_GLSL
#define PSDR_GEOMETRY_GLSL
#include "render/layout.glsl"
#include "render/scene_buffers.glsl"
#include "render/shading.glsl"
#include "grad/ad/dual.glsl"
#include "grad/ad/bsdf_dual.glsl"
#include "grad/ad/dual_texture.glsl"
#include "grad/interior/normal_map.glsl"
#include "grad/path/velocity.glsl"
#include "grad/path/record.glsl"

// At most this many pose entries touch one path when their vertex velocities are kept for the secondary
// boundary (WITH_SECONDARY; the host checks the entry count). A kernel may set it lower (MAX_ACTIVE_ENTRIES).
#ifndef MAX_ACTIVE_ENTRIES
#define MAX_ACTIVE_ENTRIES 64u
#endif
const uint MAX_ACTIVE = MAX_ACTIVE_ENTRIES;
// The entries that touch the recorded path (a pose entry, and for a vertex block the welded vertex and axis; NONE
// for a pose component), and dx_k/dθ of its vertices under each (slot j, vertex k at j * MAX_RECORD_DEPTH + k),
// written by replay_radiance.
uint active_entries[MAX_ACTIVE];
uint active_vertex[MAX_ACTIVE];
uint active_axis[MAX_ACTIVE];
uint active_count;
vec3 replay_velocity[MAX_ACTIVE * MAX_RECORD_DEPTH];

// The moving component being differentiated: its object and velocity field (a pose component), or one axis of
// one welded vertex (vertex != NONE; its corners move by vertex_velocity, stored normals do not follow).
struct Tangent {
    uint object;
    AffineVelocity field;
    uint vertex;
    vec3 vertex_velocity;
};

// A triangle whose vertices move with one pose component.
struct DualTriangle {
    D3 v0;
    D3 e1;
    D3 e2;
    uint object;
};

// Material parameters and shading normal at a sliding hit.
struct DualPoint {
    D3 ns;
    BsdfParamsD bsdf;
};

// A mesh vertex of `object` at world position x, corner `c` of triangle ti.
D3 tangent_corner(Tangent t, uint object, uint ti, uint c, vec3 x) {
    if (object != t.object) {
        return D3(x, vec3(0.0));
    }
    if (t.vertex == NONE) {
        return D3(x, affine_velocity_at(t.field, x));
    }
    return D3(x, corner_ids[3u * ti + c] == t.vertex ? t.vertex_velocity * 1.0 : vec3(0.0));
}

D3 tangent_normal(Tangent t, uint object, vec3 n) {
    return D3(n, object == t.object && t.vertex == NONE ? affine_velocity_normal(t.field, n) : vec3(0.0));
}

DualTriangle triangle(Tangent t, uint ti) {
    TriangleGeom tri = triangles[ti];
    D3 p0 = tangent_corner(t, tri.object, ti, 0u, tri.v0);
    D3 p1 = tangent_corner(t, tri.object, ti, 1u, tri.v0 + tri.e1);
    D3 p2 = tangent_corner(t, tri.object, ti, 2u, tri.v0 + tri.e2);
    // Keep the primal edge vectors bit-exact; only tangents come from the velocity field.
    return DualTriangle(p0, D3(tri.e1, p1.d - p0.d), D3(tri.e2, p2.d - p0.d), tri.object);
}

D3 dual_triangle_point(DualTriangle tri, D u, D v) {
    return d3_add(d3_add(tri.v0, d3_mul(tri.e1, u)), d3_mul(tri.e2, v));
}

D3 dual_triangle_normal(DualTriangle tri) {
    return d3_normalize(d3_cross(tri.e1, tri.e2));
}

// Möller–Trumbore for the ray from a (possibly moving) origin along a fixed direction: t, u, v.
void dual_triangle_intersect(DualTriangle tri, D3 o, vec3 dir_, out D t, out D u, out D v) {
    D3 dir = d3_c(dir_);
    D3 p = d3_cross(dir, tri.e2);
    D inv_det = d_div(d_c(1.0), d3_dot(tri.e1, p));
    D3 s = d3_sub(o, tri.v0);
    u = d_mul(d3_dot(s, p), inv_det);
    D3 q = d3_cross(s, tri.e1);
    t = d_mul(d3_dot(tri.e2, q), inv_det);
    v = d_mul(d3_dot(dir, q), inv_det);
}

// render/shading.glsl's normal mapping with the tangent frame following the moving triangle.
bool normal_mapped(MaterialGpu mat, TriangleShading sh, DualTriangle tri, D3 ns, D3 ng, D3 texel, out D3 mapped) {
    vec2 duv1 = apply_uv_transform(mat, sh.uv1) - apply_uv_transform(mat, sh.uv0);
    vec2 duv2 = apply_uv_transform(mat, sh.uv2) - apply_uv_transform(mat, sh.uv0);
    D frame_duv1[2] = D[2](d_c(duv1.x), d_c(duv1.y));
    D frame_duv2[2] = D[2](d_c(duv2.x), d_c(duv2.y));
    UvFrame frame = UvFrame(frame_duv1, frame_duv2, (sh.flags & SHADING_HAS_UVS) != 0u);
    return map_normal_dual(tri.e1, tri.e2, ns, ng.v, frame, texel, mapped);
}

D dual_scalar(uint tex, float constant, vec2 uvt, vec2 duvt) {
    return tex != NONE ? dual_texture(textures[tex], uvt, duvt, 0u) : d_c(constant);
}

D3 dual_rgb(uint tex, vec2 uvt, vec2 duvt) {
    TextureGpu t = textures[tex];
    D r = dual_texture(t, uvt, duvt, 0u);
    D g = dual_texture(t, uvt, duvt, 1u);
    D b = dual_texture(t, uvt, duvt, 2u);
    return D3(vec3(r.v, g.v, b.v), vec3(r.d, g.d, b.d));
}

// The primal clamps to [0, 1]; clamped channels do not move.
D3 dual_clamp3(D3 a) {
    bvec3 out_ = bvec3(a.v.x < 0.0 || a.v.x > 1.0, a.v.y < 0.0 || a.v.y > 1.0, a.v.z < 0.0 || a.v.z > 1.0);
    return D3(clamp(a.v, vec3(0.0), vec3(1.0)), mix(a.d, vec3(0.0), out_));
}

// Shading point in duals: the shading normal (flipped toward the incoming ray as surface_point flips it) and the
// material parameters.
DualPoint dual_point(Tangent tg, uint ti, DualTriangle tri, D u, D v, vec3 incoming) {
    TriangleShading sh = shading[ti];
    MaterialGpu mat = materials[triangles[ti].material];
    D3 ng = dual_triangle_normal(tri);
    D w = d_sub(d_sub(1.0, u), v);
    D3 ns = ng;
    if ((sh.flags & SHADING_HAS_NORMALS) != 0u) {
        D3 n = d3_add(d3_add(d3_mul(tangent_normal(tg, tri.object, sh.n0), w), d3_mul(tangent_normal(tg, tri.object, sh.n1), u)),
                      d3_mul(tangent_normal(tg, tri.object, sh.n2), v));
        ns = length3(n.v) > 0.0 ? d3_normalize(n) : ng;
    }
    if (dot3(ng.v, incoming) >= 0.0) {
        ng = d3_neg(ng);
    }
    if (dot3(ns.v, ng.v) < 0.0) {
        ns = d3_neg(ns);
    }
    // Texture coordinates slide only where the barycentrics do.
    vec2 uv;
    vec2 duv;
    if ((sh.flags & SHADING_HAS_UVS) != 0u) {
        uv = sh.uv0 * w.v + sh.uv1 * u.v + sh.uv2 * v.v;
        duv = sh.uv0 * w.d + sh.uv1 * u.d + sh.uv2 * v.d;
    } else {
        uv = vec2(u.v, v.v);
        duv = vec2(u.d, v.d);
    }
    vec2 uvt = vec2(mat.uv_row0.x * uv.x + mat.uv_row0.y * uv.y + mat.uv_row0.z,
                    mat.uv_row1.x * uv.x + mat.uv_row1.y * uv.y + mat.uv_row1.z);
    vec2 duvt = vec2(mat.uv_row0.x * duv.x + mat.uv_row0.y * duv.y + 0.0, mat.uv_row1.x * duv.x + mat.uv_row1.y * duv.y + 0.0);
    bool bent = (sh.flags & SHADING_HAS_NORMALS) != 0u;
    if (mat.normal_tex != NONE) {
        D3 mapped;
        if (normal_mapped(mat, sh, tri, ns, ng, dual_rgb(mat.normal_tex, uvt, duvt), mapped)) {
            ns = mapped;
            bent = true;
        }
    }
    if (bent) {
        ns = turn_toward_viewer(ns, incoming);
    }
    D3 albedo = mat.albedo_tex != NONE ? dual_rgb(mat.albedo_tex, uvt, duvt) : d3_c(mat.albedo);
    BsdfParamsD bsdf = BsdfParamsD(dual_clamp3(albedo), d_clamp_c(dual_scalar(mat.roughness_tex, mat.roughness, uvt, duvt), 0.0, 1.0),
                                   d_clamp_c(dual_scalar(mat.specular_tex, mat.specular, uvt, duvt), 0.0, 1.0));
    return DualPoint(ns, bsdf);
}

// d(path radiance)/dθ along one pose component of the recorded path (rec_*), ray form; with WITH_SECONDARY the
// vertices' velocities go to replay_velocity at `slot`.
vec3 replay_radiance(Tangent tg, uint slot) {
    D3 throughput = d3_c(vec3(1.0));
    D3 radiance = D3(vec3(0.0), vec3(0.0));
    D3 origin = d3_c(rec_origin);
    vec3 dir = rec_dir;
    for (uint k = 0u; k < rec_count; k++) {
        RecordedVertex v = rec_vertices[k];
        DualTriangle tri = triangle(tg, v.triangle);
        D t;
        D u;
        D vv;
        dual_triangle_intersect(tri, origin, dir, t, u, vv);
        D3 p = dual_triangle_point(tri, u, vv);
#ifdef WITH_SECONDARY
        replay_velocity[slot * MAX_RECORD_DEPTH + k] = p.d;
#endif
        DualPoint sp = dual_point(tg, v.triangle, tri, u, vv, dir);
        D3 wi = d3_c(-dir);
        if (v.emitter != NONE) {
            radiance = d3_add(radiance, d3_mul_c(throughput, v.emission * v.emission_mis));
        }
        if (v.has_nee) {
            // Fixed direction toward the recorded light point; emission is constant over the light.
            D3 f = bsdf_eval_dual(sp.bsdf, sp.ns, wi, d3_c(v.nee_dir));
            radiance = d3_add(radiance, d3_mul_c(d3_mul(throughput, f), v.nee_radiance * v.nee_w_over_pdf));
        }
        if (!v.has_next || k + 1u >= rec_count) {
            break;
        }
        D3 f = bsdf_eval_dual(sp.bsdf, sp.ns, wi, d3_c(v.next_dir));
        throughput = d3_mul(throughput, d3_mul(f, d_c(1.0 / (v.next_pdf * v.next_q))));
        origin = p;
        dir = v.next_dir;
    }
    return radiance.d;
}

#endif
