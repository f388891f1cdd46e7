// The horizon boundary of a vertex on a turning surface: its tangent plane cuts the sphere of directions, and
// as the face turns that great circle moves; sampled uniformly in angle, the scattered radiance taken on both
// sides from two sub-paths sharing their random numbers. The including kernel provides grad_rows, the
// recording switch rec_enabled (grad/path/record.glsl) and the pose entries (grad/boundary/primary.glsl).
// Rust twin: psdr/src/grad/boundary/horizon.rs (has_horizon_jump, face_normal_velocity, horizon_boundary).
#ifndef PSDR_HORIZON_GLSL
#define PSDR_HORIZON_GLSL
#include "render/shading.glsl"
#include "grad/path/velocity.glsl"
#include "grad/interior/geometry.glsl"

const float HORIZON_SIDE_EPS = 1e-4;

bool has_horizon_jump(uint ti) {
    return materials[triangles[ti].material].normal_tex != NONE || (shading[ti].flags & SHADING_HAS_NORMALS) != 0u;
}

// dn/dθ of triangle ti's geometric normal (oriented as the shading point's) as its corners move with tg.
vec3 face_normal_velocity(uint ti, Tangent tg, vec3 sp_ng) {
    TriangleGeom tri = triangles[ti];
    if (tri.object != tg.object) {
        return vec3(0.0);
    }
    vec3 u0 = tangent_corner(tg, tri.object, ti, 0u, tri.v0).d;
    vec3 de1 = tangent_corner(tg, tri.object, ti, 1u, tri.v0 + tri.e1).d - u0;
    vec3 de2 = tangent_corner(tg, tri.object, ti, 2u, tri.v0 + tri.e2).d - u0;
    vec3 cr = cross3(tri.e1, tri.e2);
    float len = length3(cr);
    if (isnan(len) || len <= 0.0) {
        return vec3(0.0);
    }
    vec3 n = cr / len;
    vec3 dc = cross3(de1, tri.e2) + cross3(tri.e1, de2);
    vec3 dn = (dc - n * dot3(n, dc)) / len;
    return dot3(n, sp_ng) < 0.0 ? -dn : dn;
}

// `count` horizon samples at a vertex; turning entries (their gradient offsets and dn/dθ) are turn_at/turn_dn.
void horizon_boundary(SurfacePoint sp, vec3 wi, vec3 adjoint_, FrameParams sub_fp, uint seed, uint pixel,
                      uint sample_base, uint count, uint turn_count, uint row) {
    vec3 t1 = orthogonal(sp.ng);
    vec3 t2 = cross3(sp.ng, t1);
    for (uint j = 0u; j < count; j++) {
        Sampler s = Sampler(seed, pixel, sample_base + j);
        float phi = 6.2831855 * sampler_get(s, 0u);
        vec3 om = t1 * cos(phi) + t2 * sin(phi);
        vec3 jump = vec3(0.0);
        for (int side = 0; side < 2; side++) {
            float sign_ = side == 0 ? -1.0 : 1.0;
            vec3 w = normalize3(om + sp.ng * (sign_ * HORIZON_SIDE_EPS));
            vec3 f = bsdf_eval(sp.bsdf, wi, to_local(sp, w));
            if (f == vec3(0.0)) {
                continue;
            }
            rec_enabled = false;
            vec3 l = trace_from(sub_fp, s, offset_origin(sp.p, sp.ng, w), w).radiance;
            rec_enabled = true;
            jump += (side == 0 ? 1.0 : -1.0) * (f * l);
        }
        if (jump == vec3(0.0)) {
            continue;
        }
        float scale = dot3(adjoint_, jump) * 6.2831855 / float(count);
        for (uint t = 0u; t < turn_count; t++) {
            grad_rows[row + turn_at[t]] += scale * -dot3(turn_dn[t], om);
        }
    }
}

#endif
