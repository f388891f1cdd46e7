//! What an optimisation records per iteration (the report draws it; a checkpoint keeps it so a resumed run
//! continues the same curves).

use serde::{Deserialize, Serialize};

/// One iteration of an optimisation: its loss (and named terms), where its time went, and the parameter
/// values it was evaluated at.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct IterationRecord {
    pub iteration: usize,
    /// NaN (a diverged iteration) is written as JSON null and read back as NaN.
    #[serde(deserialize_with = "null_as_nan")]
    pub loss: f64,
    #[serde(deserialize_with = "terms_null_as_nan")]
    pub terms: Vec<(String, f64)>,
    pub seconds_render: f64,
    pub seconds_loss: f64,
    pub seconds_backward: f64,
    pub seconds_step: f64,
    /// Per parameter (empty for long ones such as vertices).
    pub values: Vec<Vec<f32>>,
}

fn null_as_nan<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

fn terms_null_as_nan<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Vec<(String, f64)>, D::Error> {
    Ok(Vec::<(String, Option<f64>)>::deserialize(d)?.into_iter().map(|(n, v)| (n, v.unwrap_or(f64::NAN))).collect())
}
