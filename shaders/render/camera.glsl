// Primary rays of the pinhole camera. Rust twin: psdr/src/render/camera.rs.
#ifndef PSDR_CAMERA_GLSL
#define PSDR_CAMERA_GLSL
#include "layout.glsl"
#include "vec_math.glsl"

vec3 camera_ray(CameraGpu c, float x, float y) {
    float ndc_x = 2.0 * x / float(c.width) - 1.0;
    float ndc_y = 1.0 - 2.0 * y / float(c.height);
    vec3 d = c.forward
        + c.right * (ndc_x * c.tan_half_fov * c.aspect)
        + c.up * (ndc_y * c.tan_half_fov);
    return normalize3(d);
}

#endif
