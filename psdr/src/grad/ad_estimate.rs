//! Analytic (reverse-mode) gradient of an image loss, averaged over independent seeds with a standard error, so
//! it can be compared with finite differences on equal terms.

use super::{mean_and_std_err, radiance_vjp, GradLayout, ImageLoss, ParamPath};
use crate::backend::Backend;
use crate::error::Result;
use crate::render::SceneData;
use crate::scene::Scene;

/// Per gradient float: mean over replicas and its standard error (NaN with one replica).
#[derive(Clone, Debug, PartialEq)]
pub struct AdEstimate {
    pub mean: Vec<f64>,
    pub std_err: Vec<f64>,
    pub replicas: u32,
}

/// Seeds of the adjoint pass are offset from the primal's so that a nonlinear loss (L2) multiplies independent
/// estimates of the image and of its derivative (the same seed would bias the product).
const ADJOINT_SEED_OFFSET: u32 = 0x9e37_79b9;

pub fn interior_gradient(
    scene: &Scene,
    params: &[ParamPath],
    loss: &ImageLoss,
    replicas: u32,
    backend: &mut dyn Backend,
) -> Result<AdEstimate> {
    let layout = GradLayout::new(scene, params)?;
    let data = SceneData::build(scene)?;
    let mut runs = vec![];
    for r in 0..replicas.max(1) {
        let mut settings = scene.settings.clone();
        settings.seed = scene.settings.seed.wrapping_add(r);
        let adjoint = match loss {
            ImageLoss::Mean(_) => loss.radiance_adjoint(&dummy_frame(scene))?,
            _ => loss.radiance_adjoint(&backend.render(&data, &settings, &|_, _| {})?)?,
        };
        settings.seed = settings.seed.wrapping_add(ADJOINT_SEED_OFFSET);
        runs.push(radiance_vjp(&data, &settings, &layout, &adjoint)?);
    }
    let (mut mean, mut std_err) = (vec![], vec![]);
    for i in 0..layout.len {
        let (m, se) = mean_and_std_err(&runs.iter().map(|g| g[i]).collect::<Vec<_>>());
        mean.push(m);
        std_err.push(se);
    }
    Ok(AdEstimate { mean, std_err, replicas: replicas.max(1) })
}

/// A frame of the scene's size with black radiance: enough for losses whose adjoint ignores the image.
fn dummy_frame(scene: &Scene) -> crate::render::Frame {
    let n = (scene.camera.width * scene.camera.height) as usize;
    crate::render::Frame {
        width: scene.camera.width,
        height: scene.camera.height,
        radiance: vec![0.0; n * 3],
        ..Default::default()
    }
}
