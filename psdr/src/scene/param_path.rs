//! Named scene parameters addressed by stable string paths, e.g. `object/table/translation`,
//! `material/oak_floor/roughness`, `light/ceiling_light/radiance`, `material/oak_floor/albedo.texel[3,7]`.
//! Scripts select what to optimise by path; gradient checks poke one parameter at a time through `get`/`set`.

use crate::error::{Error, Result};
use crate::scene::{weld, Color, Scalar, Scene};
use glam::{EulerRot, Quat, Vec2, Vec3};
use std::fmt;
use std::str::FromStr;

/// Which material channel a texel parameter lives in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextureSlot {
    Albedo,
    Roughness,
    NormalMap,
}

/// One parameter (a small vector of floats) of a scene.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamPath {
    /// RGB radiance of an emitting object.
    LightRadiance(String),
    MaterialAlbedo(String),
    MaterialRoughness(String),
    MaterialSpecular(String),
    /// One texel (all channels) of a material's texture; x from the left, y from the top.
    MaterialTexel {
        material: String,
        slot: TextureSlot,
        x: u32,
        y: u32,
    },
    /// A continuous parameter of a procedural material's graph (1 float, or 3 for a colour); setting it
    /// bakes the material's albedo texture anew.
    GraphParam {
        material: String,
        name: String,
    },
    /// Per-channel gain on a procedural material's graph albedo (3 floats).
    ProceduralTint(String),
    /// UV transform scale (2) and rotation in degrees (1).
    UvScale(String),
    UvRotation(String),
    Translation(String),
    /// Rotation about the world up axis (+y) in radians; the other Euler angles (YXZ) stay fixed.
    Yaw(String),
    /// General rotation as a rotation vector (axis times angle, radians).
    Rotation(String),
    /// Per-axis scale.
    Scale(String),
    /// Every welded vertex position of the object (`scene::weld`: copies at one object-space position are one
    /// vertex, so moving it never tears the mesh), object space, in order of first appearance, 3 floats each.
    /// Stored shading normals stay as they are; flat-shaded faces follow their vertices.
    Vertices(String),
}

impl FromStr for ParamPath {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        let bad = |why: &str| Error::Invalid(format!("parameter path '{s}': {why}"));
        let mut it = s.splitn(3, '/');
        let (kind, name, field) = match (it.next(), it.next(), it.next()) {
            (Some(k), Some(n), Some(f)) if !n.is_empty() => (k, n.to_string(), f),
            _ => return Err(bad("expected KIND/NAME/FIELD, e.g. object/table/translation")),
        };
        let texel = |slot| -> Result<ParamPath> {
            let coords = field
                .split_once(".texel[")
                .and_then(|(_, r)| r.strip_suffix(']'))
                .ok_or_else(|| bad("a texel parameter looks like material/NAME/albedo.texel[X,Y]"))?;
            let (x, y) = coords.split_once(',').ok_or_else(|| bad("texel needs [X,Y]"))?;
            let p = |v: &str| v.trim().parse::<u32>().map_err(|_| bad("texel coordinates must be integers"));
            Ok(ParamPath::MaterialTexel { material: name.clone(), slot, x: p(x)?, y: p(y)? })
        };
        Ok(match (kind, field) {
            ("light", "radiance") => ParamPath::LightRadiance(name),
            ("material", "albedo") => ParamPath::MaterialAlbedo(name),
            ("material", "roughness") => ParamPath::MaterialRoughness(name),
            ("material", "specular") => ParamPath::MaterialSpecular(name),
            ("material", "uv_scale") => ParamPath::UvScale(name),
            ("material", "tint") => ParamPath::ProceduralTint(name),
            ("material", f) if f.starts_with("graph.") && f.len() > "graph.".len() => {
                ParamPath::GraphParam { material: name, name: f["graph.".len()..].to_string() }
            }
            ("material", "uv_rotation") => ParamPath::UvRotation(name),
            ("material", f) if f.starts_with("albedo.texel[") => texel(TextureSlot::Albedo)?,
            ("material", f) if f.starts_with("roughness.texel[") => texel(TextureSlot::Roughness)?,
            ("material", f) if f.starts_with("normal_map.texel[") => texel(TextureSlot::NormalMap)?,
            ("object", "translation") => ParamPath::Translation(name),
            ("object", "yaw") => ParamPath::Yaw(name),
            ("object", "rotation") => ParamPath::Rotation(name),
            ("object", "scale") => ParamPath::Scale(name),
            ("object", "vertices") => ParamPath::Vertices(name),
            _ => {
                return Err(bad(
                    "unknown parameter; known: light/N/radiance, material/N/{albedo,roughness,specular,uv_scale,\
                 uv_rotation,albedo.texel[x,y],roughness.texel[x,y],normal_map.texel[x,y],tint,graph.PARAM}, \
                 object/N/{translation,yaw,rotation,scale,vertices}",
                ))
            }
        })
    }
}

