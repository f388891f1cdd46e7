//! One camera path traced by the renderer's own integrator (`render::path_trace::trace_from`, which reports each
//! vertex to an observer), recorded vertex by vertex for the adjoint passes: what each vertex hit (triangle, barycentrics),
//! its local estimator terms, and the detached densities of its next-event and continuation samples.
//! Memory is one record per thread, bounded by max_depth, reused across samples.

use crate::render::bsdf::BsdfParams;
use crate::render::bvh::Hit;
use crate::render::layout::{FrameParams, NONE};
use crate::render::light::select_light;
use crate::render::path_trace::{trace_path_observed, ContinueEvent, NeeEvent, PathObserver};
use crate::render::shading::SurfacePoint;
use crate::render::SceneData;
use glam::{Vec2, Vec3};

/// Next-event estimation that reached its light.
#[derive(Clone, Copy, Debug, Default)]
pub struct RecordedNee {
    /// The light triangle.
    pub triangle: u32,
    /// World direction from the vertex to the light point.
    pub dir: Vec3,
    pub emitter: u32,
    pub radiance: Vec3,
    /// MIS weight / solid-angle density (detached: held fixed when differentiating): n = f · Le · this.
    pub w_over_pdf: f32,
    /// f · cos_o toward the light, and the light direction in the shading frame (for its derivatives).
    pub f: Vec3,
    pub wo_local: Vec3,
}

/// The BSDF-sampled continuation to the next vertex.
#[derive(Clone, Copy, Debug, Default)]
pub struct RecordedContinuation {
    /// World direction of the continuation ray.
    pub dir: Vec3,
    /// Solid-angle density of the sampled direction and the roulette survival probability (detached).
    pub pdf: f32,
    pub q: f32,
    /// β = f · cos / pdf / q, and the sampled direction in the shading frame (for its derivatives).
    pub beta: Vec3,
    pub wo_local: Vec3,
}

#[derive(Clone, Copy, Debug, Default)]
pub struct RecordedVertex {
    pub triangle: u32,
    pub u: f32,
    pub v: f32,
    /// Path throughput arriving at this vertex (T_k).
    pub throughput: Vec3,
    /// Emitter found here (NONE when none), its emission, what the emitter's radiance was multiplied by
    /// toward the path (`light::sky_shape`: d(emission)/d(radiance)), and its MIS weight.
    pub emitter: u32,
    pub emission: Vec3,
    pub emission_shape: Vec3,
    pub emission_mis: f32,
    pub nee: Option<RecordedNee>,
    pub next: Option<RecordedContinuation>,
    pub material: u32,
    /// The BSDF's inputs here (material values after texture lookup and clamping) and the incoming direction
    /// in the shading frame: derivatives w.r.t. material values are computed from them only when asked for.
    pub albedo: Vec3,
    pub roughness: f32,
    pub specular: f32,
    pub wi_local: Vec3,
    /// Texture coordinates after the uv transform.
    pub uv: Vec2,
    /// e_k + n_k: the radiance this vertex adds, relative to its throughput.
    pub local: Vec3,
}

#[derive(Clone, Debug, Default)]
pub struct PathRecord {
    pub origin: Vec3,
    pub dir: Vec3,
    pub vertices: Vec<RecordedVertex>,
}

impl RecordedVertex {
    pub fn bsdf(&self) -> BsdfParams {
        BsdfParams { albedo: self.albedo, roughness: self.roughness, specular: self.specular }
    }
}

impl PathRecord {
    /// The path's radiance estimate (what `trace_path` returns, up to rounding).
    pub fn radiance(&self) -> Vec3 {
        self.vertices.iter().map(|v| v.throughput * v.local).sum()
    }
}

/// Records sample `sample` of pixel (px, py) into `rec`.
pub fn record_path(d: &SceneData, fp: &FrameParams, px: u32, py: u32, sample: u32, rec: &mut PathRecord) {
    rec.vertices.clear();
    trace_path_observed(d, fp, px, py, sample, &mut Recorder { d, fp, rec });
}

