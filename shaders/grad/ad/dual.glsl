// Forward-mode dual numbers with one tangent: a value and its derivative along one parameter direction. GLSL has
// no operator overloading, so each operator of the Rust twin is a function (d_add for +, d_mul for *, ...),
// overloaded on its operand types as the twin's trait impls are, with the same arithmetic in the same order.
// Rust twin: psdr/src/grad/ad/dual.rs.
#ifndef PSDR_DUAL_GLSL
#define PSDR_DUAL_GLSL
#include "render/vec_math.glsl"

struct D {
    float v;
    float d;
};

struct D3 {
    vec3 v;
    vec3 d;
};

D d_c(float v) {
    return D(v, 0.0);
}

D d_sqrt(D a) {
    float s = sqrt(a.v);
    return D(s, s > 0.0 ? a.d / (2.0 * s) : 0.0);
}

D d_max_c(D a, float m) {
    return a.v >= m ? a : d_c(m);
}

D d_min_c(D a, float m) {
    return a.v <= m ? a : d_c(m);
}

D d_clamp_c(D a, float lo, float hi) {
    return d_min_c(d_max_c(a, lo), hi);
}

D d_add(D a, D b) {
    return D(a.v + b.v, a.d + b.d);
}

D d_sub(D a, D b) {
    return D(a.v - b.v, a.d - b.d);
}

D d_mul(D a, D b) {
    return D(a.v * b.v, a.d * b.v + a.v * b.d);
}

D d_div(D a, D b) {
    return D(a.v / b.v, (a.d * b.v - a.v * b.d) / (b.v * b.v));
}

D d_add(D a, float b) {
    return D(a.v + b, a.d);
}

D d_sub(float a, D b) {
    return D(a - b.v, -b.d);
}

D d_mul(D a, float b) {
    return D(a.v * b, a.d * b);
}

D3 d3_c(vec3 v) {
    return D3(v, vec3(0.0));
}

D d3_dot(D3 a, D3 b) {
    return D(dot3(a.v, b.v), dot3(a.d, b.v) + dot3(a.v, b.d));
}

D d3_length(D3 a) {
    return d_sqrt(d3_dot(a, a));
}

D3 d3_mul(D3 a, D s) {
    return D3(a.v * s.v, a.d * s.v + a.v * s.d);
}

D3 d3_normalize(D3 a) {
    return d3_mul(a, d_div(d_c(1.0), d3_length(a)));
}

D3 d3_add(D3 a, D3 b) {
    return D3(a.v + b.v, a.d + b.d);
}

D3 d3_sub(D3 a, D3 b) {
    return D3(a.v - b.v, a.d - b.d);
}

D d_neg(D a) {
    return D(-a.v, -a.d);
}

D3 d3_cross(D3 a, D3 b) {
    return D3(cross3(a.v, b.v), cross3(a.d, b.v) + cross3(a.v, b.d));
}

D3 d3_neg(D3 a) {
    return D3(-a.v, -a.d);
}

// Component-wise product with a constant colour.
D3 d3_mul_c(D3 a, vec3 c) {
    return D3(a.v * c, a.d * c);
}

// Component-wise product of two dual colours.
D3 d3_mul(D3 a, D3 b) {
    return D3(a.v * b.v, a.d * b.v + a.v * b.d);
}

#endif
