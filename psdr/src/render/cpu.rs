//! The CPU reference backend: the `path_trace` kernel body run over all pixels with rayon.
//! Each pixel is independent and sums its samples in order, so any thread count gives identical bits.

use super::frame::Frame;
use super::layout::FrameParams;
use super::path_trace::{object_at_pixel_center, path_trace, PixelSums};
use super::scene_data::SceneData;
use crate::scene::RenderSettings;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

pub fn frame_params(d: &SceneData, s: &RenderSettings) -> FrameParams {
    FrameParams {
        seed: s.seed,
        spp: s.spp,
        max_depth: s.max_depth,
        rr_depth: s.rr_depth,
        light_count: d.light_count(),
        object_count: d.object_count,
        sample_begin: 0,
        sample_count: s.spp,
    }
}

/// Renders all samples; `progress(rows_done, rows_total)` is called as rows finish.
pub fn render_cpu(d: &SceneData, s: &RenderSettings, progress: &(dyn Fn(usize, usize) + Sync)) -> Frame {
    let fp = frame_params(d, s);
    let (w, h) = (d.camera.width as usize, d.camera.height as usize);
    let nobj = d.object_count as usize;
    let mut f = Frame {
        width: w as u32,
        height: h as u32,
        object_count: nobj as u32,
        radiance: vec![0.0; w * h * 3],
        depth: vec![0.0; w * h],
        normal: vec![0.0; w * h * 3],
        albedo: vec![0.0; w * h * 3],
        object_id: vec![0; w * h],
        // At least one slot per pixel so rows chunk evenly; trimmed below when the scene has no objects.
        coverage: vec![0.0; w * h * nobj.max(1)],
        rays: 0,
    };
    let done = AtomicUsize::new(0);
    let inv = s.spp as f32;
    let rays: u64 = f
        .radiance
        .par_chunks_mut(w * 3)
        .zip(f.depth.par_chunks_mut(w))
        .zip(f.normal.par_chunks_mut(w * 3))
        .zip(f.albedo.par_chunks_mut(w * 3))
        .zip(f.object_id.par_chunks_mut(w))
        .zip(f.coverage.par_chunks_mut(w * nobj.max(1)))
        .enumerate()
        .map(|(y, (((((rad, dep), nor), alb), ids), cov))| {
            let mut rays = 0u64;
            for x in 0..w {
                let mut sums = PixelSums::default();
                let cov_px = &mut cov[x * nobj..(x + 1) * nobj];
                path_trace(d, &fp, x as u32, y as u32, &mut sums, cov_px);
                for c in cov_px.iter_mut() {
                    *c /= inv;
                }
                rad[x * 3..x * 3 + 3].copy_from_slice(&(sums.radiance / inv).to_array());
                dep[x] = sums.depth / inv;
                nor[x * 3..x * 3 + 3].copy_from_slice(&(sums.normal / inv).to_array());
                alb[x * 3..x * 3 + 3].copy_from_slice(&(sums.albedo / inv).to_array());
                ids[x] = object_at_pixel_center(d, x as u32, y as u32);
                rays += sums.rays as u64 + 1;
            }
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, h);
            rays
        })
        .sum();
    f.rays = rays;
    if nobj == 0 {
        f.coverage.clear();
    }
    f
}
