//! Central finite differences of an image loss with respect to one scene parameter: the ground truth that
//! every analytic gradient is checked against. Each replica renders θ+h and θ−h with the same seed
//! (correlated sampling cancels most noise), replicas use different seeds, and the spread across replicas gives
//! the standard error of the mean.

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::grad::{ImageLoss, ParamPath};
use crate::render::SceneData;
use crate::scene::Scene;

/// d(loss)/d(component) for each requested component of a parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct FdEstimate {
    pub components: Vec<usize>,
    pub mean: Vec<f64>,
    /// Standard error of `mean` across replicas (NaN with one replica).
    pub std_err: Vec<f64>,
    pub replicas: u32,
    pub renders: u32,
}

pub struct FdOptions {
    pub step: f32,
    pub replicas: u32,
    /// Components of the parameter to differentiate; empty = all.
    pub components: Vec<usize>,
}

pub fn central_difference(
    scene: &Scene,
    param: &ParamPath,
    loss: &ImageLoss,
    opts: &FdOptions,
    backend: &mut dyn Backend,
) -> Result<FdEstimate> {
    if !(opts.step.is_finite() && opts.step > 0.0) {
        return Err(Error::Invalid(format!("finite-difference step {} must be positive", opts.step)));
    }
    if opts.replicas == 0 {
        return Err(Error::Invalid("finite differences need at least one replica".into()));
    }
    let value = param.get(scene)?;
    let components: Vec<usize> =
        if opts.components.is_empty() { (0..value.len()).collect() } else { opts.components.clone() };
    if let Some(&c) = components.iter().find(|&&c| c >= value.len()) {
        return Err(Error::Invalid(format!("{param} has {} components; component {c} does not exist", value.len())));
    }
    let loss_at = |c: usize, delta: f32, seed: u32, backend: &mut dyn Backend| -> Result<f64> {
        let mut s = scene.clone();
        let mut v = value.clone();
        v[c] += delta;
        param.set(&mut s, &v)?;
        s.settings.seed = seed;
        let frame = backend.render(&SceneData::build(&s)?, &s.settings, &|_, _| {})?;
        loss.eval(&frame)
    };
    let (mut mean, mut std_err) = (vec![], vec![]);
    for &c in &components {
        let diffs: Vec<f64> = (0..opts.replicas)
            .map(|r| {
                let seed = scene.settings.seed.wrapping_add(r);
                let plus = loss_at(c, opts.step, seed, backend)?;
                let minus = loss_at(c, -opts.step, seed, backend)?;
                Ok((plus - minus) / (2.0 * opts.step as f64))
            })
            .collect::<Result<_>>()?;
        let (m, se) = mean_and_std_err(&diffs);
        mean.push(m);
        std_err.push(se);
    }
    let renders = 2 * opts.replicas * components.len() as u32;
    Ok(FdEstimate { components, mean, std_err, replicas: opts.replicas, renders })
}

/// Sample mean and its standard error (sample standard deviation / sqrt(n)); NaN error for n < 2.
pub fn mean_and_std_err(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    if x.len() < 2 {
        return (m, f64::NAN);
    }
    let var = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}
