//! Image losses: an image type, a tape that records differentiable ops on rendered outputs, and the ops
//! (`ops/`), each with a hand-written backward pass checked against finite differences (`tests.rs`). The
//! tape's backward pass yields d loss / d(every rendered output the loss read), which the renderer's adjoint
//! (`grad::outputs_vjp`) turns into parameter gradients.

mod ops;
mod tape;
#[cfg(test)]
mod tests;

pub use crate::base::Image;
pub use ops::*;
pub use tape::{Gradients, Tape, Tensor};
