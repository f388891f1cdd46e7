//! Geometric parameters as velocity fields: how a world-space point of an object moves per unit change of the
//! parameter (∂x/∂θ). Boundary and interior terms of geometric parameters both need exactly this. Pose
//! components move whole objects (affine fields of the point); a welded vertex's component moves the points of
//! the triangles around it with their barycentric weight of that vertex, so a velocity is asked for at a `Site`.

use crate::error::{Error, Result};
use crate::render::SceneData;
use crate::scene::ParamPath;
use crate::scene::{weld, Scene};
use glam::{Mat3, Quat, Vec3};

/// One differentiable pose component of one object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PoseComponent {
    /// Translation along world axis 0, 1, 2.
    Translation(usize),
    /// Rotation about the world up axis (+y) through the object's origin (ParamPath::Yaw).
    Yaw,
    /// Scale along the object's own axis 0, 1, 2.
    Scale(usize),
    /// Component 0, 1, 2 of the rotation vector (axis times angle) of ParamPath::Rotation, about the object's
    /// origin.
    Rotation(usize),
    /// Object-space axis `axis` of welded vertex `vertex` (ParamPath::Vertices; `scene::weld`).
    Vertex { vertex: u32, axis: u8 },
}

/// Where a point lies on its object's mesh, as the welded vertex ids around it and their weights (barycentrics
/// on a triangle, (1 − t, t) on an edge, one weight at a vertex). Only vertex components look at it.
pub type Site<'a> = &'a [(u32, f32)];

/// An affine velocity field u(x) = a + G (x − t), the field of every pose component but a vertex's (the GPU
/// kernels read these: shaders/grad/path/velocity.glsl).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AffineVelocity {
    pub a: Vec3,
    pub g: Mat3,
    pub t: Vec3,
}

impl AffineVelocity {
    pub fn at(&self, x: Vec3) -> Vec3 {
        let r = x - self.t;
        self.a + (self.g.x_axis * r.x + self.g.y_axis * r.y + self.g.z_axis * r.z)
    }

    /// ∂n/∂θ of a unit normal carried by the motion (`PoseLayout::normal_velocity`).
    pub fn normal(&self, n: Vec3) -> Vec3 {
        let gt_n = Vec3::new(self.g.x_axis.dot(n), self.g.y_axis.dot(n), self.g.z_axis.dot(n));
        -gt_n + n * n.dot(gt_n)
    }
}

/// The pose components a set of parameter paths asks for, with their offsets in the gradient vector.
#[derive(Clone, Debug)]
pub struct PoseLayout {
    /// (object index, component, offset in the gradient vector).
    pub entries: Vec<(u32, PoseComponent, usize)>,
    pub len: usize,
    translation: Vec<Vec3>,
    rotation: Vec<Quat>,
    scale: Vec<Vec3>,
    /// Per object: the entries of its pose components, and the entry of vertex 0 axis 0 when its vertices are
    /// parameters (vertex k axis a is entry base + 3k + a).
    pose_entries: Vec<Vec<usize>>,
    vertex_base: Vec<Option<usize>>,
    /// Welded vertex ids of each triangle's corners in scene order (as `SceneData` builds them), when some
    /// object's vertices are parameters.
    corners: Vec<[u32; 3]>,
}

