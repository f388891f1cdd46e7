//! Unit renders of several emitters from one set of camera paths (CPU backend). A unit render is the radiance
//! image with one emitter alone at radiance 1 and every other dark; the light fits need one per candidate light
//! (a dozen to a few dozen per fit, several fits per stage), and rendered one by one they took over a third of
//! real room02's light and material stages (its ceiling height search alone 28 of 291 s).
//!
//! With the same samples every one of those renders traces the same camera paths: the bounces, their
//! throughput and the roulette do not depend on which emitter emits (a dark emitter is a surface like any
//! other). Only two things differ: the next-event estimate, which selects from the emitting triangles (its own
//! emitter's alone), and the emission a path reaches, credited where it is that emitter's with the MIS weight
//! of that selection. So each path is traced once here, and at each vertex one next-event estimate is made per
//! emitter from the distribution its own render would select from (`UnitLights`), the emission credited to
//! the emitter's image. Each image is then `render_cpu`'s of that emitter alone, bit for bit: the same
//! operations in the same order (`trace_units` follows `path_trace::trace_from` line by line; the test below
//! compares the images' bits). Per vertex one closest-hit ray and a shadow ray per emitter, where the renders
//! one by one trace both per emitter.
//!
//! No GLSL twin: the Vulkan backend renders the emitters one by one (`Backend::unit_radiances`' default).

use super::bsdf::{bsdf_at, bsdf_eval_pdf, bsdf_sample_at};
use super::bvh::trace_closest;
use super::camera::camera_ray;
use super::cpu::frame_params;
use super::layout::*;
use super::light::{emitted_radiance, light_pdf_area_in, mis_power, sample_light_in, sky_shape};
use super::path_trace::unoccluded;
use super::sampler::*;
use super::scene_data::SceneData;
use super::shading::{offset_origin, surface_point};
use crate::error::{Error, Result};
use crate::scene::RenderSettings;
use glam::Vec3;
use rayon::prelude::*;

/// The selection distributions of the emitters whose unit renders are made together.
pub struct UnitLights {
    /// Per emitter rendered: the distribution `SceneData::lights` holds with it alone at radiance 1, and its
    /// count of real lights.
    sets: Vec<(Vec<LightGpu>, u32)>,
    /// Per emitter of the data: its place in `sets`, or NONE.
    slot: Vec<u32>,
    /// Per triangle: its place in its own emitter's distribution, or NONE.
    entry: Vec<u32>,
}

impl UnitLights {
    /// The distributions of `emitters` (indices into `data`'s emitters, each at most once), made by
    /// `SceneData::set_emitter_radiances` as each emitter's render alone makes them. Leaves `data` with every
    /// emitter at radiance 1: what the shared paths read as an emitter's radiance.
    pub fn new(data: &mut SceneData, emitters: &[usize]) -> Result<UnitLights> {
        let n = data.emitter_count as usize;
        let mut slot = vec![NONE; n];
        let mut entry = vec![NONE; data.triangles.len()];
        let mut sets = vec![];
        for (k, &e) in emitters.iter().enumerate() {
            if e >= n || slot[e] != NONE {
                return Err(Error::Invalid(format!(
                    "unit renders: emitter {e} is not one of the scene's {n} or is asked for twice"
                )));
            }
            slot[e] = k as u32;
            let alone: Vec<Vec3> = (0..n).map(|i| if i == e { Vec3::ONE } else { Vec3::ZERO }).collect();
            data.set_emitter_radiances(&alone)?;
            let count = data.light_count();
            for l in &data.lights[..count as usize] {
                entry[l.triangle as usize] = data.triangles[l.triangle as usize].light;
            }
            sets.push((data.lights.clone(), count));
        }
        data.set_emitter_radiances(&vec![Vec3::ONE; n])?;
        Ok(UnitLights { sets, slot, entry })
    }

    pub fn len(&self) -> usize {
        self.sets.len()
    }

    pub fn is_empty(&self) -> bool {
        self.sets.is_empty()
    }
}

