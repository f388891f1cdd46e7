//! Interior terms: reverse-mode replay for parameters that do not move geometry, ray-form dual replay for those that do.

pub(crate) mod fused_l2;
pub(crate) mod geometry;
pub(crate) mod material_light;
pub(crate) mod normal_map;
