#version 450
// std430 round trip: reads structs written from Rust, transforms each field in a known way, writes them back.
// The Rust twins are in tests/std430_layout.rs; keep both sides field-for-field identical.
layout(local_size_x = 64) in;

struct Node {          // 32 bytes: vec3 (align 16) packs with the following uint
    vec3 bmin;
    uint prim_count;
    vec3 bmax;
    uint first_index;
};

struct Material {      // 32 bytes
    vec4 albedo;
    vec2 uv_scale;
    float roughness;
    uint flags;
};

struct Mixed {         // 24 bytes: vec2 aligns to 8, so 4 bytes of padding follow `a`; size rounds to 8
    float a;
    vec2 b;
    float c;
};

layout(push_constant) uniform Push {
    uint nodes;
    uint materials;
    uint mixed;
    float scale;
} pc;

layout(std430, set = 0, binding = 0) readonly buffer NodesIn { Node nodes_in[]; };
layout(std430, set = 0, binding = 1) readonly buffer MaterialsIn { Material materials_in[]; };
layout(std430, set = 0, binding = 2) readonly buffer MixedIn { Mixed mixed_in[]; };
layout(std430, set = 0, binding = 3) writeonly buffer NodesOut { Node nodes_out[]; };
layout(std430, set = 0, binding = 4) writeonly buffer MaterialsOut { Material materials_out[]; };
layout(std430, set = 0, binding = 5) writeonly buffer MixedOut { Mixed mixed_out[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < pc.nodes) {
        Node n = nodes_in[i];
        n.bmin += vec3(1.0);
        n.prim_count *= 2u;
        n.bmax *= pc.scale;
        n.first_index += 7u;
        nodes_out[i] = n;
    }
    if (i < pc.materials) {
        Material m = materials_in[i];
        m.albedo = m.albedo.zyxw;
        m.uv_scale *= pc.scale;
        m.roughness = 1.0 - m.roughness;
        m.flags ^= 0xffu;
        materials_out[i] = m;
    }
    if (i < pc.mixed) {
        Mixed x = mixed_in[i];
        mixed_out[i] = Mixed(x.b.x, vec2(x.c, x.a), x.b.y);
    }
}
