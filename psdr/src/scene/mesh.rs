//! Objects: named instances made of mesh parts (one material each), a pose, and an optional emitter.

use super::Pose;
use glam::{Vec2, Vec3};

/// A triangle mesh in object space with one material.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct MeshPart {
    /// Material group name from the OBJ file, or the primitive's name.
    pub name: String,
    pub material: usize,
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals; `None` means flat shading.
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    pub indices: Vec<[u32; 3]>,
}

/// An area light: every triangle of the object emits `radiance` (linear RGB, W/(m^2 sr)), shaped by
/// `sky_gradient` along the vertical.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emitter {
    pub radiance: Vec3,
    /// One-sided emitters emit on the side their geometric normal points to.
    pub two_sided: bool,
    /// Per channel g in [-1, 1]: a ray travelling in direction d that reaches the emitter sees
    /// `radiance * (1 + g * d.y)` (`render::light::sky_shape`). A window's daylight: with g > 0 the rays that
    /// look up through it (the sky) see more than those that look down (the ground); 0 is a uniform emitter.
    /// Linear in g, so a light fit finds it from two unit renders (g = +1 and -1); the shape is relative,
    /// so scaling the radiance keeps it.
    pub sky_gradient: Vec3,
}

impl Emitter {
    /// An emitter of the same radiance in every direction.
    pub fn uniform(radiance: Vec3, two_sided: bool) -> Emitter {
        Emitter { radiance, two_sided, sky_gradient: Vec3::ZERO }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    pub name: String,
    pub parts: Vec<MeshPart>,
    pub pose: Pose,
    pub emitter: Option<Emitter>,
}

impl Object {
    /// The radiance of a uniform emitter that emits the same power as this object's (`None` if it does not
    /// emit), for formats whose area lights have no directional profile (Mitsuba, glTF). A patch with
    /// emitting normal n sends out its rays about n, cosine-weighted, so the rays reaching it travel with a
    /// mean d_y of -2/3 n_y and its `sky_shape` averages 1 - 2/3 g n_y; over the object, weighted by area
    /// (both sides of a two-sided emitter: 1). A window on a wall (n_y = 0) keeps its radiance.
    pub fn uniform_equivalent_radiance(&self) -> Option<Vec3> {
        let e = self.emitter?;
        if e.two_sided || e.sky_gradient == Vec3::ZERO {
            return Some(e.radiance);
        }
        let m = self.pose.matrix();
        let sign = if self.pose.is_mirroring() { -1.0 } else { 1.0 };
        let (mut area, mut ny) = (0.0f64, 0.0f64);
        for part in &self.parts {
            for t in &part.indices {
                let [a, b, c] = t.map(|i| m.transform_point3(part.positions[i as usize]));
                let n2 = (b - a).cross(c - a) * sign;
                area += n2.length() as f64;
                ny += n2.y as f64;
            }
        }
        let mean_ny = if area > 0.0 { (ny / area) as f32 } else { 0.0 };
        Some(e.radiance * (Vec3::ONE - e.sky_gradient * (2.0 / 3.0 * mean_ny)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{rectangle_mesh, Pose};
    use glam::Quat;

    /// The uniform equivalent against the power integrated over the emitted hemisphere (a midpoint rule in
    /// cos theta and phi, 400 x 400: its error is below 1e-4): a ceiling panel facing down, a window facing
    /// sideways (unchanged), and a panel facing up.
    #[test]
    fn the_uniform_equivalent_emits_the_same_power() {
        let g = Vec3::new(0.8, -0.5, 0.3);
        for (rotation, n) in [
            (Quat::from_rotation_x(std::f32::consts::FRAC_PI_2), Vec3::NEG_Y),
            (Quat::from_rotation_y(std::f32::consts::FRAC_PI_2), Vec3::X),
            (Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2), Vec3::Y),
        ] {
            let o = Object {
                name: "panel".into(),
                parts: vec![rectangle_mesh(1.0, 0.5)],
                pose: Pose { rotation, ..Pose::default() },
                emitter: Some(Emitter { sky_gradient: g, ..Emitter::uniform(Vec3::new(2.0, 3.0, 4.0), false) }),
            };
            // Emitted direction w about n (cosine-weighted): the ray reaching the panel travels along -w.
            let (t, b) = n.any_orthonormal_pair();
            let k = 400;
            let mut power = Vec3::ZERO;
            for i in 0..k {
                let mu = (i as f32 + 0.5) / k as f32; // cos theta
                for j in 0..k {
                    let phi = std::f32::consts::TAU * (j as f32 + 0.5) / k as f32;
                    let s = (1.0 - mu * mu).sqrt();
                    let w = n * mu + t * (s * phi.cos()) + b * (s * phi.sin());
                    power += (Vec3::ONE + g * -w.y) * (2.0 * mu / (k * k) as f32);
                }
            }
            let got = o.uniform_equivalent_radiance().unwrap();
            let want = Vec3::new(2.0, 3.0, 4.0) * power;
            assert!((got - want).abs().max_element() < 1e-3, "normal {n}: {got} vs integrated {want}");
        }
    }
}
