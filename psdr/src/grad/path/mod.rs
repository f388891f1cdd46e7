//! Camera paths recorded for the adjoint passes, and the velocity fields of geometric parameters.

pub(crate) mod record;
pub(crate) mod velocity;
