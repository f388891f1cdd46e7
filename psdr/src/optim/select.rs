//! Selecting parameters by path pattern: `object/*/translation`, `material/floor/*`, `light/*/radiance`.
//! `*` matches any run of characters within one path segment (never a `/`), `?` one character. A pattern
//! without wildcards is parsed as a path, so texels and vertices, which no wildcard expands to, can be named.

use crate::error::{Error, Result};
use crate::scene::ParamPath;
use crate::scene::{Color, Scalar, Scene};

/// Every parameter a wildcard can select, in scene order: light radiances; per material its constant albedo,
/// roughness and specular, a procedural one's tint and graph parameters, uv scale and rotation; per object translation, yaw, rotation and scale. Texels and
/// vertices are left out (thousands of entries that no pattern like `material/*/*` should sweep in).
pub fn scene_parameters(scene: &Scene) -> Vec<ParamPath> {
    let mut out = vec![];
    for o in &scene.objects {
        if o.emitter.is_some() {
            out.push(ParamPath::LightRadiance(o.name.clone()));
        }
    }
    for m in &scene.materials {
        let n = || m.name.clone();
        if matches!(m.albedo, Color::Constant(_)) {
            out.push(ParamPath::MaterialAlbedo(n()));
        }
        if matches!(m.roughness, Scalar::Constant(_)) {
            out.push(ParamPath::MaterialRoughness(n()));
        }
        if matches!(m.specular, Scalar::Constant(_)) {
            out.push(ParamPath::MaterialSpecular(n()));
        }
        if let Some(p) = &m.procedural {
            out.push(ParamPath::ProceduralTint(n()));
            // A graph that no longer loads is reported when a parameter of it is used, not here.
            for name in p.float_param_names().unwrap_or_default() {
                out.push(ParamPath::GraphParam { material: n(), name });
            }
        }
        out.push(ParamPath::UvScale(n()));
        out.push(ParamPath::UvRotation(n()));
    }
    for o in &scene.objects {
        let n = || o.name.clone();
        out.extend([ParamPath::Translation(n()), ParamPath::Yaw(n()), ParamPath::Rotation(n()), ParamPath::Scale(n())]);
    }
    out
}

/// True when `text` matches the glob `pattern` (`*` within a segment, `?` one non-`/` character).
pub fn glob_match(pattern: &str, text: &str) -> bool {
    fn rec(p: &[u8], t: &[u8]) -> bool {
        match p.first() {
            None => t.is_empty(),
            Some(b'*') => (0..=t.len()).take_while(|&i| i == 0 || t[i - 1] != b'/').any(|i| rec(&p[1..], &t[i..])),
            Some(b'?') => t.first().is_some_and(|&c| c != b'/') && rec(&p[1..], &t[1..]),
            Some(&c) => t.first() == Some(&c) && rec(&p[1..], &t[1..]),
        }
    }
    rec(pattern.as_bytes(), text.as_bytes())
}

/// The parameters matching `pattern`, in scene order. A pattern matching nothing is an error that lists what
/// there is, so a typo never silently optimises nothing.
pub fn select(scene: &Scene, pattern: &str) -> Result<Vec<ParamPath>> {
    if !pattern.contains(['*', '?']) {
        let p: ParamPath = pattern.parse()?;
        p.get(scene)?;
        return Ok(vec![p]);
    }
    let all = scene_parameters(scene);
    let hits: Vec<ParamPath> = all.iter().filter(|p| glob_match(pattern, &p.to_string())).cloned().collect();
    if hits.is_empty() {
        let mut names: Vec<String> = all.iter().map(|p| p.to_string()).take(24).collect();
        if all.len() > names.len() {
            names.push(format!("... ({} in all)", all.len()));
        }
        return Err(Error::Invalid(format!(
            "parameter pattern '{pattern}' matches nothing; the scene's parameters are: {}",
            names.join(", ")
        )));
    }
    Ok(hits)
}

#[cfg(test)]
mod tests {
    use super::glob_match;

    #[test]
    fn wildcards_stay_within_a_segment() {
        assert!(glob_match("object/*/translation", "object/sofa_0/translation"));
        assert!(!glob_match("object/*/translation", "object/sofa_0/yaw"));
        assert!(glob_match("material/floor/*", "material/floor/albedo"));
        assert!(!glob_match("material/*", "material/floor/albedo"), "* must not cross '/'");
        assert!(glob_match("light/ceiling_?/radiance", "light/ceiling_3/radiance"));
        assert!(!glob_match("light/ceiling_?/radiance", "light/ceiling_12/radiance"));
        assert!(glob_match("*/*/*", "object/a/scale"));
        assert!(glob_match("object/chair*/yaw", "object/chair/yaw"));
    }
}
