#version 450
// Layout round trip: reads element 0 of every shared struct through the std430 declarations of layout.glsl and
// writes its fields, in declaration order, as raw 32-bit words. The Rust test (tests/tests/vk_consistency.rs)
// compares them with the fields it wrote, so any offset or padding mismatch between layout.rs and layout.glsl
// shows up as a wrong word.
// Rust twin: psdr/src/render/layout.rs (the structs it reads). GLSL only: put (appends one word to the output).
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 1) in;
#include "layout.glsl"

layout(push_constant) uniform Push { FrameParams fp; };
layout(std430, set = 0, binding = 0) readonly buffer Nodes { BvhNode nodes[]; };
layout(std430, set = 0, binding = 1) readonly buffer Triangles { TriangleGeom triangles[]; };
layout(std430, set = 0, binding = 2) readonly buffer Shading { TriangleShading shading[]; };
layout(std430, set = 0, binding = 3) readonly buffer Materials { MaterialGpu materials[]; };
layout(std430, set = 0, binding = 4) readonly buffer Textures { TextureGpu textures[]; };
layout(std430, set = 0, binding = 5) readonly buffer Emitters { EmitterGpu emitters[]; };
layout(std430, set = 0, binding = 6) readonly buffer Lights { LightGpu lights[]; };
layout(std430, set = 0, binding = 7) readonly buffer Cameras { CameraGpu camera[]; };
layout(std430, set = 0, binding = 8) buffer Out { uint words[]; };

uint n = 0u;
void put(float x) { words[n++] = floatBitsToUint(x); }
void put(uint x) { words[n++] = x; }
void put(vec2 v) { put(v.x); put(v.y); }
void put(vec3 v) { put(v.x); put(v.y); put(v.z); }
void put(vec4 v) { put(v.x); put(v.y); put(v.z); put(v.w); }

void main() {
    // Element 1 of each array, so the array stride is checked too.
    BvhNode b = nodes[1];
    put(b.p); put(b.e_imask); put(b.child_base_idx); put(b.primitive_base_idx); put(b.child_meta.x); put(b.child_meta.y);
    put(b.child_min_x.x); put(b.child_min_x.y); put(b.child_max_x.x); put(b.child_max_x.y);
    put(b.child_min_y.x); put(b.child_min_y.y); put(b.child_max_y.x); put(b.child_max_y.y);
    put(b.child_min_z.x); put(b.child_min_z.y); put(b.child_max_z.x); put(b.child_max_z.y);
    TriangleGeom t = triangles[1];
    put(t.v0); put(t.material); put(t.e1); put(t.object); put(t.e2); put(t.light);
    TriangleShading s = shading[1];
    put(s.n0); put(s.flags); put(s.n1); put(s.emitter); put(s.n2); put(s._pad0); put(s.uv0); put(s.uv1); put(s.uv2);
    put(s._pad1.x); put(s._pad1.y); put(s.ng); put(s._pad2); put(s.dpdu); put(s._pad3); put(s.dpdv); put(s._pad4);
    MaterialGpu m = materials[1];
    put(m.albedo); put(m.albedo_tex); put(m.roughness); put(m.roughness_tex); put(m.specular); put(m.specular_tex);
    put(m.normal_tex); put(m._pad0); put(m._pad1); put(m._pad2); put(m.uv_row0); put(m.uv_row1);
    TextureGpu x = textures[1];
    put(x.offset); put(x.width); put(x.height); put(x.channels);
    EmitterGpu e = emitters[1];
    put(e.radiance); put(e.two_sided); put(e.sky_gradient); put(e._pad0);
    LightGpu l = lights[1];
    put(l.triangle); put(l.emitter); put(l.cdf); put(l.pmf);
    CameraGpu c = camera[1];
    put(c.origin); put(c.tan_half_fov); put(c.forward); put(c.aspect); put(c.right); put(c.width); put(c.up); put(c.height);
    put(fp.seed); put(fp.spp); put(fp.max_depth); put(fp.rr_depth); put(fp.light_count); put(fp.object_count);
    put(fp.sample_begin); put(fp.sample_count);
}
