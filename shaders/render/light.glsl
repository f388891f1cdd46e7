// Emitters: choosing a light, sampling a point on it, and the emitted radiance / density of a hit.
// Rust twin: psdr/src/render/light.rs.
#ifndef PSDR_LIGHT_GLSL
#define PSDR_LIGHT_GLSL
#include "scene_buffers.glsl"
#include "vec_math.glsl"

uint select_light(uint count, float u) {
    uint lo = 0u;
    uint hi = count - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (u < lights[mid].cdf) {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

struct LightSample {
    vec3 p;
    vec3 n;
    vec3 radiance;
    vec3 sky_gradient;
    bool two_sided;
    float pdf_area;
    uint emitter;
};

LightSample sample_light(uint count, float u_select, float u1, float u2) {
    uint li = select_light(count, u_select);
    LightGpu light = lights[li];
    TriangleGeom tri = triangles[light.triangle];
    vec3 e1 = tri.e1;
    vec3 e2 = tri.e2;
    float su = sqrt(u1);
    float b1 = 1.0 - su;
    float b2 = u2 * su;
    vec3 c = cross3(e1, e2);
    float area = 0.5 * length3(c);
    EmitterGpu em = emitters[light.emitter];
    return LightSample(tri.v0 + e1 * b1 + e2 * b2, normalize3(c), em.radiance, em.sky_gradient,
                       em.two_sided != 0u, light.pmf / area, light.emitter);
}

vec3 sky_shape(vec3 g, vec3 dir) {
    return vec3(1.0) + g * dir.y;
}

vec3 emitter_shape(uint e, vec3 dir) {
    return sky_shape(emitters[e].sky_gradient, dir);
}

vec3 emitted_radiance(uint ti, bool front, vec3 dir) {
    uint e = shading[ti].emitter;
    if (e == NONE) {
        return vec3(0.0);
    }
    EmitterGpu em = emitters[e];
    if (em.two_sided != 0u || front) {
        return em.radiance * sky_shape(em.sky_gradient, dir);
    } else {
        return vec3(0.0);
    }
}

float light_pdf_area(uint ti) {
    TriangleGeom tri = triangles[ti];
    if (tri.light == NONE) {
        return 0.0;
    }
    float area = 0.5 * length3(cross3(tri.e1, tri.e2));
    return lights[tri.light].pmf / area;
}

// Power heuristic (beta = 2) weight of a strategy with density a against one with density b.
float mis_power(float a, float b) {
    float a2 = a * a;
    float b2 = b * b;
    if (a2 + b2 > 0.0 && !isinf(a2 + b2) && !isnan(a2 + b2)) {
        return a2 / (a2 + b2);
    } else if (isinf(a)) {
        return 1.0;
    } else {
        return 0.0;
    }
}

#endif
