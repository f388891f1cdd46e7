//! One backward pass for a whole loss: a loss may read radiance, depth and the masks of several objects at once;
//! their adjoint images go into one call that returns the gradient of every selected parameter.

use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::grad::path::velocity::PoseLayout;
use crate::grad::vjp::aov::AovAdjoints;
use crate::grad::vjp::radiance_pose::{radiance_pose_vjp, BoundarySamples};
use crate::grad::{aovs_vjp_on, radiance_vjp_on, GradLayout, ParamPath};
use crate::render::SceneData;
use crate::scene::{RenderSettings, Scene};

/// dLoss/d(output) of one loss evaluation, laid out like the frame's outputs (3 values per pixel for radiance,
/// 1 for depth and masks). Outputs the loss did not read are `None` / absent and cost nothing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OutputAdjoints {
    pub radiance: Option<Vec<f32>>,
    pub depth: Option<Vec<f32>>,
    /// (object index, adjoint of that object's coverage mask); each object at most once.
    pub masks: Vec<(usize, Vec<f32>)>,
}

impl OutputAdjoints {
    pub fn is_empty(&self) -> bool {
        self.radiance.is_none() && self.depth.is_none() && self.masks.is_empty()
    }
}

/// True for parameters that move geometry (differentiated in ray form, with boundary terms).
pub fn moves_geometry(p: &ParamPath) -> bool {
    matches!(
        p,
        ParamPath::Translation(_)
            | ParamPath::Yaw(_)
            | ParamPath::Rotation(_)
            | ParamPath::Scale(_)
            | ParamPath::Vertices(_)
    )
}

/// dLoss/dθ of `params` (in their order, each parameter's floats in a row) given the adjoints of every output
/// the loss read. `settings.seed` should differ from the seed of the primal render the adjoints came from (an
/// L2 loss's adjoint times the derivative is biased when both use the same paths).
/// Radiance: interior term of materials and lights (on `backend`'s device where its kernels cover them),
/// interior + primary + secondary boundary of poses and vertices. Depth and masks: poses and vertices (interior
/// + silhouettes, on the device for poses); their derivatives w.r.t. materials and lights are zero.
pub fn outputs_vjp(
    scene: &Scene,
    data: &SceneData,
    settings: &RenderSettings,
    params: &[ParamPath],
    adjoints: &OutputAdjoints,
    boundary: BoundarySamples,
    backend: &mut dyn Backend,
) -> Result<Vec<f64>> {
    let (pose_params, other): (Vec<ParamPath>, Vec<ParamPath>) = params.iter().cloned().partition(moves_geometry);
    let material = GradLayout::new(scene, &other)?;
    let pose = PoseLayout::new(scene, &pose_params)?;
    let mut g_material = vec![0.0; material.len];
    let mut g_pose = vec![0.0; pose.len];
    if let Some(radiance) = &adjoints.radiance {
        if material.len > 0 {
            g_material = radiance_vjp_on(backend, data, settings, &material, radiance)?;
        }
        if pose.len > 0 {
            g_pose = radiance_pose_vjp(scene, data, settings, &pose, radiance, boundary, backend)?;
        }
    }
    if pose.len > 0 && (adjoints.depth.is_some() || !adjoints.masks.is_empty()) {
        let masks: Vec<(usize, &[f32])> = adjoints.masks.iter().map(|(o, a)| (*o, a.as_slice())).collect();
        let aov = AovAdjoints { depth: adjoints.depth.as_deref(), masks: &masks };
        let g = aovs_vjp_on(backend, scene, data, settings, &pose, &aov, boundary.primary)?;
        g_pose.iter_mut().zip(g).for_each(|(a, b)| *a += b);
    }
    in_param_order(scene, params, g_material, g_pose)
}

/// Interleaves the material/light block and the pose block back into the caller's parameter order.
pub fn in_param_order(scene: &Scene, params: &[ParamPath], g_material: Vec<f64>, g_pose: Vec<f64>) -> Result<Vec<f64>> {
    let (mut gm, mut gp) = (g_material.into_iter(), g_pose.into_iter());
    let mut g = vec![];
    for p in params {
        let n = p.get(scene)?.len();
        let src: &mut dyn Iterator<Item = f64> = if moves_geometry(p) { &mut gp } else { &mut gm };
        let before = g.len();
        g.extend(src.take(n));
        if g.len() != before + n {
            return Err(Error::Invalid(format!("{p}: gradient layout has fewer values than the parameter")));
        }
    }
    Ok(g)
}
