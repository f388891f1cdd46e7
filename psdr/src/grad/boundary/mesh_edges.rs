//! The welded edges of object meshes with what their adjacent triangles look like: the raw material of every
//! boundary term. Vertices are welded by exact object-space position per object (`scene::weld`; meshes with
//! per-face vertices, such as flat-shaded OBJs, still get adjacency); positions come from the scene's own
//! meshes, because positions rebuilt from the renderer's edge vectors do not weld bit-exactly.

use crate::scene::{weld, Scene};
use glam::Vec3;
use std::collections::HashMap;

/// The smallest `MeshEdge::strength`: an edge between two nearly coplanar faces is drawn 50 times less often
/// than a sharp one, never not at all (the estimator stays unbiased).
pub const MIN_EDGE_STRENGTH: f32 = 0.02;

/// One triangle next to an edge.
#[derive(Clone, Copy, Debug)]
pub struct Face {
    /// Unit geometric normal (winding, corrected for mirroring poses).
    pub normal: Vec3,
    pub material: usize,
    /// Shading normals at the edge's two endpoints (the face normal when the part has none).
    pub shading: [Vec3; 2],
    /// From the edge into the face: the triangle's third corner minus its part along the edge (not unit).
    pub inward: Vec3,
}

#[derive(Clone, Debug)]
pub struct MeshEdge {
    pub a: Vec3,
    pub b: Vec3,
    /// Welded vertex ids of `a` and `b` within the object (vertex-position parameters move them).
    pub ends: [u32; 2],
    pub object: u32,
    pub faces: Vec<Face>,
}

impl MeshEdge {
    /// Whether the edge can carry a visibility discontinuity seen from x: a mesh boundary, an edge whose two
    /// faces x sees from different sides, or a non-manifold edge.
    pub fn is_silhouette_from(&self, x: Vec3) -> bool {
        match self.faces.as_slice() {
            [f1, f2] => (f1.normal.dot(x - self.a) > 0.0) != (f2.normal.dot(x - self.a) > 0.0),
            _ => true,
        }
    }

    /// How strongly the edge can change the integrand, as a sampling weight factor: 1 for a mesh boundary, a
    /// non-manifold edge or a material change; for an edge between two faces of one material, the difference of
    /// their normals (|n1 - n2|, 2 sin of half the dihedral angle; the shading jump of a crease scales with it),
    /// kept above `MIN_EDGE_STRENGTH` so that no edge that can contribute is never drawn.
    pub fn strength(&self) -> f32 {
        match self.faces.as_slice() {
            [f1, f2] if f1.material == f2.material => {
                let d = (f1.normal - f2.normal)
                    .length()
                    .max((f1.shading[0] - f2.shading[0]).length())
                    .max((f1.shading[1] - f2.shading[1]).length());
                d.clamp(MIN_EDGE_STRENGTH, 1.0)
            }
            _ => 1.0,
        }
    }

    /// Whether shading jumps across the edge although both faces are visible from the same side: flat-shaded
    /// creases, split normals, material changes.
    pub fn is_crease(&self) -> bool {
        match self.faces.as_slice() {
            [f1, f2] => {
                f1.material != f2.material
                    || (f1.shading[0] - f2.shading[0]).length_squared() > 1e-10
                    || (f1.shading[1] - f2.shading[1]).length_squared() > 1e-10
            }
            _ => false,
        }
    }
}

/// What an edge sampler tests at every draw, packed without the faces' list (the GPU's `MeshEdge` in
/// shaders/grad/boundary/mesh_edges.glsl holds the same): endpoints, the two faces' normals (zero unless exactly
/// two faces meet), `MeshEdge::is_crease` and `MeshEdge::strength`.
#[derive(Clone, Copy, Debug)]
pub struct EdgeShape {
    pub a: Vec3,
    pub b: Vec3,
    pub n1: Vec3,
    pub n2: Vec3,
    pub two_faces: bool,
    pub crease: bool,
    pub strength: f32,
}

impl EdgeShape {
    pub fn of(e: &MeshEdge) -> EdgeShape {
        let (two_faces, n1, n2) = match e.faces.as_slice() {
            [f1, f2] => (true, f1.normal, f2.normal),
            _ => (false, Vec3::ZERO, Vec3::ZERO),
        };
        EdgeShape { a: e.a, b: e.b, n1, n2, two_faces, crease: e.is_crease(), strength: e.strength() }
    }

    /// `MeshEdge::is_silhouette_from`.
    pub fn is_silhouette_from(&self, x: Vec3) -> bool {
        !self.two_faces || (self.n1.dot(x - self.a) > 0.0) != (self.n2.dot(x - self.a) > 0.0)
    }
}

