// The integrator: path tracing with next-event estimation, MIS (power heuristic) and Russian roulette, plus
// the primary-hit AOVs, shared by the primal kernel and the adjoint passes' path recorder. A kernel that records
// paths defines the OBSERVE_* hooks before including this file (grad/path/record.glsl); the primal leaves them
// empty. Rust twin: psdr/src/render/path_trace.rs (trace_path, trace_from, unoccluded; the hooks are its
// PathObserver's methods).
#ifndef PSDR_PATH_TRACE_GLSL
#define PSDR_PATH_TRACE_GLSL
#include "layout.glsl"
#include "scene_buffers.glsl"
#include "vec_math.glsl"
#include "sampler.glsl"
#include "camera.glsl"
#include "bvh.glsl"
#include "bsdf.glsl"
#include "shading.glsl"
#include "light.glsl"

#ifndef OBSERVE_HIT
#define OBSERVE_START(origin, dir)
#define OBSERVE_HIT(hit, sp, beta)
#define OBSERVE_EMISSION(emitter, le, shape, mis)
#define OBSERVE_SCATTER(wi)
#define OBSERVE_NEE(u_select, wl, emitter, radiance, w_over_pdf, f, wo)
#define OBSERVE_CONTINUATION(dir, pdf, q, weight, wo)
#endif

struct PathSample {
    vec3 radiance;
    float depth;
    vec3 normal;
    vec3 albedo;
    uint object;
    uint rays;
    vec3 first_emission;
};

// True when nothing blocks the segment from surface point p (normal ng) to light point q (normal nq).
bool unoccluded(vec3 p, vec3 ng, vec3 q, vec3 nq) {
    vec3 o = offset_origin(p, ng, q - p);
    vec3 v = offset_origin(q, nq, p - q) - o;
    float dist = length3(v);
    return dist > 0.0 && !trace_occluded(o, v / dist, dist);
}

// The integrator from the ray (origin, dir) on, drawing bounce numbers from s, with the depth, roulette and light
// settings of fp (a sub-path from a boundary sample has its own depth).
PathSample trace_from(FrameParams fp, Sampler s, vec3 origin, vec3 dir) {
    CameraGpu cam = camera[0];
    OBSERVE_START(origin, dir);
    PathSample out_ = PathSample(vec3(0.0), 0.0, vec3(0.0), vec3(0.0), NONE, 0u, vec3(0.0));
    vec3 beta = vec3(1.0);
    float prev_bsdf_pdf = 0.0;
    for (uint depth = 0u; depth < fp.max_depth; depth++) {
        out_.rays += 1u;
        Hit hit = trace_closest(origin, dir, INFINITY);
        if (hit.triangle == NONE) {
            break;
        }
        SurfacePoint sp = surface_point(hit.triangle, hit.u, hit.v, dir);
        OBSERVE_HIT(hit, sp, beta);
        if (depth == 0u) {
            out_.depth = hit.t * dot3(dir, cam.forward);
            out_.normal = sp.ns;
            out_.albedo = sp.bsdf.albedo;
            out_.object = sp.object;
        }
        // Emission reached by the previous bounce (or seen directly), MIS-weighted against NEE.
        vec3 le = emitted_radiance(hit.triangle, sp.front, dir);
        if (le != vec3(0.0)) {
            uint emitter = shading[hit.triangle].emitter;
            vec3 shape = emitter_shape(emitter, dir);
            if (depth == 0u) {
                out_.radiance += beta * le;
                out_.first_emission = beta * le;
                OBSERVE_EMISSION(emitter, le, shape, 1.0);
            } else {
                float cos_l = abs(dot3(sp.ng, -dir));
                float light_pdf = light_pdf_area(hit.triangle) * hit.t * hit.t / cos_l;
                float mis = mis_power(prev_bsdf_pdf, light_pdf);
                out_.radiance += beta * le * mis;
                OBSERVE_EMISSION(emitter, le, shape, mis);
            }
        }
        if (depth + 1u >= fp.max_depth) {
            break;
        }
        vec3 wi = to_local(sp, -dir);
        OBSERVE_SCATTER(wi);
        BsdfAt bsdf = bsdf_at(sp.bsdf, wi);
        vec2 u_select_lobe = sampler_bounce2(s, depth, DIM_LIGHT_SELECT);
        // Next-event estimation: one point on one light.
        if (fp.light_count > 0u) {
            vec2 u = sampler_bounce2(s, depth, DIM_LIGHT_U);
            LightSample ls = sample_light(fp.light_count, u_select_lobe.x, u.x, u.y);
            vec3 to_light = ls.p - sp.p;
            float dist2 = dot3(to_light, to_light);
            float dist = sqrt(dist2);
            vec3 wl = to_light / dist;
            float cos_l = ls.two_sided ? abs(dot3(ls.n, -wl)) : dot3(ls.n, -wl);
            if (cos_l > 0.0 && dist > 0.0) {
                float pdf;
                vec3 wo = to_local(sp, wl);
                vec3 f = bsdf_eval_pdf(bsdf, wo, pdf);
                if (f != vec3(0.0)) {
                    out_.rays += 1u;
                    if (unoccluded(sp.p, sp.ng, ls.p, ls.n)) {
                        float light_pdf = ls.pdf_area * dist2 / cos_l;
                        float w = mis_power(light_pdf, pdf);
                        float w_over_pdf = w / light_pdf;
                        vec3 le = ls.radiance * sky_shape(ls.sky_gradient, wl);
                        out_.radiance += beta * f * le * w_over_pdf;
                        OBSERVE_NEE(u_select_lobe.x, wl, ls.emitter, le, w_over_pdf, f, wo);
                    }
                }
            }
        }
        // Continue the path by sampling the BSDF.
        vec2 b = sampler_bounce2(s, depth, DIM_BSDF_U);
        BsdfSample bs;
        if (!bsdf_sample_at(bsdf, u_select_lobe.y, b.x, b.y, bs)) {
            break;
        }
        beta *= bs.weight;
        prev_bsdf_pdf = bs.pdf;
        dir = normalize3(to_world(sp, bs.wo));
        origin = offset_origin(sp.p, sp.ng, dir);
        float q = 1.0;
        if (depth + 1u >= fp.rr_depth) {
            q = min(max_element(beta), 0.95);
            if (sampler_bounce(s, depth, DIM_ROULETTE) >= q || isnan(q)) {
                break;
            }
            beta /= q;
        }
        OBSERVE_CONTINUATION(dir, bs.pdf, q, bs.weight, bs.wo);
    }
    return out_;
}

// Traces sample `sample_` of pixel (px, py).
PathSample trace_path(uint px, uint py, uint sample_) {
    CameraGpu cam = camera[0];
    Sampler s = Sampler(fp.seed, py * cam.width + px, sample_);
    vec2 jitter = sampler_get2(s, DIM_PIXEL_X);
    vec3 dir = camera_ray(cam, float(px) + jitter.x, float(py) + jitter.y);
    return trace_from(fp, s, cam.origin, dir);
}

#endif