/// The observer that writes a `PathRecord`.
struct Recorder<'a> {
    d: &'a SceneData,
    fp: &'a FrameParams,
    rec: &'a mut PathRecord,
}

impl Recorder<'_> {
    fn last(&mut self) -> &mut RecordedVertex {
        self.rec.vertices.last_mut().expect("events follow a hit")
    }
}

impl PathObserver for Recorder<'_> {
    fn start(&mut self, origin: Vec3, dir: Vec3) {
        (self.rec.origin, self.rec.dir) = (origin, dir);
    }

    fn hit(&mut self, hit: &Hit, sp: &SurfacePoint, beta: Vec3) {
        self.rec.vertices.push(RecordedVertex {
            triangle: hit.triangle,
            u: hit.u,
            v: hit.v,
            throughput: beta,
            emitter: NONE,
            material: self.d.triangles[hit.triangle as usize].material,
            uv: sp.uv,
            albedo: sp.bsdf.albedo,
            roughness: sp.bsdf.roughness,
            specular: sp.bsdf.specular,
            ..Default::default()
        });
    }

    fn emission(&mut self, emitter: u32, le: Vec3, shape: Vec3, mis: f32) {
        let v = self.last();
        (v.emitter, v.emission, v.emission_shape, v.emission_mis) = (emitter, le, shape, mis);
        v.local += le * mis;
    }

    fn scatter(&mut self, wi_local: Vec3) {
        self.last().wi_local = wi_local;
    }

    fn nee(&mut self, e: &NeeEvent) {
        let triangle = self.d.lights[select_light(&self.d.lights, self.fp.light_count, e.u_select) as usize].triangle;
        let v = self.last();
        v.local += e.f * e.radiance * e.w_over_pdf;
        v.nee = Some(RecordedNee {
            triangle,
            dir: e.dir,
            emitter: e.emitter,
            radiance: e.radiance,
            w_over_pdf: e.w_over_pdf,
            f: e.f,
            wo_local: e.wo_local,
        });
    }

    fn continuation(&mut self, e: &ContinueEvent) {
        let beta = e.weight / e.q; // q is 1 before roulette: exact
        self.last().next = Some(RecordedContinuation { dir: e.dir, pdf: e.pdf, q: e.q, beta, wo_local: e.wo_local });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::path_trace::trace_path;

    /// The recorder and the renderer trace the same paths: the recorded estimate is the rendered one (up to the
    /// order of its sums) and the vertex count is the hits', on a room with textures, glossy surfaces and a light.
    #[test]
    fn recorded_paths_are_the_rendered_paths() {
        let scene = crate::scene::load_scene(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../examples/room/scene.json"
        )))
        .unwrap();
        let d = SceneData::build(&scene).unwrap();
        let mut settings = scene.settings.clone();
        (settings.spp, settings.max_depth) = (4, 6);
        let fp = crate::render::cpu::frame_params(&d, &settings);
        let mut rec = PathRecord::default();
        let (mut paths, mut nonzero) = (0, 0);
        for py in (0..d.camera.height).step_by(7) {
            for px in (0..d.camera.width).step_by(5) {
                for sample in 0..fp.spp {
                    let primal = trace_path(&d, &fp, px, py, sample);
                    record_path(&d, &fp, px, py, sample, &mut rec);
                    let r = rec.radiance();
                    let tol = 1e-5 * primal.radiance.max_element().max(1e-3);
                    assert!((r - primal.radiance).abs().max_element() <= tol, "{r} vs {}", primal.radiance);
                    paths += 1;
                    nonzero += usize::from(r != Vec3::ZERO);
                }
            }
        }
        assert!(nonzero * 2 > paths, "{nonzero} of {paths} paths carry light");
    }
}
