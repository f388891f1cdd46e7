#version 450
// The radiance-pose kernel without the secondary boundary (the body: radiance_pose.glsl).
// Rust twin: psdr/src/grad/vjp/radiance_pose.rs.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

#include "grad/vjp/radiance_pose.glsl"
