// The scene's buffers (bindings 0-8), shared by every rendering kernel. Rust twin: psdr/src/render/scene_data.rs
// (SceneData's fields, uploaded in this order by psdr/src/backend/vk_backend.rs).
#ifndef PSDR_SCENE_BUFFERS_GLSL
#define PSDR_SCENE_BUFFERS_GLSL
#include "layout.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Nodes { BvhNode nodes[]; };
layout(std430, set = 0, binding = 1) readonly buffer Triangles { TriangleGeom triangles[]; };
layout(std430, set = 0, binding = 2) readonly buffer Shading { TriangleShading shading[]; };
layout(std430, set = 0, binding = 3) readonly buffer Materials { MaterialGpu materials[]; };
layout(std430, set = 0, binding = 4) readonly buffer Textures { TextureGpu textures[]; };
layout(std430, set = 0, binding = 5) readonly buffer Texels { float texels[]; };
layout(std430, set = 0, binding = 6) readonly buffer Emitters { EmitterGpu emitters[]; };
layout(std430, set = 0, binding = 7) readonly buffer Lights { LightGpu lights[]; };
layout(std430, set = 0, binding = 8) readonly buffer Cameras { CameraGpu camera[]; };

#endif
