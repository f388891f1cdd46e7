//! Flattens a `Scene` into the buffers both backends render from: world-space triangles ordered as the
//! BVH leaves reference them, per-triangle shading data, materials, texels, emitters and the light
//! distribution. Building this is the only place scene semantics turn into numbers.

use super::layout::*;
use super::shading::apply_uv_transform;
use crate::error::{Error, Result};
use crate::scene::{Color, MeshPart, Scalar, Scene};
use glam::Vec3;
use obvhs::{aabb::Aabb, cwbvh::builder::build_cwbvh, cwbvh::CwBvh, BvhBuildParams};
use rayon::prelude::*;
use std::time::Duration;

#[derive(Clone, Debug, Default)]
pub struct SceneData {
    pub nodes: Vec<BvhNode>,
    pub triangles: Vec<TriangleGeom>,
    pub shading: Vec<TriangleShading>,
    pub materials: Vec<MaterialGpu>,
    pub textures: Vec<TextureGpu>,
    pub texels: Vec<f32>,
    pub emitters: Vec<EmitterGpu>,
    pub lights: Vec<LightGpu>,
    pub camera: CameraGpu,
    /// Host only: for each triangle, its index in scene order (objects, parts, faces), before the BVH reordering.
    pub triangle_source: Vec<u32>,
    pub object_count: u32,
    /// Emitters of the scene (the buffer holds one dummy when there are none).
    pub emitter_count: u32,
    /// Total emitted power proxy (sum of area x luminance) — zero means the scene is dark.
    pub light_weight: f32,
}

/// Longest traversal stack (in node groups) the kernels allow (GLSL twin: BVH_STACK_SIZE in shaders/render/bvh.glsl).
/// Traversal pushes at most one group per level, and an 8-wide tree over millions of triangles is ~10 deep.
pub const BVH_STACK_SIZE: usize = 32;

pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl SceneData {
    pub fn build(scene: &Scene) -> Result<SceneData> {
        crate::render::frame::check_frame_memory(scene.camera.width, scene.camera.height, scene.objects.len())?;
        Self::build_over(scene, None)
    }

    /// `build(scene)` for a scene that may differ from the one `self` was built from only in appearance
    /// (materials, textures, light radiance, camera): when every triangle is where it was, bit for bit, the BVH
    /// and the triangle order are reused instead of rebuilt; the result is identical to `build(scene)` either
    /// way. An optimiser's material and light stages call this once per iteration.
    pub fn rebuild(&self, scene: &Scene) -> Result<SceneData> {
        crate::render::frame::check_frame_memory(scene.camera.width, scene.camera.height, scene.objects.len())?;
        Self::build_over(scene, Some(self))
    }

    fn build_over(scene: &Scene, previous: Option<&SceneData>) -> Result<SceneData> {
        crate::scene::validate::validate(scene).map_err(|(f, m)| Error::Invalid(format!("scene: {f}: {m}")))?;
        let mut d = SceneData { object_count: scene.objects.len() as u32, ..Default::default() };
        d.camera = camera(scene);
        for m in &scene.materials {
            d.materials.push(material(m));
        }
        for t in &scene.textures {
            d.textures.push(TextureGpu {
                offset: d.texels.len() as u32,
                width: t.width,
                height: t.height,
                channels: t.channels,
            });
            d.texels.extend_from_slice(&t.texels);
        }
        if d.texels.is_empty() {
            d.texels.push(0.0); // Vulkan cannot bind an empty buffer.
        }
        // Triangles in scene order; the BVH permutation is applied below. Each part is flattened on its own, in
        // parallel (a serial build of 150 000 triangles kept one core waiting on the other), then joined in order.
        let mut emitter_of = vec![None; scene.objects.len()];
        for (oi, o) in scene.objects.iter().enumerate() {
            if let Some(e) = o.emitter {
                d.emitters.push(EmitterGpu {
                    radiance: e.radiance.to_array(),
                    two_sided: e.two_sided as u32,
                    sky_gradient: e.sky_gradient.to_array(),
                    _pad0: 0.0,
                });
                emitter_of[oi] = Some(d.emitters.len() as u32 - 1);
            }
        }
        let parts: Vec<(usize, &MeshPart)> =
            scene.objects.iter().enumerate().flat_map(|(oi, o)| o.parts.iter().map(move |p| (oi, p))).collect();
        let flat: Vec<(Vec<TriangleGeom>, Vec<TriangleShading>)> =
            parts.par_iter().map(|&(oi, part)| flatten_part(scene, oi, part, emitter_of[oi])).collect();
        let count: usize = flat.iter().map(|f| f.0.len()).sum();
        let (mut tris, mut shading) = (Vec::with_capacity(count), Vec::with_capacity(count));
        for (t, sh) in flat {
            tris.extend(t);
            shading.extend(sh);
        }
        if !tris.is_empty() {
            let (nodes, order) = match previous.filter(|p| p.has_triangles_at(&tris)) {
                Some(p) => (p.nodes.clone(), p.triangle_source.clone()),
                None => super::bvh_cache::cached_bvh(&tris, || {
                    let bvh = build_bvh(&tris);
                    let depth = tree_depth(&bvh.nodes);
                    if depth > BVH_STACK_SIZE {
                        return Err(Error::Invalid(format!(
                            "scene: BVH depth {depth} exceeds the traversal stack ({BVH_STACK_SIZE})"
                        )));
                    }
                    Ok((bvh.nodes, bvh.primitive_indices))
                })?,
            };
            // Reorder triangles so leaves index them directly (no indirection in the kernels). Without spatial
            // splits every triangle sits in exactly one leaf: the order is a permutation.
            debug_assert_eq!(order.len(), tris.len());
            d.triangles = order.par_iter().map(|&i| tris[i as usize]).collect();
            d.shading = order.par_iter().map(|&i| shading[i as usize]).collect();
            d.triangle_source = order;
            d.nodes = nodes;
        }
        let materials = &d.materials;
        d.triangles.par_iter().zip(d.shading.par_iter_mut()).for_each(|(tri, sh)| {
            triangle_frame(tri, sh, &materials[tri.material as usize]);
        });
        d.emitter_count = d.emitters.len() as u32;
        d.distribute_light();
        // Never hand an empty buffer to Vulkan.
        if d.nodes.is_empty() {
            // A root with eight empty slots: traversal works unchanged and never reports a hit.
            d.nodes.push(BvhNode::default());
        }
        for v in [&mut d.triangles] {
            if v.is_empty() {
                v.push(TriangleGeom::default());
            }
        }
        if d.shading.is_empty() {
            d.shading.push(TriangleShading::default());
        }
        if d.materials.is_empty() {
            d.materials.push(MaterialGpu::default());
        }
        if d.textures.is_empty() {
            d.textures.push(TextureGpu::default());
        }
        if d.emitters.is_empty() {
            d.emitters.push(EmitterGpu::default());
        }
        Ok(d)
    }

    /// Sets every emitter's radiance (`radiance[e]` for the e-th object with an emitter, in scene order) and
    /// redoes what depends on it, the light distribution, keeping the triangles, BVH and shading: the result
    /// equals `build` of the scene with those radiances, at a small part of its cost. The light fits render
    /// one geometry once per candidate light, each lit alone; flattening 150 000 triangles for each of those
    /// renders kept a core waiting on the other (about a quarter of the ceiling search on real rooms).
    pub fn set_emitter_radiances(&mut self, radiance: &[Vec3]) -> Result<()> {
        if radiance.len() != self.emitter_count as usize {
            return Err(Error::Invalid(format!(
                "scene data: {} emitter radiances given for {} emitters",
                radiance.len(),
                self.emitter_count
            )));
        }
        for (e, r) in self.emitters.iter_mut().zip(radiance) {
            e.radiance = r.to_array();
        }
        self.distribute_light();
        Ok(())
    }

    /// The light-selection distribution from the emitters as they are: each emitting triangle chosen in
    /// proportion to its area x luminance (twice that for a two-sided emitter; dark ones not at all), listed in
    /// scene order so that the BVH build (leaf sizes, build quality) never changes which light a sample picks,
    /// and each triangle's `light` pointing into it.
    fn distribute_light(&mut self) {
        // (scene order, BVH position, weight) of every emitting triangle.
        let mut emitting: Vec<(u32, usize, f32)> = (0..self.triangle_source.len())
            .into_par_iter()
            .filter(|&ti| self.shading[ti].emitter != NONE)
            .map(|ti| {
                let (t, em) = (&self.triangles[ti], &self.emitters[self.shading[ti].emitter as usize]);
                let area = 0.5 * Vec3::from(t.e1).cross(Vec3::from(t.e2)).length();
                let side = if em.two_sided != 0 { 2.0 } else { 1.0 };
                (self.triangle_source[ti], ti, luminance(Vec3::from(em.radiance)) * side * area)
            })
            .collect();
        emitting.sort_unstable_by_key(|e| e.0);
        self.lights.clear();
        for &(_, ti, _) in &emitting {
            self.triangles[ti].light = NONE;
        }
        let total: f64 = emitting.iter().fold(0.0, |acc, e| acc + e.2 as f64);
        self.light_weight = total as f32;
        if total > 0.0 {
            let mut acc = 0.0f64;
            for &(_, ti, w) in emitting.iter().filter(|e| e.2 > 0.0) {
                acc += w as f64;
                self.triangles[ti].light = self.lights.len() as u32;
                self.lights.push(LightGpu {
                    triangle: ti as u32,
                    emitter: self.shading[ti].emitter,
                    cdf: (acc / total) as f32,
                    pmf: (w as f64 / total) as f32,
                });
            }
            self.lights.last_mut().unwrap().cdf = 1.0;
        }
        if self.lights.is_empty() {
            self.lights.push(LightGpu { triangle: NONE, emitter: NONE, cdf: 1.0, pmf: 0.0 });
        }
    }

    /// Number of real lights (the buffer holds one dummy when there are none).
    pub fn light_count(&self) -> u32 {
        if self.lights[0].triangle == NONE {
            0
        } else {
            self.lights.len() as u32
        }
    }

    /// True when `tris` (scene order) are this data's triangles, vertex for vertex bit-identical: the BVH
    /// built over them would be this one (obvhs builds deterministically from the bounds).
    fn has_triangles_at(&self, tris: &[TriangleGeom]) -> bool {
        let bits = |v: [f32; 3]| v.map(f32::to_bits);
        self.triangle_source.len() == tris.len()
            && self.triangle_source.iter().zip(&self.triangles).all(|(&src, t)| {
                let n = &tris[src as usize];
                bits(n.v0) == bits(t.v0) && bits(n.e1) == bits(t.e1) && bits(n.e2) == bits(t.e2)
            })
    }

    /// True when the BVH is the empty-scene placeholder.
    pub fn is_empty(&self) -> bool {
        self.triangles.len() == 1 && self.triangles[0] == TriangleGeom::default()
    }
}

