//! The Vulkan backend's radiance adjoint with respect to object poses (shaders/grad/vjp/radiance_pose.comp, the
//! GLSL twin of grad/vjp/radiance_pose.rs): the primary boundary (silhouettes and creases chosen on the host by
//! `PrimaryEdges::build`, as the CPU does, sampled on the device, two paths of the integrator per edge sample;
//! one row per sample) and the ray-form interior term (each pixel's paths recorded and replayed in dual numbers
//! along every pose component that touches them, and with them the secondary boundary, edges drawn from the
//! host's edge trees; one row per pixel); rows summed in order (`vk_rows`). Vertex parameters stay on the CPU.

use super::vk_adjoint::{check_depth, check_image};
use super::vk_backend::{upload, upload_scene, VkBackend};
use super::vk_primary::{corner_ids, edge_words, pose_words};
use super::vk_rows::rows_in_order;
use crate::error::{Error, Result};
use crate::grad::{PoseLayout, PrimaryEdges, SecondaryEdges};
use crate::render::cpu::frame_params;
use crate::render::layout::{FrameParams, NONE};
use crate::render::SceneData;
use crate::scene::{RenderSettings, Scene};
use bytemuck::{Pod, Zeroable};
use psdr_vk::StorageBinding;

/// Push constants of the kernel (its `Push` block).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct RadiancePoseParams {
    pub fp: FrameParams,
    pub grad_len: u32,
    /// First edge sample of this pass and how many.
    pub begin: u32,
    pub count: u32,
    pub pose_entry_count: u32,
    pub edge_count: u32,
    pub total_length: f32,
    pub edge_samples: u32,
    /// PRIMARY (0) or INTERIOR (1).
    pub mode: u32,
    /// Secondary edge samples per scattering vertex (the secondary kernel only), the roots of the moving and
    /// static edge trees (NONE when empty), the number of moving edges and whether any belongs to an emitter.
    pub secondary_samples: u32,
    pub moving_root: u32,
    pub static_root: u32,
    pub moving_edges: u32,
    pub moving_emits: u32,
}

/// Pose entries whose vertex velocities the secondary kernels keep per path (MAX_ACTIVE_ENTRIES in
/// shaders/grad/vjp/radiance_pose_secondary.comp and _small.comp): the large kernel, and the small one for
/// drivers that refuse the large one's private arrays (NVIDIA's).
pub const SECONDARY_MAX_ACTIVE: [usize; 2] = [64, 16];

/// Set to 1 to let a device that lacks a feature a gradient kernel needs leave that term to the CPU.
pub const CPU_FALLBACK_ENV: &str = "PSDR_VK_CPU_FALLBACK";

const PRIMARY: u32 = 0;
const INTERIOR: u32 = 1;

impl VkBackend {
    /// `grad::radiance_primary_boundary` on the device (pose components and vertices alike).
    pub fn radiance_primary_on_device(
        &mut self,
        scene: &Scene,
        d: &SceneData,
        settings: &RenderSettings,
        pose: &PoseLayout,
        adjoint: &[f32],
        edge_samples: u32,
    ) -> Result<Option<Vec<f64>>> {
        let (pose_words, entry_count) = pose_words(pose);
        check_image(d, adjoint, "adjoint image")?;
        let mut grad = vec![0.0f64; pose.len];
        let edges = PrimaryEdges::build(scene, &d.camera, true, |o| pose.moves(o));
        if pose.len == 0 || edges.edges.is_empty() || edge_samples == 0 {
            return Ok(Some(grad));
        }
        let ctx = &self.ctx;
        let scene_bufs = upload_scene(ctx, d)?;
        let bufs = [
            Box::new(upload(ctx, "pose_words", &pose_words)?) as Box<dyn StorageBinding>,
            Box::new(upload(ctx, "edge_words", &edge_words(&edges))?) as Box<dyn StorageBinding>,
            Box::new(upload(ctx, "edge_cdf", &edges.cdf)?) as Box<dyn StorageBinding>,
            Box::new(upload(ctx, "adjoint", adjoint)?) as Box<dyn StorageBinding>,
        ];
        let params = RadiancePoseParams {
            fp: frame_params(d, settings),
            grad_len: pose.len as u32,
            pose_entry_count: entry_count,
            edge_count: edges.edges.len() as u32,
            total_length: edges.total_length,
            edge_samples,
            ..Default::default()
        };
        let inputs: Vec<&dyn StorageBinding> = scene_bufs.iter().chain(&bufs).map(|b| b.as_ref()).collect();
        // Two paths per edge sample.
        let per_pass = (self.pass_path_samples / 2).max(1) as usize;
        let push = |begin, count| RadiancePoseParams { begin, count, mode: PRIMARY, ..params };
        let corners = upload(ctx, "corner_ids", &corner_ids(d, pose))?;
        let tail = [&corners as &dyn StorageBinding];
        rows_in_order(
            ctx,
            self.radiance_pose_vjp.get(&self.ctx)?,
            &inputs,
            &tail,
            push,
            edge_samples as usize,
            per_pass,
            &mut grad,
        )?;
        Ok(Some(grad))
    }