impl fmt::Display for ParamPath {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        use ParamPath::*;
        match self {
            LightRadiance(n) => write!(f, "light/{n}/radiance"),
            MaterialAlbedo(n) => write!(f, "material/{n}/albedo"),
            MaterialRoughness(n) => write!(f, "material/{n}/roughness"),
            MaterialSpecular(n) => write!(f, "material/{n}/specular"),
            MaterialTexel { material, slot, x, y } => {
                let s = match slot {
                    TextureSlot::Albedo => "albedo",
                    TextureSlot::Roughness => "roughness",
                    TextureSlot::NormalMap => "normal_map",
                };
                write!(f, "material/{material}/{s}.texel[{x},{y}]")
            }
            GraphParam { material, name } => write!(f, "material/{material}/graph.{name}"),
            ProceduralTint(n) => write!(f, "material/{n}/tint"),
            UvScale(n) => write!(f, "material/{n}/uv_scale"),
            UvRotation(n) => write!(f, "material/{n}/uv_rotation"),
            Translation(n) => write!(f, "object/{n}/translation"),
            Yaw(n) => write!(f, "object/{n}/yaw"),
            Rotation(n) => write!(f, "object/{n}/rotation"),
            Scale(n) => write!(f, "object/{n}/scale"),
            Vertices(n) => write!(f, "object/{n}/vertices"),
        }
    }
}

impl ParamPath {
    /// The parameter's current value.
    pub fn get(&self, scene: &Scene) -> Result<Vec<f32>> {
        use ParamPath::*;
        Ok(match self {
            LightRadiance(n) => emitter(scene, self, n)?.to_array().to_vec(),
            MaterialAlbedo(n) => match scene.materials[material(scene, self, n)?].albedo {
                Color::Constant(c) => c.to_array().to_vec(),
                Color::Texture(_) => return Err(textured(self)),
            },
            MaterialRoughness(n) | MaterialSpecular(n) => match scalar(scene, self, n)? {
                Scalar::Constant(v) => vec![v],
                Scalar::Texture(_) => return Err(textured(self)),
            },
            MaterialTexel { .. } => {
                let (t, i) = texel(scene, self)?;
                let tex = &scene.textures[t];
                tex.texels[i..i + tex.channels as usize].to_vec()
            }
            GraphParam { material: m, name } => {
                let p = procedural(scene, self, m)?;
                let (at, len) = p.float_param(&p.load_graph()?, name)?;
                p.params.floats[at..at + len].iter().map(|&v| v as f32).collect()
            }
            ProceduralTint(n) => procedural(scene, self, n)?.tint.to_array().to_vec(),
            UvScale(n) => scene.materials[material(scene, self, n)?].uv_transform.scale.to_array().to_vec(),
            UvRotation(n) => vec![scene.materials[material(scene, self, n)?].uv_transform.rotation_deg],
            Translation(n) => scene.objects[object(scene, self, n)?].pose.translation.to_array().to_vec(),
            Yaw(n) => vec![scene.objects[object(scene, self, n)?].pose.rotation.to_euler(EulerRot::YXZ).0],
            Rotation(n) => scene.objects[object(scene, self, n)?].pose.rotation.to_scaled_axis().to_array().to_vec(),
            Scale(n) => scene.objects[object(scene, self, n)?].pose.scale.to_array().to_vec(),
            Vertices(n) => {
                weld(&scene.objects[object(scene, self, n)?]).positions.iter().flat_map(|v| v.to_array()).collect()
            }
        })
    }