/// Sample `sample` of pixel (px, py) added into `out[k]` for the k-th emitter of `units` (`trace_from` with
/// each emitter alone, one path for all).
#[inline(always)]
pub fn trace_units(
    d: &SceneData,
    fp: &FrameParams,
    units: &UnitLights,
    px: u32,
    py: u32,
    sample: u32,
    out: &mut [Vec3],
) {
    let cam = &d.camera;
    let s = Sampler { seed: fp.seed, pixel: py * cam.width + px, sample };
    let (jx, jy) = s.get2(DIM_PIXEL_X);
    let mut dir = camera_ray(cam, px as f32 + jx, py as f32 + jy);
    let mut origin = Vec3::from(cam.origin);
    let mut beta = Vec3::ONE;
    let mut prev_bsdf_pdf = 0.0f32;
    for depth in 0..fp.max_depth {
        let Some(hit) = trace_closest(&d.nodes, &d.triangles, origin, dir, f32::INFINITY) else {
            break;
        };
        let sp = surface_point(d, hit.triangle, hit.u, hit.v, dir);
        // Emission reached by the previous bounce (or seen directly), credited to its emitter's image with the
        // MIS weight of that emitter's own selection.
        let le = emitted_radiance(d, hit.triangle, sp.front, dir);
        let emitter = d.shading[hit.triangle as usize].emitter;
        if le != Vec3::ZERO && units.slot[emitter as usize] != NONE {
            let k = units.slot[emitter as usize] as usize;
            if depth == 0 {
                out[k] += beta * le;
            } else {
                let cos_l = sp.ng.dot(-dir).abs();
                let (lights, _) = &units.sets[k];
                let tri = &d.triangles[hit.triangle as usize];
                let light_pdf =
                    light_pdf_area_in(lights, units.entry[hit.triangle as usize], tri) * hit.t * hit.t / cos_l;
                let mis = mis_power(prev_bsdf_pdf, light_pdf);
                out[k] += beta * le * mis;
            }
        }
        if depth + 1 >= fp.max_depth {
            break;
        }
        let wi = sp.to_local(-dir);
        let bsdf = bsdf_at(&sp.bsdf, wi);
        let (u_select, u_lobe) = s.bounce2(depth, DIM_LIGHT_SELECT);
        // Next-event estimation: one point on each emitter, from its own selection.
        let (u1, u2) = s.bounce2(depth, DIM_LIGHT_U);
        for (k, (lights, count)) in units.sets.iter().enumerate() {
            if *count == 0 {
                continue;
            }
            let ls = sample_light_in(d, lights, *count, u_select, u1, u2);
            let to_light = ls.p - sp.p;
            let dist2 = to_light.dot(to_light);
            let dist = dist2.sqrt();
            let wl = to_light / dist;
            let cos_l = if ls.two_sided { ls.n.dot(-wl).abs() } else { ls.n.dot(-wl) };
            if cos_l > 0.0 && dist > 0.0 {
                let wo = sp.to_local(wl);
                let (f, pdf) = bsdf_eval_pdf(&bsdf, wo);
                if f != Vec3::ZERO && unoccluded(d, sp.p, sp.ng, ls.p, ls.n) {
                    let light_pdf = ls.pdf_area * dist2 / cos_l;
                    let w = mis_power(light_pdf, pdf);
                    let w_over_pdf = w / light_pdf;
                    let le = ls.radiance * sky_shape(ls.sky_gradient, wl);
                    out[k] += beta * f * le * w_over_pdf;
                }
            }
        }
        // Continue the path by sampling the BSDF.
        let (b1, b2) = s.bounce2(depth, DIM_BSDF_U);
        let Some(bs) = bsdf_sample_at(&bsdf, u_lobe, b1, b2) else {
            break;
        };
        beta *= bs.weight;
        prev_bsdf_pdf = bs.pdf;
        dir = sp.to_world(bs.wo).normalize();
        origin = offset_origin(sp.p, sp.ng, dir);
        if depth + 1 >= fp.rr_depth {
            let q = beta.max_element().min(0.95);
            if s.bounce(depth, DIM_ROULETTE) >= q || q.is_nan() {
                break;
            }
            beta /= q;
        }
    }
}