fn camera(scene: &Scene) -> CameraGpu {
    camera_gpu(&scene.camera)
}

/// The camera as the kernels see it.
pub fn camera_gpu(c: &crate::scene::Camera) -> CameraGpu {
    CameraGpu {
        origin: c.origin.to_array(),
        tan_half_fov: c.tan_half_fov(),
        forward: c.forward.to_array(),
        aspect: c.aspect(),
        right: c.right().to_array(),
        width: c.width,
        up: c.up.to_array(),
        height: c.height,
    }
}

fn material(m: &crate::scene::Material) -> MaterialGpu {
    let (albedo, albedo_tex) = match m.albedo {
        Color::Constant(c) => (c.to_array(), NONE),
        Color::Texture(t) => ([1.0; 3], t as u32),
    };
    let scalar = |s: Scalar| match s {
        Scalar::Constant(v) => (v, NONE),
        Scalar::Texture(t) => (1.0, t as u32),
    };
    let (roughness, roughness_tex) = scalar(m.roughness);
    let (specular, specular_tex) = scalar(m.specular);
    let [r0, r1] = m.uv_transform.rows();
    MaterialGpu {
        albedo,
        albedo_tex,
        roughness,
        roughness_tex,
        specular,
        specular_tex,
        normal_tex: m.normal_map.map_or(NONE, |t| t as u32),
        _pad: [0; 3],
        uv_row0: [r0[0], r0[1], r0[2], 0.0],
        uv_row1: [r1[0], r1[1], r1[2], 0.0],
    }
}

