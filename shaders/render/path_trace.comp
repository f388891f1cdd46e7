#version 450
// The primal integrator: path tracing with next-event estimation, MIS and Russian roulette, plus the
// primary-hit AOVs. One invocation per pixel accumulates samples [sample_begin, sample_begin + sample_count)
// into the pixel's running sums, in sample order, exactly as the CPU does.
// Rust twin: psdr/src/render/path_trace.rs (trace_path, unoccluded, path_trace, object_at_pixel_center).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 8, local_size_y = 8) in;

#include "layout.glsl"
#include "scene_buffers.glsl"
#include "vec_math.glsl"
#include "sampler.glsl"
#include "camera.glsl"
#include "bvh.glsl"
#include "bsdf.glsl"
#include "shading.glsl"
#include "light.glsl"

layout(push_constant) uniform Push { FrameParams fp; };

layout(std430, set = 0, binding = 9) buffer RadianceSums { float radiance_sums[]; };
layout(std430, set = 0, binding = 10) buffer DepthSums { float depth_sums[]; };
layout(std430, set = 0, binding = 11) buffer NormalSums { float normal_sums[]; };
layout(std430, set = 0, binding = 12) buffer AlbedoSums { float albedo_sums[]; };
layout(std430, set = 0, binding = 13) buffer Coverage { float coverage[]; };
layout(std430, set = 0, binding = 14) buffer ObjectIds { uint object_ids[]; };
layout(std430, set = 0, binding = 15) buffer Rays { uint rays[]; };

struct PathSample {
    vec3 radiance;
    float depth;
    vec3 normal;
    vec3 albedo;
    uint object;
    uint rays;
};

// True when nothing blocks the segment from surface point p (normal ng) to light point q (normal nq).
bool unoccluded(vec3 p, vec3 ng, vec3 q, vec3 nq) {
    vec3 o = offset_origin(p, ng, q - p);
    vec3 v = offset_origin(q, nq, p - q) - o;
    float dist = length3(v);
    return dist > 0.0 && !trace_occluded(o, v / dist, dist);
}

PathSample trace_path(uint px, uint py, uint sample_) {
    CameraGpu cam = camera[0];
    Sampler s = Sampler(fp.seed, py * cam.width + px, sample_);
    vec2 jitter = sampler_get2(s, DIM_PIXEL_X);
    vec3 dir = camera_ray(cam, float(px) + jitter.x, float(py) + jitter.y);
    vec3 origin = cam.origin;
    PathSample out_ = PathSample(vec3(0.0), 0.0, vec3(0.0), vec3(0.0), NONE, 0u);
    vec3 beta = vec3(1.0);
    float prev_bsdf_pdf = 0.0;
    for (uint depth = 0u; depth < fp.max_depth; depth++) {
        out_.rays += 1u;
        Hit hit = trace_closest(origin, dir, INFINITY);
        if (hit.triangle == NONE) {
            break;
        }
        SurfacePoint sp = surface_point(hit.triangle, hit.u, hit.v, dir);
        if (depth == 0u) {
            out_.depth = hit.t * dot3(dir, cam.forward);
            out_.normal = sp.ns;
            out_.albedo = sp.bsdf.albedo;
            out_.object = sp.object;
        }
        // Emission reached by the previous bounce (or seen directly), MIS-weighted against NEE.
        vec3 le = emitted_radiance(hit.triangle, sp.front);
        if (le != vec3(0.0)) {
            if (depth == 0u) {
                out_.radiance += beta * le;
            } else {
                float cos_l = abs(dot3(sp.ng, -dir));
                float light_pdf = light_pdf_area(hit.triangle) * hit.t * hit.t / cos_l;
                out_.radiance += beta * le * mis_power(prev_bsdf_pdf, light_pdf);
            }
        }
        if (depth + 1u >= fp.max_depth) {
            break;
        }
        vec3 wi = to_local(sp, -dir);
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
                vec3 f = bsdf_eval_pdf(bsdf, to_local(sp, wl), pdf);
                if (f != vec3(0.0)) {
                    out_.rays += 1u;
                    if (unoccluded(sp.p, sp.ng, ls.p, ls.n)) {
                        float light_pdf = ls.pdf_area * dist2 / cos_l;
                        float w = mis_power(light_pdf, pdf);
                        out_.radiance += beta * f * ls.radiance * (w / light_pdf);
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
        if (depth + 1u >= fp.rr_depth) {
            float q = min(max_element(beta), 0.95);
            if (sampler_bounce(s, depth, DIM_ROULETTE) >= q || isnan(q)) {
                break;
            }
            beta /= q;
        }
    }
    return out_;
}

// Object seen through the centre of pixel (px, py), or NONE (the id AOV: exact, not averaged).
uint object_at_pixel_center(uint px, uint py) {
    CameraGpu cam = camera[0];
    vec3 dir = camera_ray(cam, float(px) + 0.5, float(py) + 0.5);
    Hit h = trace_closest(cam.origin, dir, INFINITY);
    return h.triangle == NONE ? NONE : triangles[h.triangle].object;
}

// The kernel body (Rust twin: path_trace): accumulates this pass's samples into the pixel's sums.
void main() {
    CameraGpu cam = camera[0];
    uint px = gl_GlobalInvocationID.x;
    uint py = gl_GlobalInvocationID.y;
    if (px >= cam.width || py >= cam.height) {
        return;
    }
    uint i = py * cam.width + px;
    vec3 radiance = vec3(radiance_sums[3u * i], radiance_sums[3u * i + 1u], radiance_sums[3u * i + 2u]);
    float depth = depth_sums[i];
    vec3 normal = vec3(normal_sums[3u * i], normal_sums[3u * i + 1u], normal_sums[3u * i + 2u]);
    vec3 albedo = vec3(albedo_sums[3u * i], albedo_sums[3u * i + 1u], albedo_sums[3u * i + 2u]);
    uint ray_count = rays[i];
    uint nobj = fp.object_count;
    for (uint sample_ = fp.sample_begin; sample_ < fp.sample_begin + fp.sample_count; sample_++) {
        PathSample ps = trace_path(px, py, sample_);
        radiance += ps.radiance;
        depth += ps.depth;
        normal += ps.normal;
        albedo += ps.albedo;
        ray_count += ps.rays;
        if (ps.object != NONE) {
            coverage[i * nobj + ps.object] += 1.0;
        }
    }
    radiance_sums[3u * i] = radiance.x;
    radiance_sums[3u * i + 1u] = radiance.y;
    radiance_sums[3u * i + 2u] = radiance.z;
    depth_sums[i] = depth;
    normal_sums[3u * i] = normal.x;
    normal_sums[3u * i + 1u] = normal.y;
    normal_sums[3u * i + 2u] = normal.z;
    albedo_sums[3u * i] = albedo.x;
    albedo_sums[3u * i + 1u] = albedo.y;
    albedo_sums[3u * i + 2u] = albedo.z;
    rays[i] = ray_count;
    if (fp.sample_begin == 0u) {
        object_ids[i] = object_at_pixel_center(px, py);
    }
}