impl PoseLayout {
    pub fn new(scene: &Scene, params: &[ParamPath]) -> Result<PoseLayout> {
        let mut l = PoseLayout {
            entries: vec![],
            len: 0,
            translation: scene.objects.iter().map(|o| o.pose.translation).collect(),
            rotation: scene.objects.iter().map(|o| o.pose.rotation).collect(),
            scale: scene.objects.iter().map(|o| o.pose.scale).collect(),
            pose_entries: vec![vec![]; scene.objects.len()],
            vertex_base: vec![None; scene.objects.len()],
            corners: vec![],
        };
        for p in params {
            let object = |name: &str| {
                scene
                    .object_index(name)
                    .map(|i| i as u32)
                    .ok_or_else(|| Error::Invalid(format!("{p}: no object named '{name}'")))
            };
            match p {
                ParamPath::Translation(n) => {
                    let o = object(n)?;
                    (0..3).for_each(|a| l.entries.push((o, PoseComponent::Translation(a), l.len + a)));
                    l.len += 3;
                }
                ParamPath::Yaw(n) => {
                    l.entries.push((object(n)?, PoseComponent::Yaw, l.len));
                    l.len += 1;
                }
                ParamPath::Rotation(n) => {
                    let o = object(n)?;
                    (0..3).for_each(|a| l.entries.push((o, PoseComponent::Rotation(a), l.len + a)));
                    l.len += 3;
                }
                ParamPath::Scale(n) => {
                    let o = object(n)?;
                    if l.scale[o as usize].min_element().abs() < 1e-12 {
                        return Err(Error::Invalid(format!("{p}: a zero scale has no derivative")));
                    }
                    (0..3).for_each(|a| l.entries.push((o, PoseComponent::Scale(a), l.len + a)));
                    l.len += 3;
                }
                ParamPath::Vertices(n) => {
                    let o = object(n)?;
                    if l.vertex_base[o as usize].is_some() {
                        return Err(Error::Invalid(format!("{p} is listed twice")));
                    }
                    l.vertex_base[o as usize] = Some(l.entries.len());
                    let count = weld(&scene.objects[o as usize]).positions.len() as u32;
                    for vertex in 0..count {
                        for axis in 0..3u8 {
                            l.entries.push((o, PoseComponent::Vertex { vertex, axis }, l.len));
                            l.len += 1;
                        }
                    }
                }
                _ => {
                    return Err(Error::Invalid(format!(
                        "{p}: geometric gradients cover object translation, yaw, rotation, scale and vertices; use \
                         --fd"
                    )))
                }
            }
        }
        for (e, &(o, c, _)) in l.entries.iter().enumerate() {
            if !matches!(c, PoseComponent::Vertex { .. }) {
                l.pose_entries[o as usize].push(e);
            }
        }
        if l.vertex_base.iter().any(Option::is_some) {
            l.corners = scene_corners(scene);
        }
        Ok(l)
    }

    /// True when some entry moves `object`.
    pub fn moves(&self, object: u32) -> bool {
        let o = object as usize;
        o < self.pose_entries.len() && (!self.pose_entries[o].is_empty() || self.vertex_base[o].is_some())
    }

    /// Welded vertex ids of the corners of `SceneData` triangle `ti` (zeros when no vertices are parameters:
    /// then nothing reads them).
    pub fn corners(&self, d: &SceneData, ti: u32) -> [u32; 3] {
        if self.corners.is_empty() {
            return [0; 3];
        }
        self.corners[d.triangle_source[ti as usize] as usize]
    }

    /// Appends to `out` (once each) the entries that move a point of `object` near the welded vertices `ids`:
    /// the object's pose components and the components of those vertices.
    pub fn entries_moving(&self, object: u32, ids: &[u32], out: &mut Vec<usize>) {
        let o = object as usize;
        if !self.moves(object) {
            return;
        }
        let mut add = |e: usize| {
            if !out.contains(&e) {
                out.push(e)
            }
        };
        self.pose_entries[o].iter().for_each(|&e| add(e));
        if let Some(base) = self.vertex_base[o] {
            for &id in ids {
                (0..3).for_each(|a| add(base + 3 * id as usize + a));
            }
        }
    }

    /// ∂u/∂x, the constant Jacobian of the (affine) velocity field of one component.
    pub fn velocity_gradient(&self, object: u32, c: PoseComponent) -> Mat3 {
        let o = object as usize;
        match c {
            PoseComponent::Translation(_) => Mat3::ZERO,
            // G v = ŷ × v.
            PoseComponent::Yaw => Mat3::from_cols(-Vec3::Z, Vec3::ZERO, Vec3::X),
            PoseComponent::Scale(a) => {
                let r = Mat3::from_quat(self.rotation[o]);
                r * Mat3::from_diagonal(Vec3::AXES[a] / self.scale[o][a]) * r.transpose()
            }
            PoseComponent::Rotation(a) => skew(self.angular_velocity(o, a)),
            // Not affine over the object; only `normal_velocity` asks, and stored normals do not follow vertices.
            PoseComponent::Vertex { .. } => Mat3::ZERO,
        }
    }

