//! Scalar losses of a rendered frame, the quantity whose gradient `psdr grad` reports.

use crate::error::{Error, Result};
use crate::output::{read_exr_channels, read_exr_rgb};
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
    /// L2 to an EXR: its R, G, B channels for radiance, its `channel` (or only channel) otherwise — the files
    /// `psdr render --aov depth,mask` writes can serve as targets directly.
    pub fn l2_to_exr(path: &Path, output: Output, channel: Option<&str>) -> Result<ImageLoss> {
        let target = match output {
            Output::Radiance => read_exr_rgb(path)?.2,
            _ => {
                let (_, _, channels) = read_exr_channels(path)?;
                let names: Vec<&str> = channels.iter().map(|c| c.0.as_str()).collect();
                let pick = match channel {
                    Some(name) => channels.iter().find(|c| c.0 == name),
                    None if channels.len() == 1 => channels.first(),
                    None => None,
                };
                pick.ok_or_else(|| Error::io(path, format!("no target channel {channel:?} among {names:?}")))?.1.clone()
            }
        };
        Ok(ImageLoss::L2To { output, target })
    }

    /// The output this loss reads.
    pub fn output(&self) -> &Output {
        match self {
            ImageLoss::Mean(o) | ImageLoss::L2To { output: o, .. } => o,
        }
    }

    /// True when the adjoint depends on the rendered image (so a primal render must come first).
    pub fn needs_primal(&self) -> bool {
        !matches!(self, ImageLoss::Mean(_))
    }

    /// dLoss/d(output values), laid out like `Output::values`. `f` may be any frame of the right size when
    /// `needs_primal` is false.
    pub fn adjoint(&self, f: &Frame) -> Result<Vec<f32>> {
        let v = self.output().values(f)?;
        let n = v.len().max(1) as f32;
        match self {
            ImageLoss::Mean(_) => Ok(vec![1.0 / n; v.len()]),
            ImageLoss::L2To { target, .. } => {
                self.eval(f)?; // checks the size
                Ok(v.iter().zip(target).map(|(&a, &b)| 2.0 * (a - b) / n).collect())
            }
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
