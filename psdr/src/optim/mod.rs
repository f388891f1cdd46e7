//! Optimisation: choosing parameters by path pattern (`select`), how each maps to the unconstrained vector the
//! optimiser moves (`parametrization`: bounds, log spaces, locked axes), Adam (`adam`), the loop with its
//! divergence guard (`optimize`), what a loss closure reads (`rendered`) and resumable state (`checkpoint`).

mod adam;
mod checkpoint;
mod optimize;
mod parametrization;
mod record;
mod rendered;
mod select;

pub use adam::{AdamConfig, AdamState};
pub use checkpoint::{BestState, Checkpoint, CHECKPOINT_FORMAT};
pub use optimize::{gradient, optimize, Evaluation, LossFn, OptimizeOptions, OptimizeOutcome};
pub use parametrization::{defaults, ParamSpec, Schedule, Space};
pub use record::IterationRecord;
pub use rendered::Rendered;
pub use select::{glob_match, scene_parameters, select};
