// Buffer layouts shared with the CPU renderer. Rust twin: psdr/src/render/layout.rs (std430; field order,
// sizes and padding match exactly; tests/tests/vk_consistency.rs round-trips every struct through a kernel).
#ifndef PSDR_LAYOUT_GLSL
#define PSDR_LAYOUT_GLSL

const uint NONE = 0xffffffffu;
const uint SHADING_HAS_NORMALS = 1u;
const uint SHADING_HAS_UVS = 2u;
const uint SHADING_HAS_TANGENT = 4u;
#define INFINITY uintBitsToFloat(0x7f800000u)

// obvhs CwBvhNode (80 bytes): grid origin; e[0..3] in bytes 0-2 and imask in byte 3 of e_imask; [u8; 8]
// fields as two little-endian words (byte i in word i / 4, bits 8 * (i % 4)).
struct BvhNode {
    vec3 p;
    uint e_imask;
    uint child_base_idx;
    uint primitive_base_idx;
    uvec2 child_meta;
    uvec2 child_min_x;
    uvec2 child_max_x;
    uvec2 child_min_y;
    uvec2 child_max_y;
    uvec2 child_min_z;
    uvec2 child_max_z;
};

struct TriangleGeom {
    vec3 v0;
    uint material;
    vec3 e1;
    uint object;
    vec3 e2;
    uint light;
};

struct TriangleShading {
    vec3 n0;
    uint flags;
    vec3 n1;
    uint emitter;
    vec3 n2;
    uint _pad0;
    vec2 uv0;
    vec2 uv1;
    vec2 uv2;
    uvec2 _pad1;
    vec3 ng;
    uint _pad2;
    vec3 dpdu;
    uint _pad3;
    vec3 dpdv;
    uint _pad4;
};

struct MaterialGpu {
    vec3 albedo;
    uint albedo_tex;
    float roughness;
    uint roughness_tex;
    float specular;
    uint specular_tex;
    uint normal_tex;
    uint _pad0;
    uint _pad1;
    uint _pad2;
    vec4 uv_row0;
    vec4 uv_row1;
};

struct TextureGpu {
    uint offset;
    uint width;
    uint height;
    uint channels;
};

struct EmitterGpu {
    vec3 radiance;
    uint two_sided;
    vec3 sky_gradient;
    float _pad0;
};

struct LightGpu {
    uint triangle;
    uint emitter;
    float cdf;
    float pmf;
};

struct CameraGpu {
    vec3 origin;
    float tan_half_fov;
    vec3 forward;
    float aspect;
    vec3 right;
    uint width;
    vec3 up;
    uint height;
};

struct FrameParams {
    uint seed;
    uint spp;
    uint max_depth;
    uint rr_depth;
    uint light_count;
    uint object_count;
    uint sample_begin;
    uint sample_count;
};

#endif
