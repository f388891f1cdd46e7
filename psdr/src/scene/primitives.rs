//! Built-in primitives as triangle meshes in object space.

use super::MeshPart;
use glam::{Vec2, Vec3};

/// Rectangle in the xy plane centred at the origin, geometric normal +z (counter-clockwise winding),
/// uv (0,0) at (-w/2, -h/2).
pub fn rectangle_mesh(width: f32, height: f32) -> MeshPart {
    let (hw, hh) = (width * 0.5, height * 0.5);
    MeshPart {
        name: "rectangle".into(),
        material: 0,
        positions: vec![
            Vec3::new(-hw, -hh, 0.0),
            Vec3::new(hw, -hh, 0.0),
            Vec3::new(hw, hh, 0.0),
            Vec3::new(-hw, hh, 0.0),
        ],
        normals: None,
        uvs: Some(vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)]),
        indices: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// Axis-aligned box centred at the origin, flat shaded, uv [0,1]^2 per face.
/// `inward` flips the winding so geometric normals point inside (a room seen from within).
pub fn box_mesh(size: Vec3, inward: bool) -> MeshPart {
    let h = size * 0.5;
    // Each face: outward normal axis and the two in-plane axes (u, v) with u x v = normal.
    let faces = [
        (Vec3::X, Vec3::NEG_Z, Vec3::Y),
        (Vec3::NEG_X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::X, Vec3::NEG_Z),
        (Vec3::NEG_Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::NEG_Z, Vec3::NEG_X, Vec3::Y),
    ];
    let mut m = MeshPart { name: "box".into(), uvs: Some(Vec::new()), ..Default::default() };
    for (n, u, v) in faces {
        let base = m.positions.len() as u32;
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            m.positions.push((n + u * su + v * sv) * h);
            m.uvs.as_mut().unwrap().push(Vec2::new((su + 1.0) * 0.5, (sv + 1.0) * 0.5));
        }
        if inward {
            m.indices.push([base, base + 2, base + 1]);
            m.indices.push([base, base + 3, base + 2]);
        } else {
            m.indices.push([base, base + 1, base + 2]);
            m.indices.push([base, base + 2, base + 3]);
        }
    }
    m
}

/// UV sphere with smooth normals; `rings` >= 2 latitude bands, `segments` >= 3 longitude slices.
pub fn sphere_mesh(radius: f32, rings: u32, segments: u32, inward: bool) -> MeshPart {
    let (rings, segments) = (rings.max(2), segments.max(3));
    let mut m =
        MeshPart { name: "sphere".into(), normals: Some(Vec::new()), uvs: Some(Vec::new()), ..Default::default() };
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = 2.0 * std::f32::consts::PI * s as f32 / segments as f32;
            let n = Vec3::new(theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin());
            m.positions.push(n * radius);
            m.normals.as_mut().unwrap().push(if inward { -n } else { n });
            m.uvs.as_mut().unwrap().push(Vec2::new(s as f32 / segments as f32, 1.0 - r as f32 / rings as f32));
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (r * row + s, (r + 1) * row + s, (r + 1) * row + s + 1, r * row + s + 1);
            let mut tris = vec![];
            if r != 0 {
                tris.push([a, b, d]);
            }
            if r + 1 != rings {
                tris.push([b, c, d]);
            }
            for t in tris {
                m.indices.push(if inward { [t[0], t[2], t[1]] } else { t });
            }
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area_and_normal_sum(m: &MeshPart) -> (f32, Vec3) {
        let mut area = 0.0;
        let mut nsum = Vec3::ZERO;
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let n = (b - a).cross(c - a) * 0.5;
            area += n.length();
            nsum += n;
        }
        (area, nsum)
    }

    #[test]
    fn box_is_closed_with_exact_area_and_outward_normals() {
        let m = box_mesh(Vec3::new(1.0, 2.0, 3.0), false);
        let (area, nsum) = area_and_normal_sum(&m);
        assert!((area - 2.0 * (2.0 + 3.0 + 6.0)).abs() < 1e-5);
        assert!(nsum.length() < 1e-5, "closed surface");
        // Outward: every face normal points away from the centre.
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            assert!((b - a).cross(c - a).dot((a + b + c) / 3.0) > 0.0);
        }
    }

    #[test]
    fn sphere_area_converges_and_winding_is_outward() {
        let m = sphere_mesh(1.0, 64, 128, false);
        let (area, _) = area_and_normal_sum(&m);
        let exact = 4.0 * std::f32::consts::PI;
        assert!((area - exact).abs() / exact < 2e-3, "area {area}");
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
        }
    }
}
