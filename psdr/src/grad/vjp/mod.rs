//! Entry points by output: radiance w.r.t. poses, the depth and mask AOVs, and one call for a whole loss.

pub(crate) mod aov;
pub(crate) mod device_or_cpu;
pub(crate) mod outputs;
pub(crate) mod radiance_pose;
