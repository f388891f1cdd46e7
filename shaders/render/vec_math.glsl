// Vector helpers written the way glam evaluates them (same operand order), so Rust and GLSL round alike.
// Rust twin: glam's Vec3::{dot, length, normalize, cross, max_element, min_element}, f32::copysign.
#ifndef PSDR_VEC_MATH_GLSL
#define PSDR_VEC_MATH_GLSL

float dot3(vec3 a, vec3 b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

float length3(vec3 a) {
    return sqrt(dot3(a, a));
}

vec3 normalize3(vec3 a) {
    return a * (1.0 / length3(a));
}

vec3 cross3(vec3 a, vec3 b) {
    return vec3(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}

// glam's component-wise min/max and horizontal reductions (ternaries, as glam writes them).
float gmin(float a, float b) {
    return a < b ? a : b;
}

float gmax(float a, float b) {
    return a > b ? a : b;
}

vec3 vmin3(vec3 a, vec3 b) {
    return vec3(gmin(a.x, b.x), gmin(a.y, b.y), gmin(a.z, b.z));
}

vec3 vmax3(vec3 a, vec3 b) {
    return vec3(gmax(a.x, b.x), gmax(a.y, b.y), gmax(a.z, b.z));
}

float max_element(vec3 a) {
    return gmax(gmax(a.x, a.y), a.z);
}

float min_element(vec3 a) {
    return gmin(gmin(a.x, a.y), a.z);
}

// Magnitude of x with the sign bit of s (f32::copysign).
float copysign(float x, float s) {
    return uintBitsToFloat((floatBitsToUint(x) & 0x7fffffffu) | (floatBitsToUint(s) & 0x80000000u));
}

#endif
