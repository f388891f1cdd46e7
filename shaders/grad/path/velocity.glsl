// Velocity fields of pose components, u(x) = a + G (x − t): translation (a = e_a, G = 0), yaw, rotation and
// scale (a = 0, G the field's constant Jacobian about the object's origin t). Vertex components are not affine
// and stay on the CPU. The host fills these from PoseLayout::affine_velocity.
// Rust twin: psdr/src/grad/path/velocity.rs (AffineVelocity::at, AffineVelocity::normal).
#ifndef PSDR_VELOCITY_GLSL
#define PSDR_VELOCITY_GLSL
#include "render/vec_math.glsl"

struct AffineVelocity {
    vec3 a;
    mat3 g;
    vec3 t;
};

vec3 affine_velocity_at(AffineVelocity f, vec3 x) {
    vec3 r = x - f.t;
    return f.a + (f.g[0] * r.x + f.g[1] * r.y + f.g[2] * r.z);
}

// ∂n/∂θ of a unit normal carried by the motion (normals transform with the inverse transpose).
vec3 affine_velocity_normal(AffineVelocity f, vec3 n) {
    vec3 gt_n = vec3(dot3(f.g[0], n), dot3(f.g[1], n), dot3(f.g[2], n));
    return -gt_n + n * dot3(n, gt_n);
}

#endif