    /// Sets the parameter. Values must be finite and have the parameter's length; range checks (albedo in
    /// [0, 1], ...) are the scene validator's job, which every render runs.
    pub fn set(&self, scene: &mut Scene, value: &[f32]) -> Result<()> {
        use ParamPath::*;
        let want = self.get(scene)?.len();
        if value.len() != want {
            return Err(Error::Invalid(format!("{self}: expected {want} values, got {}", value.len())));
        }
        if let Some(i) = value.iter().position(|v| !v.is_finite()) {
            return Err(Error::Invalid(format!("{self}: value {i} is {} (not finite)", value[i])));
        }
        let v3 = || Vec3::from_slice(value);
        match self {
            LightRadiance(n) => {
                let o = object(scene, self, n)?;
                scene.objects[o].emitter.as_mut().expect("checked by get").radiance = v3();
            }
            MaterialAlbedo(n) => {
                let m = material(scene, self, n)?;
                scene.materials[m].albedo = Color::Constant(v3());
            }
            MaterialRoughness(n) => {
                let m = material(scene, self, n)?;
                scene.materials[m].roughness = Scalar::Constant(value[0]);
            }
            MaterialSpecular(n) => {
                let m = material(scene, self, n)?;
                scene.materials[m].specular = Scalar::Constant(value[0]);
            }
            MaterialTexel { .. } => {
                let (t, i) = texel(scene, self)?;
                scene.textures[t].texels[i..i + value.len()].copy_from_slice(value);
            }
            GraphParam { material: name, name: param } => {
                let m = material(scene, self, name)?;
                let mut p = procedural(scene, self, name)?.clone();
                let (at, len) = p.float_param(&p.load_graph()?, param)?;
                p.params.floats[at..at + len].iter_mut().zip(value).for_each(|(f, &v)| *f = v as f64);
                scene.set_procedural(m, p)?;
            }
            ProceduralTint(n) => {
                let m = material(scene, self, n)?;
                let mut p = procedural(scene, self, n)?.clone();
                p.tint = v3();
                scene.set_procedural(m, p)?;
            }
            UvScale(n) => {
                let m = material(scene, self, n)?;
                scene.materials[m].uv_transform.scale = Vec2::from_slice(value);
            }
            UvRotation(n) => {
                let m = material(scene, self, n)?;
                scene.materials[m].uv_transform.rotation_deg = value[0];
            }
            Translation(n) => {
                let o = object(scene, self, n)?;
                scene.objects[o].pose.translation = v3();
            }
            Yaw(n) => {
                let o = object(scene, self, n)?;
                let r = &mut scene.objects[o].pose.rotation;
                let (_, x, z) = r.to_euler(EulerRot::YXZ);
                *r = Quat::from_euler(EulerRot::YXZ, value[0], x, z);
            }
            Rotation(n) => {
                let o = object(scene, self, n)?;
                scene.objects[o].pose.rotation = Quat::from_scaled_axis(v3());
            }
            Scale(n) => {
                let o = object(scene, self, n)?;
                scene.objects[o].pose.scale = v3();
            }
            Vertices(n) => {
                let o = object(scene, self, n)?;
                let w = weld(&scene.objects[o]);
                for (p, ids) in scene.objects[o].parts.iter_mut().zip(&w.ids) {
                    for (v, &id) in p.positions.iter_mut().zip(ids) {
                        *v = Vec3::from_slice(&value[3 * id as usize..3 * id as usize + 3]);
                    }
                }
            }
        }
        Ok(())
    }
}