    /// World angular velocity of R = exp([r]×) per unit change of r_a: the left Jacobian of SO(3) times e_a,
    /// J(r) = I + (1 − cos θ)/θ² [r]× + (θ − sin θ)/θ³ [r]×².
    fn angular_velocity(&self, o: usize, a: usize) -> Vec3 {
        let r = self.rotation[o].to_scaled_axis();
        let t = r.length();
        let (c1, c2) = if t < 1e-4 {
            (0.5 - t * t / 24.0, 1.0 / 6.0 - t * t / 120.0)
        } else {
            ((1.0 - t.cos()) / (t * t), (t - t.sin()) / (t * t * t))
        };
        let e = Vec3::AXES[a];
        e + r.cross(e) * c1 + r.cross(r.cross(e)) * c2
    }

    /// ∂n/∂θ of a unit normal carried by the motion (normals transform with the inverse transpose).
    pub fn normal_velocity(&self, object: u32, c: PoseComponent, n: Vec3) -> Vec3 {
        let gt_n = self.velocity_gradient(object, c).transpose() * n;
        -gt_n + n * n.dot(gt_n)
    }

    /// The velocity field of a pose component (`None` for a vertex's, which depends on the site): translation
    /// moves every point by e_a; yaw, rotation and scale move x by G (x − T) with G the constant Jacobian of
    /// `velocity_gradient` (the same field as `velocity`, written for kernels that cannot branch on the
    /// component cheaply).
    pub fn affine_velocity(&self, object: u32, c: PoseComponent) -> Option<AffineVelocity> {
        let t = self.translation[object as usize];
        match c {
            PoseComponent::Vertex { .. } => None,
            PoseComponent::Translation(a) => Some(AffineVelocity { a: Vec3::AXES[a], g: Mat3::ZERO, t }),
            _ => Some(AffineVelocity { a: Vec3::ZERO, g: self.velocity_gradient(object, c), t }),
        }
    }

    /// True when some entry is a vertex component (whose field is not affine).
    pub fn has_vertices(&self) -> bool {
        self.vertex_base.iter().any(Option::is_some)
    }

    /// Per object whose vertices are parameters: the object, the gradient offset of its vertex 0 axis 0 (vertex
    /// k axis a is 3k + a further) and ∂x/∂(v_k)_a at weight 1 per axis, R (e_a S) (the GPU kernels' vertex
    /// blocks; `velocity` multiplies these by the point's weight of the vertex).
    pub fn vertex_blocks(&self) -> Vec<(u32, usize, [Vec3; 3])> {
        let mut out = vec![];
        for (o, base) in self.vertex_base.iter().enumerate() {
            if let Some(base) = base {
                let axes = [0, 1, 2].map(|a| self.rotation[o] * (Vec3::AXES[a] * self.scale[o]));
                out.push((o as u32, self.entries[*base].2, axes));
            }
        }
        out
    }

    /// ∂x/∂θ of the world-space point `x` of `object`, lying at `site` on its mesh, for one component.
    pub fn velocity(&self, object: u32, c: PoseComponent, x: Vec3, site: Site) -> Vec3 {
        let o = object as usize;
        match c {
            // x = T + R S Σ_k b_k v_k  ⇒  ∂x/∂(v_k)_a = b_k R S e_a.
            PoseComponent::Vertex { vertex, axis } => {
                let b: f32 = site.iter().filter(|s| s.0 == vertex).map(|s| s.1).sum();
                if b == 0.0 {
                    return Vec3::ZERO;
                }
                let e = Vec3::AXES[axis as usize];
                self.rotation[o] * (e * self.scale[o]) * b
            }
            PoseComponent::Translation(a) => Vec3::AXES[a],
            // x = T + Ry(ψ) R' S x_obj  ⇒  ∂x/∂ψ = ŷ × (x − T).
            PoseComponent::Yaw => Vec3::Y.cross(x - self.translation[o]),
            // x = T + R S x_obj  ⇒  ∂x/∂s_a = R e_a (x_obj)_a, with x_obj = S⁻¹ R⁻¹ (x − T).
            PoseComponent::Scale(a) => {
                let local = self.rotation[o].inverse() * (x - self.translation[o]);
                self.rotation[o] * (Vec3::AXES[a] * (local[a] / self.scale[o][a]))
            }
            PoseComponent::Rotation(a) => self.angular_velocity(o, a).cross(x - self.translation[o]),
        }
    }
}

