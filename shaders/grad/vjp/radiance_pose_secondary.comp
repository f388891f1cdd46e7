#version 450
// The radiance-pose kernel with the secondary boundary (the body: radiance_pose.glsl); its edge-tree descent is
// in double precision, so the device needs shaderFloat64. It keeps 64 entries' vertex velocities per path;
// radiance_pose_secondary_small.comp keeps 16, for drivers that refuse this one.
// Rust twin: psdr/src/grad/vjp/radiance_pose.rs.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

#define WITH_SECONDARY
#include "grad/vjp/radiance_pose.glsl"