fn not_found(p: &ParamPath, what: &str, name: &str) -> Error {
    Error::Invalid(format!("{p}: no {what} named '{name}'"))
}

fn textured(p: &ParamPath) -> Error {
    Error::Invalid(format!("{p}: the material uses a texture here; address its texels (…texel[x,y]) instead"))
}

fn object(scene: &Scene, p: &ParamPath, name: &str) -> Result<usize> {
    scene.object_index(name).ok_or_else(|| not_found(p, "object", name))
}

fn material(scene: &Scene, p: &ParamPath, name: &str) -> Result<usize> {
    scene.material_index(name).ok_or_else(|| not_found(p, "material", name))
}

fn procedural<'a>(scene: &'a Scene, p: &ParamPath, name: &str) -> Result<&'a crate::scene::Procedural> {
    scene.materials[material(scene, p, name)?]
        .procedural
        .as_ref()
        .ok_or_else(|| Error::Invalid(format!("{p}: material '{name}' is not procedural (no graph generates it)")))
}

fn emitter(scene: &Scene, p: &ParamPath, name: &str) -> Result<Vec3> {
    let o = &scene.objects[object(scene, p, name)?];
    o.emitter.map(|e| e.radiance).ok_or_else(|| Error::Invalid(format!("{p}: object '{name}' does not emit")))
}

fn scalar(scene: &Scene, p: &ParamPath, name: &str) -> Result<Scalar> {
    let m = &scene.materials[material(scene, p, name)?];
    Ok(if matches!(p, ParamPath::MaterialRoughness(_)) { m.roughness } else { m.specular })
}

/// (texture index, index of the texel's first channel in `texels`).
fn texel(scene: &Scene, p: &ParamPath) -> Result<(usize, usize)> {
    let ParamPath::MaterialTexel { material: name, slot, x, y } = p else { unreachable!("texel paths only") };
    let m = &scene.materials[material(scene, p, name)?];
    let t = match slot {
        TextureSlot::Albedo => match m.albedo {
            Color::Texture(t) => Some(t),
            Color::Constant(_) => None,
        },
        TextureSlot::Roughness => match m.roughness {
            Scalar::Texture(t) => Some(t),
            Scalar::Constant(_) => None,
        },
        TextureSlot::NormalMap => m.normal_map,
    }
    .ok_or_else(|| Error::Invalid(format!("{p}: material '{name}' has no texture in that slot")))?;
    let tex = &scene.textures[t];
    if *x >= tex.width || *y >= tex.height {
        return Err(Error::Invalid(format!("{p}: texel outside the {}x{} texture", tex.width, tex.height)));
    }
    Ok((t, ((*y * tex.width + *x) * tex.channels) as usize))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_round_trip_through_text() {
        for s in [
            "light/lamp/radiance",
            "material/oak/albedo",
            "material/oak/roughness",
            "material/oak/specular",
            "material/oak/albedo.texel[3,7]",
            "material/oak/normal_map.texel[0,1]",
            "material/oak/uv_scale",
            "material/oak/uv_rotation",
            "material/oak/tint",
            "material/oak/graph.grain_warp",
            "object/sofa_0/translation",
            "object/sofa_0/yaw",
            "object/sofa_0/rotation",
            "object/sofa_0/scale",
            "object/sofa_0/vertices",
        ] {
            assert_eq!(s.parse::<ParamPath>().unwrap().to_string(), s);
        }
        for bad in [
            "object/x",
            "object//translation",
            "object/x/color",
            "material/m/albedo.texel[1]",
            "material/m/graph.",
            "x/y/z",
        ] {
            assert!(bad.parse::<ParamPath>().is_err(), "{bad} should not parse");
        }
    }
}
