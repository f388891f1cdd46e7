//! Analytic (reverse-mode) gradient of an image loss, averaged over independent seeds with a standard error, so
//! it can be compared with finite differences on equal terms.

use crate::backend::Backend;
use crate::error::Result;
use crate::grad::vjp::outputs::{moves_geometry, outputs_vjp, OutputAdjoints};
use crate::grad::vjp::radiance_pose::BoundarySamples;
use crate::grad::{mean_and_std_err, radiance_vjp_cross_on, GradLayout, ImageLoss, Output, ParamPath};
use crate::render::{Frame, SceneData};
use crate::scene::Scene;

/// Per gradient float: mean over replicas and its standard error (NaN with one replica).
#[derive(Clone, Debug, PartialEq)]
pub struct AdEstimate {
    pub mean: Vec<f64>,
    pub std_err: Vec<f64>,
    pub replicas: u32,
    /// The loss on the primal renders the adjoints came from, averaged over replicas; None for losses whose
    /// adjoint needs no render (then none was made). An optimiser gets its loss value without another render.
    pub loss: Option<f64>,
}

#[derive(Clone, Copy, Debug)]
pub struct AdOptions {
    /// Independent seeds averaged (the standard error needs at least 2).
    pub replicas: u32,
    /// Primary boundary (camera silhouette) samples per evaluation (sppe).
    pub edge_samples: u32,
    /// Secondary boundary (shadow and indirect) samples per scattering path vertex (sppse); as many again
    /// light-side direct-shadow samples per camera path (boundary/shadow.rs).
    pub secondary_edge_samples: u32,
}

impl Default for AdOptions {
    fn default() -> Self {
        AdOptions { replicas: 1, edge_samples: 1 << 16, secondary_edge_samples: 1 }
    }
}

/// Seeds of the adjoint pass are offset from the primal's so that a nonlinear loss (L2) multiplies independent
/// estimates of the image and of its derivative (the same seed would bias the product).
pub const ADJOINT_SEED_OFFSET: u32 = 0x9e37_79b9;

/// dLoss/dθ of `params`, in their order: radiance losses w.r.t. lights, materials (interior term) and object
/// poses and vertices (interior + primary, direct and indirect boundary terms); depth and mask losses w.r.t.
/// poses and vertices
/// (interior + primary boundary; they do not depend on lights or materials, whose gradients are zero).
/// An L2 radiance loss of light and material parameters only (spp >= 2) takes the fused estimator
/// (`radiance_vjp_cross`: one pass of paths, its two independently seeded halves giving each other's adjoint);
/// every other case renders the primal, then runs the backward pass with an independent seed.
pub fn analytic_gradient(
    scene: &Scene,
    params: &[ParamPath],
    loss: &ImageLoss,
    opts: &AdOptions,
    backend: &mut dyn Backend,
) -> Result<AdEstimate> {
    GradientEvaluator::default().gradient(scene, params, loss, opts, backend)
}

/// `analytic_gradient` for a scene that changes between calls (an optimiser's iterations): it keeps the scene
/// buffers of the last call and rebuilds the BVH only when some triangle moved (`SceneData::rebuild`), so
/// material and light stages do not pay for a tree build per iteration. Results equal `analytic_gradient`'s.
#[derive(Default)]
pub struct GradientEvaluator {
    data: Option<SceneData>,
}

impl GradientEvaluator {
    /// The scene buffers for `scene`: the previous call's, updated in place, or a fresh build. An optimiser
    /// renders and differentiates each iteration's scene from these.
    pub fn prepare(&mut self, scene: &Scene) -> Result<&SceneData> {
        let data = match self.data.take() {
            Some(previous) => previous.rebuild(scene)?,
            None => SceneData::build(scene)?,
        };
        Ok(self.data.insert(data))
    }

    pub fn gradient(
        &mut self,
        scene: &Scene,
        params: &[ParamPath],
        loss: &ImageLoss,
        opts: &AdOptions,
        backend: &mut dyn Backend,
    ) -> Result<AdEstimate> {
        let data = match self.data.take() {
            Some(previous) => previous.rebuild(scene)?,
            None => SceneData::build(scene)?,
        };
        let g = gradient_on(scene, &data, params, loss, opts, backend);
        self.data = Some(data);
        g
    }
}

fn gradient_on(
    scene: &Scene,
    data: &SceneData,
    params: &[ParamPath],
    loss: &ImageLoss,
    opts: &AdOptions,
    backend: &mut dyn Backend,
) -> Result<AdEstimate> {
    let (pose_params, other): (Vec<ParamPath>, Vec<ParamPath>) = params.iter().cloned().partition(moves_geometry);
    let material = GradLayout::new(scene, &other)?;
    let radiance = matches!(loss.output(), Output::Radiance);
    let boundary = BoundarySamples { primary: opts.edge_samples, secondary: opts.secondary_edge_samples };
    let (mut runs, mut losses) = (vec![], vec![]);
    for r in 0..opts.replicas.max(1) {
        let mut settings = scene.settings.clone();
        settings.seed = scene.settings.seed.wrapping_add(r);
        // An L2 radiance loss of material and light parameters: one fused pass (see grad/interior/fused_l2.rs).
        if let (true, true, true, Some(pixelwise)) =
            (radiance, pose_params.is_empty(), settings.spp >= 2, loss.pixelwise())
        {
            let seed_b = settings.seed.wrapping_add(ADJOINT_SEED_OFFSET);
            let (g, image) = radiance_vjp_cross_on(backend, data, &settings, &material, &pixelwise, seed_b)?;
            losses.push(pixelwise.loss(&image));
            runs.push(g);
            continue;
        }
        let adjoint = if loss.needs_primal() {
            let primal = backend.render(data, &settings, &|_, _| {})?;
            losses.push(loss.eval(&primal)?);
            loss.adjoint(&primal)?
        } else {
            loss.adjoint(&blank_frame(scene))?
        };
        settings.seed = settings.seed.wrapping_add(ADJOINT_SEED_OFFSET);
        let adjoints = match loss.output() {
            Output::Radiance => OutputAdjoints { radiance: Some(adjoint), ..Default::default() },
            Output::Depth => OutputAdjoints { depth: Some(adjoint), ..Default::default() },
            Output::Mask(o) => OutputAdjoints { masks: vec![(*o, adjoint)], ..Default::default() },
        };
        runs.push(outputs_vjp(scene, data, &settings, params, &adjoints, boundary, backend)?);
    }
    let len = runs[0].len();
    let (mut mean, mut std_err) = (vec![], vec![]);
    for i in 0..len {
        let (m, se) = mean_and_std_err(&runs.iter().map(|g| g[i]).collect::<Vec<_>>());
        mean.push(m);
        std_err.push(se);
    }
    let loss = (!losses.is_empty()).then(|| losses.iter().sum::<f64>() / losses.len() as f64);
    Ok(AdEstimate { mean, std_err, replicas: opts.replicas.max(1), loss })
}

/// A black frame of the scene's size (all AOVs zero): enough for losses whose adjoint ignores the image.
fn blank_frame(scene: &Scene) -> Frame {
    let n = (scene.camera.width * scene.camera.height) as usize;
    let objects = scene.objects.len();
    Frame {
        width: scene.camera.width,
        height: scene.camera.height,
        object_count: objects as u32,
        radiance: vec![0.0; n * 3],
        depth: vec![0.0; n],
        normal: vec![0.0; n * 3],
        albedo: vec![0.0; n * 3],
        object_id: vec![u32::MAX; n],
        coverage: vec![0.0; n * objects],
        rays: 0,
    }
}
