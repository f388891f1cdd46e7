// Buffer layouts shared with the CPU renderer. Rust twin: psdr/src/render/layout.rs (std430; field order,
// sizes and padding match exactly; tests/tests/vk_consistency.rs round-trips every struct through a kernel).
#ifndef PSDR_LAYOUT_GLSL
#define PSDR_LAYOUT_GLSL

const uint NONE = 0xffffffffu;
const uint SHADING_HAS_NORMALS = 1u;
const uint SHADING_HAS_UVS = 2u;
#define INFINITY uintBitsToFloat(0x7f800000u)

// obvhs Bvh2Node with feature small_bvh2_node (32 bytes).
struct BvhNode {
    vec3 min_;
    uint prim_count;
    vec3 max_;
    uint first_index;
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
