//! Dual numbers, BSDF derivatives and texture lookups in dual numbers: the automatic-differentiation pieces every term builds on.

pub(crate) mod bsdf_dual;
pub(crate) mod bsdf_grad;
pub(crate) mod dual;
pub(crate) mod dual_texture;