    /// The interior term of `grad::radiance_pose_vjp` (its ray-form replay) on the device, with the secondary
    /// boundary (`secondary_samples` per scattering vertex) when it is asked for; `Ok(None)` when the secondary
    /// term is asked for and more entries could touch one path than the secondary kernel the driver builds keeps (SECONDARY_MAX_ACTIVE) (its kernel keeps each active
    /// entry's vertex velocities), or when the device lacks shaderFloat64 (its edge-tree descent is in double
    /// precision).
    pub fn radiance_pose_interior_on_device(
        &mut self,
        scene: &Scene,
        d: &SceneData,
        settings: &RenderSettings,
        pose: &PoseLayout,
        adjoint: &[f32],
        secondary_samples: u32,
    ) -> Result<Option<Vec<f64>>> {
        let (pose_words, entry_count) = pose_words(pose);
        // At most this many entries touch one path: every pose component, and per vertex block 3 axes of the 3
        // corners of the hit and light triangles of every vertex.
        let blocks = pose.vertex_blocks().len();
        let most_active = entry_count as usize - blocks + blocks * 18 * settings.max_depth as usize;
        if secondary_samples > 0 && self.radiance_pose_secondary_vjp.is_none() {
            // A missing device feature: the CPU only when asked.
            if std::env::var_os(CPU_FALLBACK_ENV).is_none_or(|v| v.is_empty() || v == "0") {
                return Err(Error::Backend(format!(
                    "the Vulkan device lacks shaderFloat64, which the secondary boundary kernel needs (its edge-tree \
                     descent is in double precision); set {CPU_FALLBACK_ENV}=1 to compute that term on the CPU, or \
                     --sppse 0 to leave it out"
                )));
            }
            note_once("the Vulkan device lacks shaderFloat64: the secondary boundary runs on the CPU");
            return Ok(None);
        }
        // The secondary kernel this device builds (the large one, else the small one), and how many entries per
        // path it keeps. A path that could have more is not a device limit but the kernel's: the CPU reference
        // takes the term (every backend computes it alike), as where the driver builds neither.
        let mut secondary = None;
        if let (true, Some(kernels)) = (secondary_samples > 0, self.radiance_pose_secondary_vjp.as_ref()) {
            let skip = usize::from(self.small_secondary_only);
            let built =
                kernels.iter().zip(SECONDARY_MAX_ACTIVE).skip(skip).find_map(|(k, cap)| match k.get(&self.ctx) {
                    Ok(k) => Some((k, cap)),
                    Err(e) => {
                        note_once(&format!(
                            "{e}: the device takes the secondary boundary's smaller kernel, or the CPU"
                        ));
                        None
                    }
                });
            match built {
                Some((kernel, cap)) if most_active <= cap => secondary = Some(kernel),
                _ => return Ok(None),
            }
        }
        let pixels = (d.camera.width * d.camera.height) as usize;
        check_image(d, adjoint, "adjoint image")?;
        check_depth(settings)?;
        let mut grad = vec![0.0f64; pose.len];
        if pose.len == 0 {
            return Ok(Some(grad));
        }
        let ctx = &self.ctx;
        let scene_bufs = upload_scene(ctx, d)?;
        let bufs = [
            Box::new(upload(ctx, "pose_words", &pose_words)?) as Box<dyn StorageBinding>,
            Box::new(upload::<u32>(ctx, "edge_words", &[])?) as Box<dyn StorageBinding>,
            Box::new(upload::<f32>(ctx, "edge_cdf", &[])?) as Box<dyn StorageBinding>,
            Box::new(upload(ctx, "adjoint", adjoint)?) as Box<dyn StorageBinding>,
        ];
        let fp = frame_params(d, settings);
        let mut params = RadiancePoseParams {
            fp,
            grad_len: pose.len as u32,
            pose_entry_count: entry_count,
            mode: INTERIOR,
            secondary_samples,
            moving_root: NONE,
            static_root: NONE,
            ..Default::default()
        };
        let inputs: Vec<&dyn StorageBinding> = scene_bufs.iter().chain(&bufs).map(|b| b.as_ref()).collect();
        let per_pass = (self.pass_path_samples / u64::from(fp.spp.max(1))).max(1) as usize;
        let corners = upload(ctx, "corner_ids", &corner_ids(d, pose))?;
        if secondary_samples == 0 {
            let push = |begin, count| RadiancePoseParams { begin, count, ..params };
            let tail = [&corners as &dyn StorageBinding];
            rows_in_order(
                ctx,
                self.radiance_pose_vjp.get(&self.ctx)?,
                &inputs,
                &tail,
                push,
                pixels,
                per_pass,
                &mut grad,
            )?;
            return Ok(Some(grad));
        }
        let words = SecondaryEdges::build(scene, pose).gpu_words();
        (params.moving_root, params.static_root, params.moving_edges, params.moving_emits) =
            (words.moving_root, words.static_root, words.moving, u32::from(words.moving_emits));
        let tail = [
            Box::new(upload(ctx, "sec_edge_words", &words.edges)?) as Box<dyn StorageBinding>,
            Box::new(upload(ctx, "tree_words", &words.nodes)?) as Box<dyn StorageBinding>,
            Box::new(upload(ctx, "edge_order", &words.order)?) as Box<dyn StorageBinding>,
        ];
        let tail: Vec<&dyn StorageBinding> =
            tail.iter().map(|b| b.as_ref()).chain([&corners as &dyn StorageBinding]).collect();
        let kernel = secondary.expect("chosen above when secondary samples are asked for");
        let push = |begin, count| RadiancePoseParams { begin, count, ..params };
        rows_in_order(ctx, kernel, &inputs, &tail, push, pixels, per_pass, &mut grad)?;
        Ok(Some(grad))
    }
}

/// Prints `msg` on stderr the first time it is asked to.
fn note_once(msg: &str) {
    static SAID: std::sync::Once = std::sync::Once::new();
    SAID.call_once(|| eprintln!("psdr: {msg}"));
}