/// One part of object `oi` in world space: its triangles (wound as the pose leaves them) and their shading data.
fn flatten_part(
    scene: &Scene,
    oi: usize,
    part: &MeshPart,
    emitter: Option<u32>,
) -> (Vec<TriangleGeom>, Vec<TriangleShading>) {
    let pose = &scene.objects[oi].pose;
    let (m, nm, flip) = (pose.matrix(), pose.normal_matrix(), pose.is_mirroring());
    let p: Vec<Vec3> = part.positions.iter().map(|&v| m.transform_point3(v)).collect();
    let n: Option<Vec<Vec3>> =
        part.normals.as_ref().map(|ns| ns.iter().map(|&v| (nm * v).normalize_or_zero()).collect());
    let mut tris = Vec::with_capacity(part.indices.len());
    let mut shading = Vec::with_capacity(part.indices.len());
    for t in &part.indices {
        let [a, b, c] = if flip { [t[0], t[2], t[1]] } else { *t }.map(|i| i as usize);
        let (v0, e1, e2) = (p[a], p[b] - p[a], p[c] - p[a]);
        tris.push(TriangleGeom {
            v0: v0.to_array(),
            material: part.material as u32,
            e1: e1.to_array(),
            object: oi as u32,
            e2: e2.to_array(),
            light: NONE,
        });
        let mut s = TriangleShading { emitter: emitter.unwrap_or(NONE), ..Default::default() };
        if let Some(n) = &n {
            s.flags |= SHADING_HAS_NORMALS;
            (s.n0, s.n1, s.n2) = (n[a].to_array(), n[b].to_array(), n[c].to_array());
        }
        if let Some(uv) = &part.uvs {
            s.flags |= SHADING_HAS_UVS;
            (s.uv0, s.uv1, s.uv2) = (uv[a].to_array(), uv[b].to_array(), uv[c].to_array());
        }
        shading.push(s);
    }
    (tris, shading)
}

/// The BVH over triangle bounds (degenerate triangles stay in: they can never be hit). Its leaves index
/// `primitive_indices`, so the kernels want the triangles reordered by it.
pub fn build_bvh(tris: &[TriangleGeom]) -> CwBvh {
    let aabbs: Vec<Aabb> = tris
        .iter()
        .map(|t| {
            let (lo, hi) = triangle_bounds(t);
            Aabb::new(lo.into(), hi.into())
        })
        .collect();
    build_cwbvh(&aabbs, bvh_build_params(), &mut Duration::default())
}

/// The per-triangle part of `surface_point`'s frame: the unit geometric normal and, for a uv-mapped triangle,
/// dp/du' and dp/dv' for the material's transformed uv (the same operations as shading a hit used to do).
fn triangle_frame(tri: &TriangleGeom, sh: &mut TriangleShading, mat: &MaterialGpu) {
    let (e1, e2) = (Vec3::from(tri.e1), Vec3::from(tri.e2));
    sh.ng = e1.cross(e2).normalize().to_array();
    let [uv0, uv1, uv2] = [sh.uv0, sh.uv1, sh.uv2].map(|uv| apply_uv_transform(mat, uv.into()));
    let (duv1, duv2) = (uv1 - uv0, uv2 - uv0);
    let det = duv1.x * duv2.y - duv1.y * duv2.x;
    if det != 0.0 && sh.flags & SHADING_HAS_UVS != 0 {
        sh.flags |= SHADING_HAS_TANGENT;
        sh.dpdu = ((e1 * duv2.y - e2 * duv1.y) * (1.0 / det)).to_array();
        sh.dpdv = ((e2 * duv1.x - e1 * duv2.x) * (1.0 / det)).to_array();
    }
}

/// A triangle's bounds as the BVH sees them (the build's input, and what a refit requantizes from).
pub(crate) fn triangle_bounds(t: &TriangleGeom) -> (Vec3, Vec3) {
    let v0 = Vec3::from(t.v0);
    let (v1, v2) = (v0 + Vec3::from(t.e1), v0 + Vec3::from(t.e2));
    (v0.min(v1).min(v2), v0.max(v1).max(v2))
}

/// obvhs's medium build: PLOC + reinsertion for the binary tree, converted to the 8-wide compressed tree with
/// at most 3 triangles per leaf (the encoding's limit) by the cost-optimal collapse of Ylitie et al.
/// Both backends trace this same tree.
fn bvh_build_params() -> BvhBuildParams {
    BvhBuildParams::medium_build()
}