/// The unit render (radiance, RGB rows) of each emitter of `units` over `d` with `s`, as `render_cpu` renders
/// it with that emitter alone: each pixel sums its samples in order, so any thread count gives the same bits.
pub fn render_units_cpu(d: &SceneData, s: &RenderSettings, units: &UnitLights) -> Vec<Vec<f32>> {
    let fp = frame_params(d, s);
    let (w, h, n) = (d.camera.width as usize, d.camera.height as usize, units.len());
    let inv = s.spp as f32;
    // Per row: the emitters' rows one after another.
    let rows: Vec<Vec<f32>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut row = vec![0.0f32; n * w * 3];
            let (mut sums, mut path) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
            for x in 0..w {
                sums.fill(Vec3::ZERO);
                for sample in fp.sample_begin..fp.sample_begin + fp.sample_count {
                    path.fill(Vec3::ZERO);
                    trace_units(d, &fp, units, x as u32, y as u32, sample, &mut path);
                    sums.iter_mut().zip(&path).for_each(|(s, p)| *s += *p);
                }
                for (k, sum) in sums.iter().enumerate() {
                    row[(k * w + x) * 3..(k * w + x) * 3 + 3].copy_from_slice(&(*sum / inv).to_array());
                }
            }
            row
        })
        .collect();
    (0..n).map(|k| rows.iter().flat_map(|row| row[k * w * 3..(k + 1) * w * 3].iter().copied()).collect()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::cpu::render_cpu;
    use crate::scene::{Emitter, Scene};

    /// The example room, small, with three emitters: its ceiling light, the vase two-sided and the right wall
    /// a window whose radiance grows toward the sky, over surfaces that bounce light between them.
    fn scene() -> Scene {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/room/scene.json");
        let mut scene = crate::scene::load_scene(std::path::Path::new(path)).unwrap();
        (scene.camera.width, scene.camera.height) = (40, 30);
        let at = |scene: &Scene, name: &str| scene.objects.iter().position(|o| o.name == name).unwrap();
        let vase = at(&scene, "vase");
        scene.objects[vase].emitter = Some(Emitter::uniform(Vec3::new(1.0, 2.0, 3.0), true));
        let wall = at(&scene, "right_wall");
        scene.objects[wall].emitter =
            Some(Emitter { sky_gradient: Vec3::new(0.5, 0.7, 0.9), ..Emitter::uniform(Vec3::ONE, false) });
        scene.settings = RenderSettings { spp: 6, max_depth: 8, rr_depth: 2, seed: 17 };
        scene
    }

    /// Each image equals `render_cpu`'s of its emitter alone, bit for bit, for any subset and order of the
    /// emitters; and it is not nothing (each emitter lights the room).
    #[test]
    fn shared_paths_give_each_emitters_own_render() {
        let scene = scene();
        let mut data = SceneData::build(&scene).unwrap();
        let n = data.emitter_count as usize;
        assert!(n >= 3, "{n} emitters");
        for emitters in [(0..n).collect::<Vec<_>>(), vec![n - 1, 0]] {
            let units = UnitLights::new(&mut data, &emitters).unwrap();
            let images = render_units_cpu(&data, &scene.settings, &units);
            for (k, &e) in emitters.iter().enumerate() {
                let alone: Vec<Vec3> = (0..n).map(|i| if i == e { Vec3::ONE } else { Vec3::ZERO }).collect();
                let mut single = data.clone();
                single.set_emitter_radiances(&alone).unwrap();
                let want = render_cpu(&single, &scene.settings, &|_, _| {}).radiance;
                assert_eq!(images[k].len(), want.len());
                let differ = images[k].iter().zip(&want).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
                assert_eq!(differ, 0, "emitter {e}: {differ} values differ");
                assert!(want.iter().sum::<f32>() > 0.0, "emitter {e} lights nothing");
            }
        }
    }

    #[test]
    fn an_emitter_asked_for_twice_or_out_of_range_is_an_error() {
        let mut data = SceneData::build(&scene()).unwrap();
        let n = data.emitter_count as usize;
        assert!(UnitLights::new(&mut data, &[0, 0]).is_err());
        assert!(UnitLights::new(&mut data, &[n]).is_err());
        assert!(UnitLights::new(&mut data, &[]).unwrap().is_empty());
    }
}