/// All welded edges of the objects for which `wanted(object)` holds, in a deterministic order.
pub fn mesh_edges(scene: &Scene, wanted: impl Fn(u32) -> bool) -> Vec<MeshEdge> {
    // A closed mesh has 3/2 edges per triangle: sized once, the map never rehashes (a large share of the
    // build on 100k-triangle meshes).
    let sides: usize = (scene.objects.iter().enumerate())
        .filter(|(i, _)| wanted(*i as u32))
        .flat_map(|(_, o)| o.parts.iter().map(|p| p.indices.len() * 3))
        .sum();
    let mut by_key: HashMap<(u32, u32, u32), usize> = HashMap::with_capacity(sides / 2 + 16);
    let mut edges: Vec<MeshEdge> = Vec::with_capacity(sides / 2 + 16);
    for (oi, obj) in scene.objects.iter().enumerate().filter(|(i, _)| wanted(*i as u32)) {
        let o = oi as u32;
        let m = obj.pose.matrix();
        let nm = obj.pose.normal_matrix();
        let mirror = if obj.pose.is_mirroring() { -1.0 } else { 1.0 };
        let welding = weld(obj);
        for (part, vid) in obj.parts.iter().zip(&welding.ids) {
            let world: Vec<Vec3> = part.positions.iter().map(|&p| m.transform_point3(p)).collect();
            let normals: Option<Vec<Vec3>> =
                part.normals.as_ref().map(|ns| ns.iter().map(|&n| (nm * n).normalize_or_zero()).collect());
            for tri in &part.indices {
                let vs = tri.map(|i| world[i as usize]);
                let n = (vs[1] - vs[0]).cross(vs[2] - vs[0]);
                if n.length_squared() == 0.0 {
                    continue; // degenerate: no area, no edges
                }
                let n = n.normalize() * mirror;
                for k in 0..3 {
                    let (ia, ib) = (tri[k] as usize, tri[(k + 1) % 3] as usize);
                    let (i, j) = (vid[ia], vid[ib]);
                    if i == j {
                        continue;
                    }
                    // Shading normals in the edge's (a, b) order.
                    let sn = |v: usize| normals.as_ref().map_or(n, |ns| ns[v]);
                    let at = *by_key.entry((o, i.min(j), i.max(j))).or_insert_with(|| {
                        let (a, b) = (vs[k], vs[(k + 1) % 3]);
                        edges.push(MeshEdge { a, b, ends: [i, j], object: o, faces: Vec::with_capacity(2) });
                        edges.len() - 1
                    });
                    let same_dir = edges[at].a == vs[k];
                    let shading = if same_dir { [sn(ia), sn(ib)] } else { [sn(ib), sn(ia)] };
                    let (ab, third) = (vs[(k + 1) % 3] - vs[k], vs[(k + 2) % 3] - vs[k]);
                    let inward = third - ab * (third.dot(ab) / ab.length_squared());
                    edges[at].faces.push(Face { normal: n, material: part.material, shading, inward });
                }
            }
        }
    }
    edges
}

/// The example room with a sphere of `rings` x `segments` added at (0.3, 1.0, -0.5), smooth or flat-shaded:
/// the edge tests' scene.
#[cfg(test)]
pub(crate) fn example_room_with_ball(rings: u32, segments: u32, flat: bool) -> Scene {
    use crate::scene::{load_scene, sphere_mesh, Object, Pose};
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/room/scene.json");
    let mut scene = load_scene(std::path::Path::new(path)).unwrap();
    let mut ball = sphere_mesh(0.3, rings, segments, false);
    ball.material = 0;
    if flat {
        ball.normals = None;
    }
    let pose = Pose { translation: Vec3::new(0.3, 1.0, -0.5), ..Pose::default() };
    scene.objects.push(Object { name: "ball".into(), parts: vec![ball], pose, emitter: None });
    scene
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sampler::Sampler;

    /// The packed record answers as the edge it packs: silhouette tests from random points, crease and
    /// strength, on the example room with a flat-shaded sphere (creases everywhere) added.
    #[test]
    fn edge_shape_answers_as_its_edge() {
        let scene = example_room_with_ball(8, 16, true);
        let edges = mesh_edges(&scene, |_| true);
        let ball = scene.objects.len() as u32 - 1;
        let (mut silhouettes, mut creases) = (0, 0);
        for (i, e) in edges.iter().enumerate() {
            let sh = EdgeShape::of(e);
            assert_eq!((sh.a, sh.b, sh.crease, sh.strength), (e.a, e.b, e.is_crease(), e.strength()));
            creases += usize::from(sh.crease && e.object == ball);
            for k in 0..8 {
                let s = Sampler { seed: 3, pixel: i as u32, sample: k };
                let x = Vec3::new(4.0 * s.get(0) - 2.0, 2.6 * s.get(1), 5.0 * s.get(2) - 2.5);
                assert_eq!(sh.is_silhouette_from(x), e.is_silhouette_from(x), "edge {i} from {x}");
                silhouettes += usize::from(sh.is_silhouette_from(x));
            }
        }
        assert!(silhouettes > 0 && creases > 0, "{silhouettes} silhouettes, {creases} creases on the ball");
    }
}