/// Depth of the tree (root = 1); traversal pushes at most one group per level, so the stack needs `depth`.
fn tree_depth(nodes: &[BvhNode]) -> usize {
    let mut deepest = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, depth)) = stack.pop() {
        deepest = deepest.max(depth);
        let n = &nodes[i];
        for k in 0..n.imask.count_ones() as usize {
            stack.push((n.child_base_idx as usize + k, depth + 1));
        }
    }
    deepest
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load_scene;
    use crate::scene::ParamPath;

    fn room() -> Scene {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/room/scene.json");
        load_scene(std::path::Path::new(path)).unwrap()
    }

    fn set(scene: &Scene, path: &str, f: impl Fn(f32) -> f32) -> Scene {
        let mut s = scene.clone();
        let p: ParamPath = path.parse().unwrap();
        let v: Vec<f32> = p.get(&s).unwrap().iter().map(|&x| f(x)).collect();
        p.set(&mut s, &v).unwrap();
        s
    }

    fn assert_same(a: &SceneData, b: &SceneData, what: &str) {
        assert!(a.nodes == b.nodes && a.triangle_source == b.triangle_source, "{what}: BVH");
        assert!(a.triangles == b.triangles && a.shading == b.shading, "{what}: triangles");
        assert!(a.materials == b.materials && a.textures == b.textures && a.texels == b.texels, "{what}: materials");
        assert!(a.emitters == b.emitters && a.lights == b.lights && a.camera == b.camera, "{what}: lights");
        assert_eq!(a.light_weight.to_bits(), b.light_weight.to_bits(), "{what}: light weight");
    }

    /// Emitter radiances set on built data give what building the scene with those radiances gives, field for
    /// field: a light turned off, one turned on, a two-sided one, all dark; a wrong count is an error.
    #[test]
    fn set_emitter_radiances_equals_building_the_relit_scene() {
        let mut scene = room();
        let plain = scene.objects.iter().position(|o| o.emitter.is_none()).unwrap();
        scene.objects[plain].emitter = Some(crate::scene::Emitter::uniform(Vec3::new(1.0, 2.0, 3.0), true));
        let emitting: Vec<usize> = (0..scene.objects.len()).filter(|&i| scene.objects[i].emitter.is_some()).collect();
        assert_eq!(emitting.len(), 2);
        let mut data = SceneData::build(&scene).unwrap();
        assert_eq!(data.emitter_count, 2);
        let cases = [
            [Vec3::ZERO, Vec3::ONE],
            [Vec3::new(2.0, 1.0, 0.5), Vec3::ZERO],
            [Vec3::splat(3.0), Vec3::new(4.0, 0.0, 1.0)],
            [Vec3::ZERO, Vec3::ZERO],
        ];
        for radiance in cases {
            let mut relit = scene.clone();
            for (&o, &r) in emitting.iter().zip(&radiance) {
                relit.objects[o].emitter.as_mut().unwrap().radiance = r;
            }
            data.set_emitter_radiances(&radiance).unwrap();
            assert_same(&data, &SceneData::build(&relit).unwrap(), &format!("radiances {radiance:?}"));
        }
        assert!(data.set_emitter_radiances(&[Vec3::ONE]).is_err());
    }

    /// `rebuild` equals a fresh `build` after appearance changes (which reuse the tree) and after geometry
    /// changes (which must not); the reuse test itself tells the two apart.
    #[test]
    fn rebuild_equals_build_and_reuses_the_tree_only_for_unmoved_triangles() {
        let base = room();
        let first = SceneData::build(&base).unwrap();
        let appearance = [
            set(&base, "material/wall/albedo", |x| x * 0.8),
            set(&base, "light/ceiling_light/radiance", |x| x * 3.0),
            set(&base, "material/oak_floor/uv_scale", |x| x * 1.3),
        ];
        for (i, s) in appearance.iter().enumerate() {
            let tris_unmoved = first.rebuild(s).unwrap();
            assert_same(&tris_unmoved, &SceneData::build(s).unwrap(), &format!("appearance change {i}"));
        }
        let moved = set(&base, &format!("object/{}/translation", base.objects[1].name), |x| x + 0.01);
        let rebuilt = first.rebuild(&moved).unwrap();
        assert_same(&rebuilt, &SceneData::build(&moved).unwrap(), "moved object");
        assert!(rebuilt.triangles != first.triangles, "the moved object's triangles moved");
        // The reuse decision: unmoved triangles are recognised, moved ones are not.
        let tris_of = |d: &SceneData| {
            let mut t = vec![TriangleGeom::default(); d.triangles.len()];
            for (at, &src) in d.triangle_source.iter().enumerate() {
                t[src as usize] = d.triangles[at];
            }
            t
        };
        assert!(first.has_triangles_at(&tris_of(&first)));
        assert!(!first.has_triangles_at(&tris_of(&rebuilt)));
    }
}
