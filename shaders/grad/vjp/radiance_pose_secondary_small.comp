#version 450
// radiance_pose_secondary.comp keeping 16 entries' vertex velocities per path instead of 64: NVIDIA's driver
// (H100, 580.159) refused to create that kernel's pipeline (VK_ERROR_UNKNOWN; 12 KB of private velocities per
// invocation plus the secondary sampler's arrays) and created it with 8 entries. The host uses this one where
// the large one fails, for paths with at most 16 entries, and the CPU term beyond.
// Rust twin: psdr/src/grad/vjp/radiance_pose.rs.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

#define WITH_SECONDARY
#define MAX_ACTIVE_ENTRIES 16u
#include "grad/vjp/radiance_pose.glsl"
