//! The optimiser's whole state, written atomically every few iterations, so a killed run resumes where it
//! stopped and finishes with the same result as an uninterrupted one (same seeds, same moments, same rates).

use super::adam::AdamState;
use super::parametrization::ParamSpec;
use crate::error::{Error, Result};
use crate::optim::IterationRecord;
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const CHECKPOINT_FORMAT: &str = "psdr-optimizer-checkpoint";

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    pub format: String,
    /// The iteration to run next (== iters when the optimisation finished).
    pub next_iteration: usize,
    pub specs: Vec<ParamSpec>,
    pub u: Vec<Vec<f64>>,
    pub adam: Vec<AdamState>,
    /// Product of the halvings after divergences.
    pub lr_scale: f64,
    pub divergences: usize,
    pub best: Option<BestState>,
    pub records: Vec<IterationRecord>,
    pub events: Vec<String>,
    /// Why the optimisation stopped early, if it did.
    pub stopped: Option<String>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BestState {
    pub loss: f64,
    pub iteration: usize,
    pub u: Vec<Vec<f64>>,
    pub adam: Vec<AdamState>,
}

impl Checkpoint {
    pub fn write(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string(self).map_err(|e| Error::io(path, e))?;
        crate::output::write_atomically(path, |tmp| std::fs::write(tmp, text).map_err(|e| Error::io(tmp, e)))
    }

    /// The checkpoint at `path`, or None if there is none; an unreadable one is an error (never silently
    /// restarted, which would waste the run it came from).
    pub fn read(path: &Path) -> Result<Option<Checkpoint>> {
        if !path.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let c: Checkpoint =
            serde_json::from_str(&text).map_err(|e| Error::io(path, format!("not a readable checkpoint: {e}")))?;
        if c.format != CHECKPOINT_FORMAT {
            return Err(Error::io(path, format!("format '{}' is not {CHECKPOINT_FORMAT}", c.format)));
        }
        Ok(Some(c))
    }
}
