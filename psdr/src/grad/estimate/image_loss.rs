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
    /// Mean of the output times fixed weights (one per value): a linear functional that, unlike the mean,
    /// sees where in the image a change happens, and unlike L2 is unbiased at the primal's own seed
    /// (what gradient tests differentiate, docs/architecture.md).
    Weighted { output: Output, weights: Vec<f32> },
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
            ImageLoss::Mean(o) | ImageLoss::L2To { output: o, .. } | ImageLoss::Weighted { output: o, .. } => o,
        }
    }

    /// True when the adjoint depends on the rendered image (so a primal render must come first).
    pub fn needs_primal(&self) -> bool {
        !matches!(self, ImageLoss::Mean(_) | ImageLoss::Weighted { .. })
    }

    /// dLoss/d(output values), laid out like `Output::values`. `f` may be any frame of the right size when
    /// `needs_primal` is false.
    pub fn adjoint(&self, f: &Frame) -> Result<Vec<f32>> {
        let v = self.output().values(f)?;
        let n = v.len().max(1) as f32;
        match self {
            ImageLoss::Mean(_) => Ok(vec![1.0 / n; v.len()]),
            ImageLoss::Weighted { weights, .. } => {
                self.eval(f)?; // checks the size
                Ok(weights.iter().map(|w| w / n).collect())
            }
            ImageLoss::L2To { target, .. } => {
                self.eval(f)?; // checks the size
                Ok(v.iter().zip(target).map(|(&a, &b)| 2.0 * (a - b) / n).collect())
            }
        }
    }

    /// The adjoint as a function of each radiance pixel's own value, for losses where it is one (L2 on
    /// radiance): what the fused estimator (`radiance_vjp_cross`) needs. None for other losses.
    pub fn pixelwise(&self) -> Option<PixelwiseAdjoint<'_>> {
        match self {
            ImageLoss::L2To { output: Output::Radiance, target } => {
                Some(PixelwiseAdjoint { target, scale: 2.0 / target.len().max(1) as f32 })
            }
            _ => None,
        }
    }

    pub fn eval(&self, f: &Frame) -> Result<f64> {
        match self {
            ImageLoss::Mean(o) => {
                let v = o.values(f)?;
                Ok(v.iter().map(|&x| x as f64).sum::<f64>() / v.len().max(1) as f64)
            }
            ImageLoss::L2To { output, target: values } | ImageLoss::Weighted { output, weights: values } => {
                let v = output.values(f)?;
                let target = values;
                if v.len() != target.len() {
                    return Err(Error::Invalid(format!(
                        "loss target has {} values, the {}x{} render has {}",
                        target.len(),
                        f.width,
                        f.height,
                        v.len()
                    )));
                }
                let sum: f64 = match self {
                    ImageLoss::Weighted { .. } => v.iter().zip(target).map(|(&a, &w)| a as f64 * w as f64).sum(),
                    _ => v.iter().zip(target).map(|(&a, &b)| (a as f64 - b as f64).powi(2)).sum(),
                };
                Ok(sum / v.len() as f64)
            }
        }
    }
}

/// dLoss/dI_p = scale · (I_p − T_p) for every radiance pixel p: affine in the pixel's value, which is what
/// makes the fused estimator's products of independent halves unbiased.
#[derive(Clone, Copy, Debug)]
pub struct PixelwiseAdjoint<'a> {
    pub target: &'a [f32],
    pub scale: f32,
}

impl PixelwiseAdjoint<'_> {
    /// The adjoint of pixel `p` (RGB) when its rendered value is `value`.
    pub fn at(&self, p: usize, value: glam::Vec3) -> glam::Vec3 {
        (value - glam::Vec3::from_slice(&self.target[p * 3..p * 3 + 3])) * self.scale
    }

    /// The loss value of a whole radiance image (mean squared difference).
    pub fn loss(&self, image: &[f32]) -> f64 {
        image.iter().zip(self.target).map(|(&a, &b)| (a as f64 - b as f64).powi(2)).sum::<f64>()
            / image.len().max(1) as f64
    }
}