/// Welded corner ids of every triangle of the scene in scene order, corners swapped as `SceneData` swaps them
/// under mirroring poses.
fn scene_corners(scene: &Scene) -> Vec<[u32; 3]> {
    let mut out = vec![];
    for o in &scene.objects {
        let w = weld(o);
        let flip = o.pose.is_mirroring();
        for (part, ids) in o.parts.iter().zip(&w.ids) {
            for t in &part.indices {
                let [a, b, c] = if flip { [t[0], t[2], t[1]] } else { *t };
                out.push([a, b, c].map(|i| ids[i as usize]));
            }
        }
    }
    out
}

/// The matrix of v ↦ w × v.
fn skew(w: Vec3) -> Mat3 {
    Mat3::from_cols(Vec3::new(0.0, w.z, -w.y), Vec3::new(-w.z, 0.0, w.x), Vec3::new(w.y, -w.x, 0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Velocities of every component match central differences of the posed point (set the parameter through
    /// its path, move a fixed object-space point), and normal velocities match those of transformed normals.
    #[test]
    fn velocities_match_finite_differences_of_the_pose() {
        use crate::scene::{Camera, Object, Pose, RenderSettings};
        let pose = Pose {
            translation: Vec3::new(0.3, -0.2, 1.0),
            rotation: Quat::from_scaled_axis(Vec3::new(0.4, -0.7, 0.2)),
            scale: Vec3::new(1.2, 0.7, 1.5),
        };
        let object = Object { name: "o".into(), parts: vec![], pose, emitter: None };
        let mut scene = Scene {
            camera: Camera::look_at(Vec3::Z, Vec3::ZERO, Vec3::Y, 40.0, 4, 4),
            settings: RenderSettings::default(),
            materials: vec![],
            textures: vec![],
            objects: vec![object],
            source: None,
            requires_grad: vec![],
        };
        let (x_obj, n_obj) = (Vec3::new(0.2, 0.5, -0.3), Vec3::new(0.3, 0.8, -0.2).normalize());
        let world = |s: &Scene| s.objects[0].pose.matrix().transform_point3(x_obj);
        let normal = |s: &Scene| (s.objects[0].pose.normal_matrix() * n_obj).normalize();
        for path in ["object/o/translation", "object/o/yaw", "object/o/rotation", "object/o/scale"] {
            let p: ParamPath = path.parse().unwrap();
            let layout = PoseLayout::new(&scene, std::slice::from_ref(&p)).unwrap();
            let value = p.get(&scene).unwrap();
            for (k, &(o, c, _)) in layout.entries.iter().enumerate() {
                let h = 1e-3;
                let at = |delta: f32, s: &mut Scene| {
                    let mut v = value.clone();
                    v[k] += delta;
                    p.set(s, &v).unwrap();
                    (world(s), normal(s))
                };
                let ((xp, np), (xm, nm)) = (at(h, &mut scene), at(-h, &mut scene));
                p.set(&mut scene, &value).unwrap();
                let x = world(&scene);
                let (fd_x, fd_n) = ((xp - xm) / (2.0 * h), (np - nm) / (2.0 * h));
                let (u, dn) = (layout.velocity(o, c, x, &[]), layout.normal_velocity(o, c, normal(&scene)));
                assert!((u - fd_x).length() < 2e-3 * (1.0 + fd_x.length()), "{path}[{k}]: {u} vs FD {fd_x}");
                assert!((dn - fd_n).length() < 2e-3 * (1.0 + fd_n.length()), "{path}[{k}] normal: {dn} vs FD {fd_n}");
                // The affine form the GPU kernels use is the same field (to f32 rounding).
                let field = layout.affine_velocity(o, c).expect("pose components are affine");
                let affine = field.at(x);
                assert!((affine - u).length() <= 1e-6 * (1.0 + u.length()), "{path}[{k}]: affine {affine} vs {u}");
                let dn_affine = field.normal(normal(&scene));
                assert!((dn_affine - dn).length() <= 1e-6 * (1.0 + dn.length()), "{path}[{k}]: {dn_affine} vs {dn}");
            }
        }
    }
}
