//! Checks a `Scene` built in code or loaded from a file; returns (field, message) for the first problem.
//! The renderer calls this too, so a NaN parameter set programmatically is caught before it makes a NaN image.

use super::{Color, Scalar, Scene};

pub fn validate(scene: &Scene) -> Result<(), (String, String)> {
    let c = &scene.camera;
    if c.width == 0 || c.height == 0 {
        return Err(("camera.width/height".into(), format!("resolution {}x{} must be positive", c.width, c.height)));
    }
    if !(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
        return Err(("camera.fov_y".into(), format!("{} is not in (0, 180) degrees", c.fov_y_deg)));
    }
    if !(c.origin.is_finite() && c.forward.is_finite() && c.up.is_finite()) {
        return Err(("camera".into(), "position or orientation is not finite".into()));
    }
    if scene.settings.spp == 0 {
        return Err(("render.spp".into(), "must be at least 1".into()));
    }
    if scene.settings.max_depth == 0 {
        return Err(("render.max_depth".into(), "must be at least 1 (1 = emitters seen directly)".into()));
    }
    let ntex = scene.textures.len();
    for (i, m) in scene.materials.iter().enumerate() {
        let f = |p: &str| format!("materials[{i}] ('{}').{p}", m.name);
        match m.albedo {
            Color::Constant(v) if !(v.is_finite() && v.min_element() >= 0.0 && v.max_element() <= 1.0) => {
                return Err((f("albedo"), format!("{v} must be finite and in [0, 1]")))
            }
            Color::Texture(t) if t >= ntex => return Err((f("albedo"), format!("texture {t} does not exist"))),
            _ => {}
        }
        for (name, s) in [("roughness", m.roughness), ("specular", m.specular)] {
            match s {
                Scalar::Constant(v) if !(0.0..=1.0).contains(&v) => {
                    return Err((f(name), format!("{v} must be finite and in [0, 1]")))
                }
                Scalar::Texture(t) if t >= ntex => return Err((f(name), format!("texture {t} does not exist"))),
                _ => {}
            }
        }
        if m.normal_map.is_some_and(|t| t >= ntex) {
            return Err((f("normal_map"), "texture does not exist".into()));
        }
        let u = &m.uv_transform;
        if !(u.scale.is_finite() && u.rotation_deg.is_finite() && u.offset.is_finite()) {
            return Err((f("uv_transform"), "must be finite".into()));
        }
    }
    for (i, t) in scene.textures.iter().enumerate() {
        if t.texels.len() != (t.width * t.height * t.channels) as usize || t.width == 0 || t.height == 0 {
            return Err((format!("textures[{i}]"), "size does not match its texels".into()));
        }
        if t.texels.iter().any(|v| !v.is_finite()) {
            return Err((format!("textures[{i}]"), "has a texel that is not finite".into()));
        }
    }
    for (i, o) in scene.objects.iter().enumerate() {
        let f = |p: &str| format!("shapes[{i}] ('{}').{p}", o.name);
        let p = &o.pose;
        if !(p.translation.is_finite() && p.rotation.is_finite() && p.scale.is_finite()) {
            return Err((f("transform"), "is not finite".into()));
        }
        if p.scale.x * p.scale.y * p.scale.z == 0.0 {
            return Err((f("transform.scale"), "must be non-zero".into()));
        }
        if let Some(e) = o.emitter {
            if !(e.radiance.is_finite() && e.radiance.min_element() >= 0.0) {
                return Err((f("emitter.radiance"), format!("{} must be finite and non-negative", e.radiance)));
            }
            // |g| <= 1 keeps the emission non-negative in every direction (1 + g d_y >= 0).
            if !(e.sky_gradient.is_finite() && e.sky_gradient.abs().max_element() <= 1.0) {
                return Err((
                    f("emitter.sky_gradient"),
                    format!("{} must be finite and within [-1, 1]", e.sky_gradient),
                ));
            }
        }
        for (k, part) in o.parts.iter().enumerate() {
            if part.material >= scene.materials.len() {
                return Err((f(&format!("parts[{k}].material")), "does not exist".into()));
            }
            if part.positions.iter().any(|v| !v.is_finite()) {
                return Err((f(&format!("parts[{k}] ('{}')", part.name)), "has a vertex that is not finite".into()));
            }
            let n = part.positions.len() as u32;
            if part.indices.iter().flatten().any(|&j| j >= n) {
                return Err((f(&format!("parts[{k}] ('{}')", part.name)), "indexes a missing vertex".into()));
            }
            if part.normals.as_ref().is_some_and(|v| v.len() != part.positions.len())
                || part.uvs.as_ref().is_some_and(|v| v.len() != part.positions.len())
            {
                return Err((f(&format!("parts[{k}] ('{}')", part.name)), "normals/uvs do not match positions".into()));
            }
        }
    }
    Ok(())
}
