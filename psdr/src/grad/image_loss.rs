//! Scalar losses of a rendered frame, the quantity whose gradient `psdr grad` reports.

use crate::error::{Error, Result};
use crate::output::read_exr_rgb;
use crate::render::Frame;
use std::path::Path;

/// Which rendered output a loss reads.
#[derive(Clone, Debug, PartialEq)]
pub enum Output {
    Radiance,
    Depth,
    /// Coverage mask of the object with this index.
    Mask(usize),
}

impl Output {
    /// The output's values, pixel-major (3 per pixel for radiance, 1 otherwise).
    pub fn values(&self, f: &Frame) -> Result<Vec<f32>> {
        Ok(match self {
            Output::Radiance => f.radiance.clone(),
            Output::Depth => f.depth.clone(),
            Output::Mask(o) if (*o as u32) < f.object_count => f.mask(*o),
            Output::Mask(o) => {
                return Err(Error::Invalid(format!("mask of object {o}: the scene has {}", f.object_count)))
            }
        })
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum ImageLoss {
    /// Mean of the output over pixels and channels.
    Mean(Output),
    /// Mean squared difference to a target image of the same size and channel count.
    L2To { output: Output, target: Vec<f32> },
}

impl ImageLoss {
    /// L2 to the radiance in an EXR (its R, G, B channels).
    pub fn l2_to_exr(path: &Path) -> Result<ImageLoss> {
        let (_, _, target) = read_exr_rgb(path)?;
        Ok(ImageLoss::L2To { output: Output::Radiance, target })
    }

    /// dLoss/d(radiance) per pixel channel. Only radiance losses have an analytic gradient so far: depth and
    /// mask derivatives come entirely from boundary terms, which are not implemented yet.
    pub fn radiance_adjoint(&self, f: &Frame) -> Result<Vec<f32>> {
        let n = f.radiance.len().max(1) as f32;
        match self {
            ImageLoss::Mean(Output::Radiance) => Ok(vec![1.0 / n; f.radiance.len()]),
            ImageLoss::L2To { output: Output::Radiance, target } => {
                self.eval(f)?; // checks the size
                Ok(f.radiance.iter().zip(target).map(|(&a, &b)| 2.0 * (a - b) / n).collect())
            }
            _ => Err(Error::Invalid(
                "analytic gradients of depth and mask losses need boundary terms (not implemented yet); use --fd"
                    .into(),
            )),
        }
    }

    pub fn eval(&self, f: &Frame) -> Result<f64> {
        match self {
            ImageLoss::Mean(o) => {
                let v = o.values(f)?;
                Ok(v.iter().map(|&x| x as f64).sum::<f64>() / v.len().max(1) as f64)
            }
            ImageLoss::L2To { output, target } => {
                let v = output.values(f)?;
                if v.len() != target.len() {
                    return Err(Error::Invalid(format!(
                        "loss target has {} values, the {}x{} render has {}",
                        target.len(),
                        f.width,
                        f.height,
                        v.len()
                    )));
                }
                Ok(v.iter().zip(target).map(|(&a, &b)| (a as f64 - b as f64).powi(2)).sum::<f64>() / v.len() as f64)
            }
        }
    }
}
