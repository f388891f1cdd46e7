#version 450
// The primal kernel: one invocation per pixel accumulates samples [sample_begin, sample_begin + sample_count)
// of the integrator (path_trace.glsl) into the pixel's running sums, in sample order, exactly as the CPU does,
// plus the primary-hit AOVs. Rust twin: psdr/src/render/path_trace.rs (path_trace, object_at_pixel_center).
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

#include "path_trace.glsl"

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
