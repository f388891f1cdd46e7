//! The Vulkan backend's adjoint pass for the depth and coverage-mask AOVs with respect to object poses
//! (shaders/grad/vjp/aov.comp, the GLSL twin of `grad::aovs_vjp`): the depth's interior term, one invocation per
//! pixel, and the silhouette boundary term, one invocation per edge sample. The silhouette edges and the CDF of
//! their projected lengths are built here (`PrimaryEdges::build`, as the CPU does) and sampled on the device.
//! Each invocation writes its own row of gradients, summed in order (`vk_rows`). Vertex parameters (whose velocity depends on
//! where on the mesh a point lies) stay on the CPU.

use super::vk_backend::{upload, upload_scene, VkBackend};
use super::vk_primary::{corner_ids, edge_words, pose_words};
use super::vk_rows::rows_in_order;
use crate::error::Result;
use crate::grad::{masks_by_object, AovAdjoints, PoseLayout, PrimaryEdges};
use crate::render::layout::NONE;
use crate::render::SceneData;
use crate::scene::{RenderSettings, Scene};
use bytemuck::{Pod, Zeroable};
use psdr_vk::StorageBinding;

/// Push constants of the AOV kernel (its `Push` block).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct AovParams {
    pub seed: u32,
    pub spp: u32,
    /// DEPTH_INTERIOR (0) or SILHOUETTES (1).
    pub mode: u32,
    pub grad_len: u32,
    /// First pixel (or edge sample) of this pass and how many.
    pub begin: u32,
    pub count: u32,
    pub pose_entry_count: u32,
    pub edge_count: u32,
    pub total_length: f32,
    pub edge_samples: u32,
    pub has_depth: u32,
}

const DEPTH_INTERIOR: u32 = 0;
const SILHOUETTES: u32 = 1;

impl VkBackend {
    /// `grad::aovs_vjp` on the device (pose components and vertices alike; `Ok(Some)` always, the Option kept
    /// for the backends' common shape).
    pub fn aovs_vjp_on_device(
        &mut self,
        scene: &Scene,
        d: &SceneData,
        settings: &RenderSettings,
        pose: &PoseLayout,
        adjoints: &AovAdjoints,
        edge_samples: u32,
    ) -> Result<Option<Vec<f64>>> {
        let (pose_words, entry_count) = pose_words(pose);
        let of_object = masks_by_object(scene, d, adjoints)?;
        let len = pose.len;
        if len == 0 || (adjoints.depth.is_none() && adjoints.masks.is_empty()) {
            return Ok(Some(vec![0.0; len]));
        }
        let ctx = &self.ctx;
        let pixels = (d.camera.width * d.camera.height) as usize;
        let edges = PrimaryEdges::build(scene, &d.camera, false, |o| pose.moves(o));
        let mut mask_index = vec![NONE; of_object.len()];
        let mut mask_images: Vec<f32> = vec![];
        for (o, a) in of_object.iter().enumerate() {
            if let Some(a) = a {
                mask_index[o] = (mask_images.len() / pixels) as u32;
                mask_images.extend_from_slice(a);
            }
        }
        let scene_bufs = upload_scene(ctx, d)?;
        let bufs = [
            Box::new(upload(ctx, "pose_words", &pose_words)?) as Box<dyn StorageBinding>,
            Box::new(upload(ctx, "edge_words", &edge_words(&edges))?) as Box<dyn StorageBinding>,
            Box::new(upload(ctx, "edge_cdf", &edges.cdf)?) as Box<dyn StorageBinding>,
            Box::new(upload(ctx, "depth_adjoint", adjoints.depth.unwrap_or(&[]))?) as Box<dyn StorageBinding>,
            Box::new(upload(ctx, "mask_adjoints", &mask_images)?) as Box<dyn StorageBinding>,
            Box::new(upload(ctx, "mask_of_object", &mask_index)?) as Box<dyn StorageBinding>,
        ];
        let params = AovParams {
            seed: settings.seed,
            spp: settings.spp,
            grad_len: len as u32,
            pose_entry_count: entry_count,
            edge_count: edges.edges.len() as u32,
            total_length: edges.total_length,
            edge_samples,
            has_depth: u32::from(adjoints.depth.is_some()),
            ..Default::default()
        };
        let inputs: Vec<&dyn StorageBinding> = scene_bufs.iter().chain(&bufs).map(|b| b.as_ref()).collect();
        let corners = upload(ctx, "corner_ids", &corner_ids(d, pose))?;
        let tail = [&corners as &dyn StorageBinding];
        let pass = |mode: u32| move |begin, count| AovParams { mode, begin, count, ..params };
        // The CPU adds the depth interior to the boundary term; so does this.
        let mut boundary = vec![0.0f64; len];
        if !edges.edges.is_empty() && edge_samples > 0 {
            let per_pass = self.pass_path_samples as usize;
            rows_in_order(
                ctx,
                self.aov_vjp.get(&self.ctx)?,
                &inputs,
                &tail,
                pass(SILHOUETTES),
                edge_samples as usize,
                per_pass,
                &mut boundary,
            )?;
        }
        let mut interior = vec![0.0f64; len];
        if adjoints.depth.is_some() {
            let per_pass = (self.pass_path_samples / u64::from(settings.spp.max(1))).max(1) as usize;
            rows_in_order(
                ctx,
                self.aov_vjp.get(&self.ctx)?,
                &inputs,
                &tail,
                pass(DEPTH_INTERIOR),
                pixels,
                per_pass,
                &mut interior,
            )?;
        }
        Ok(Some(boundary.iter().zip(&interior).map(|(b, i)| b + i).collect()))
    }
}
