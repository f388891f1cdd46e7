//! Scene file -> `Scene`, validating every field with an error that names file, field and problem.

use super::file::*;
use super::obj::load_obj;
use super::{
    box_mesh, rectangle_mesh, sphere_mesh, Camera, Color, Emitter, Material, Object, Pose, Procedural, RenderSettings,
    Scalar, Scene, Texture, TextureEncoding, UvTransform,
};
use crate::error::{Error, Result};
use glam::{EulerRot, Mat4, Quat, Vec2, Vec3};
use psdr_materials::ParamKind;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

pub fn load_scene(path: &Path) -> Result<Scene> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let file: SceneFile = parse_scene_file(&text).map_err(|(field, msg)| Error::scene(path, field, msg))?;
    let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let mut scene = Loader { file: path, base, textures: Vec::new(), texture_ids: HashMap::new() }.scene(&file)?;
    scene.source = Some(path.to_path_buf());
    crate::scene::validate::validate(&scene).map_err(|(field, msg)| Error::scene(path, field, msg))?;
    Ok(scene)
}

/// The scene file's JSON, or the field (its path in the file, "shapes[2].transform.scale", with the line) and
/// what is wrong there.
fn parse_scene_file(text: &str) -> std::result::Result<SceneFile, (String, String)> {
    let mut de = serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let inner = e.inner();
        let at = format!("line {} column {}", inner.line(), inner.column());
        let field = e.path().to_string();
        // serde_json appends " at line L column C"; it leads the field instead.
        let mut msg = inner.to_string();
        if let Some(i) = msg.rfind(" at line ") {
            msg.truncate(i);
        }
        if field.is_empty() || field == "." {
            (at, msg)
        } else {
            (format!("{field} ({at})"), msg)
        }
    })
}

struct Loader<'a> {
    file: &'a Path,
    base: PathBuf,
    textures: Vec<Texture>,
    texture_ids: HashMap<(PathBuf, bool, u32), usize>,
}

fn finite3(v: [f32; 3]) -> Option<Vec3> {
    let v = Vec3::from(v);
    v.is_finite().then_some(v)
}

impl Loader<'_> {
    fn err(&self, field: impl Into<String>, msg: impl Into<String>) -> Error {
        Error::scene(self.file, field, msg)
    }

    fn scene(mut self, f: &SceneFile) -> Result<Scene> {
        if f.format != FORMAT {
            return Err(self.err("format", format!("expected \"{FORMAT}\", found \"{}\"", f.format)));
        }
        if f.version != VERSION {
            return Err(
                self.err("version", format!("this psdr reads version {VERSION}, the file is version {}", f.version))
            );
        }
        let camera = self.camera(&f.camera)?;
        let d = RenderSettings::default();
        let settings = RenderSettings {
            spp: f.render.spp.unwrap_or(d.spp),
            max_depth: f.render.max_depth.unwrap_or(d.max_depth),
            rr_depth: f.render.rr_depth.unwrap_or(d.rr_depth),
            seed: f.render.seed.unwrap_or(d.seed),
        };
        let mut materials = Vec::new();
        for (i, m) in f.materials.iter().enumerate() {
            if materials.iter().any(|x: &Material| x.name == m.name) {
                return Err(self.err(format!("materials[{i}].name"), format!("duplicate material name '{}'", m.name)));
            }
            materials.push(self.material(m, &format!("materials[{i}]"))?);
        }
        let mut objects = Vec::new();
        for (i, s) in f.shapes.iter().enumerate() {
            let field = format!("shapes[{i}] ('{}')", s.name);
            if objects.iter().any(|o: &Object| o.name == s.name) {
                return Err(self.err(field, format!("duplicate shape name '{}'", s.name)));
            }
            objects.push(self.shape(s, &field, &mut materials)?);
        }
        let file = self.file;
        let mut scene = Scene {
            camera,
            settings,
            materials,
            textures: self.textures,
            objects,
            source: None,
            requires_grad: vec![],
        };
        for (i, path) in f.requires_grad.iter().enumerate() {
            let bad = |e: Error| Error::scene(file, format!("requires_grad[{i}]"), e.to_string());
            let p: super::ParamPath = path.parse().map_err(bad)?;
            p.get(&scene).map_err(bad)?;
            scene.requires_grad.push(p);
        }
        Ok(scene)
    }

    fn camera(&self, c: &CameraFile) -> Result<Camera> {
        if c.width == 0 || c.height == 0 {
            return Err(
                self.err("camera.width/height", format!("resolution {}x{} must be positive", c.width, c.height))
            );
        }
        if !(c.fov_y > 0.0 && c.fov_y < 180.0) {
            return Err(self.err("camera.fov_y", format!("{} is not in (0, 180) degrees", c.fov_y)));
        }
        if let Some(m) = c.to_world {
            let m = Mat4::from_cols_array_2d(&m).transpose();
            if !m.is_finite() || m.determinant().abs() < 1e-12 {
                return Err(self.err("camera.to_world", "matrix is singular or not finite"));
            }
            return Ok(Camera::from_matrix(m, c.fov_y, c.width, c.height));
        }
        let origin = c.origin.and_then(finite3).ok_or_else(|| self.err("camera.origin", "missing or not finite"))?;
        let target = c.target.and_then(finite3).ok_or_else(|| self.err("camera.target", "missing or not finite"))?;
        let up = c.up.map(finite3).unwrap_or(Some(Vec3::Y)).ok_or_else(|| self.err("camera.up", "not finite"))?;
        let dir = target - origin;
        if dir.length() < 1e-8 {
            return Err(self.err("camera.target", "coincides with camera.origin"));
        }
        if dir.normalize().cross(up).length() < 1e-6 {
            return Err(self.err("camera.up", "is parallel to the viewing direction"));
        }
        Ok(Camera::look_at(origin, target, up, c.fov_y, c.width, c.height))
    }

    fn texture(&mut self, rel: &str, field: &str, srgb: bool, channels: u32) -> Result<usize> {
        let path = self.base.join(rel);
        let key = (path.clone(), srgb, channels);
        if let Some(&id) = self.texture_ids.get(&key) {
            return Ok(id);
        }
        if !path.is_file() {
            return Err(self.err(field, format!("texture file {} not found", path.display())));
        }
        let enc = if srgb { TextureEncoding::Srgb } else { TextureEncoding::Linear };
        let tex = Texture::load(&path, enc, channels).map_err(|e| self.err(field, e.to_string()))?;
        self.textures.push(tex);
        self.texture_ids.insert(key, self.textures.len() - 1);
        Ok(self.textures.len() - 1)
    }

    fn color(&mut self, v: &ValueFile, field: &str) -> Result<Color> {
        match v {
            ValueFile::Number(x) => Ok(Color::Constant(Vec3::splat(*x))),
            ValueFile::Rgb(c) => Ok(Color::Constant(Vec3::from(*c))),
            ValueFile::Texture(t) => Ok(Color::Texture(self.texture(&t.texture, field, t.srgb.unwrap_or(true), 3)?)),
        }
    }

    fn scalar(&mut self, v: &ValueFile, field: &str) -> Result<Scalar> {
        match v {
            ValueFile::Number(x) => Ok(Scalar::Constant(*x)),
            ValueFile::Rgb(_) => Err(self.err(field, "expected one number or a texture, found an RGB triple")),
            ValueFile::Texture(t) => {
                Ok(Scalar::Texture(self.texture(&t.texture, field, t.srgb.unwrap_or(false), 1)?))
            }
        }
    }

    fn material(&mut self, m: &MaterialFile, field: &str) -> Result<Material> {
        let albedo = match &m.albedo {
            Some(v) => self.color(v, &format!("{field}.albedo"))?,
            None => Color::Constant(Vec3::splat(0.5)),
        };
        let roughness = match &m.roughness {
            Some(v) => self.scalar(v, &format!("{field}.roughness"))?,
            None => Scalar::Constant(0.5),
        };
        let specular = match &m.specular {
            Some(v) => self.scalar(v, &format!("{field}.specular"))?,
            None => Scalar::Constant(0.5),
        };
        let normal_map = match &m.normal_map {
            Some(p) => Some(self.texture(p, &format!("{field}.normal_map"), false, 3)?),
            None => None,
        };
        let uv_transform = match &m.uv_transform {
            None => UvTransform::default(),
            Some(u) => UvTransform {
                scale: match u.scale.as_deref() {
                    None => Vec2::ONE,
                    Some([s]) => Vec2::splat(*s),
                    Some([a, b]) => Vec2::new(*a, *b),
                    Some(_) => return Err(self.err(format!("{field}.uv_transform.scale"), "expected 1 or 2 numbers")),
                },
                rotation_deg: u.rotation_deg.unwrap_or(0.0),
                offset: Vec2::from(u.offset.unwrap_or([0.0, 0.0])),
            },
        };
        let model_look = match &m.model_look {
            Some(l) if l.albedo.iter().all(|v| v.is_finite()) => Some(super::ModelLook {
                albedo: Vec3::from(l.albedo),
                picture: l.picture.as_ref().map(|p| self.base.join(p)),
            }),
            Some(_) => return Err(self.err(format!("{field}.model_look.albedo"), "not finite")),
            None => None,
        };
        let mut material = Material {
            name: m.name.clone(),
            albedo,
            roughness,
            specular,
            normal_map,
            uv_transform,
            procedural: None,
            model_look,
        };
        if let Some(p) = &m.procedural {
            let proc = self.procedural(p, &format!("{field}.procedural"))?;
            let texture = proc.bake().map_err(|e| self.err(format!("{field}.procedural"), e.to_string()))?;
            self.textures.push(texture);
            material.albedo = Color::Texture(self.textures.len() - 1);
            material.procedural = Some(proc);
        }
        Ok(material)
    }

    fn procedural(&self, p: &ProceduralFile, field: &str) -> Result<Procedural> {
        let graph = if psdr_materials::library::source(&p.graph).is_some() {
            p.graph.clone()
        } else {
            self.base.join(&p.graph).display().to_string()
        };
        let size = p.size.unwrap_or(256);
        if !(4..=4096).contains(&size) {
            return Err(self.err(format!("{field}.size"), format!("{size} texels is not in 4..4096")));
        }
        let mut proc = Procedural::new(&graph, size).map_err(|e| self.err(format!("{field}.graph"), e.to_string()))?;
        let g = proc.load_graph().map_err(|e| self.err(format!("{field}.graph"), e.to_string()))?;
        for (name, value) in &p.params {
            let f = format!("{field}.params.{name}");
            let info =
                g.param(name).ok_or_else(|| self.err(&f, format!("graph '{}' has no such parameter", p.graph)))?;
            let values: Vec<f64> = match value {
                serde_json::Value::Number(n) => n.as_f64().into_iter().collect(),
                serde_json::Value::Array(a) => a.iter().filter_map(|v| v.as_f64()).collect(),
                _ => vec![],
            };
            if values.len() != info.len || values.iter().any(|v| !v.is_finite()) {
                return Err(self.err(&f, format!("expected {} finite number(s)", info.len)));
            }
            match info.kind {
                ParamKind::Int => proc.params.ints[info.offset] = values[0].round() as i64,
                _ => proc.params.floats[info.offset..info.offset + info.len].copy_from_slice(&values),
            }
        }
        if let Some(t) = p.tint {
            proc.tint = finite3(t)
                .filter(|t| t.min_element() >= 0.0)
                .ok_or_else(|| self.err(format!("{field}.tint"), "expected three finite non-negative numbers"))?;
        }
        Ok(proc)
    }

    fn shape(&mut self, s: &ShapeFile, field: &str, materials: &mut Vec<Material>) -> Result<Object> {
        let size = |n: usize| -> Result<Vec<f32>> {
            match &s.size {
                Some(v) if v.len() == n => Ok(v.clone()),
                Some(v) => Err(self.err(format!("{field}.size"), format!("expected {n} numbers, found {}", v.len()))),
                None => Err(self.err(format!("{field}.size"), format!("'{}' needs a size of {n} numbers", s.kind))),
            }
        };
        let inward = s.inward.unwrap_or(false);
        let (mut parts, mtls) = match s.kind.as_str() {
            "rectangle" => {
                let v = size(2)?;
                (vec![rectangle_mesh(v[0], v[1])], vec![None])
            }
            "box" => {
                let v = size(3)?;
                (vec![box_mesh(Vec3::new(v[0], v[1], v[2]), inward)], vec![None])
            }
            "sphere" => {
                let r = s.radius.ok_or_else(|| self.err(format!("{field}.radius"), "a sphere needs a radius"))?;
                (vec![sphere_mesh(r, s.rings.unwrap_or(32), s.segments.unwrap_or(64), inward)], vec![None])
            }
            "obj" => {
                let rel =
                    s.file.as_ref().ok_or_else(|| self.err(format!("{field}.file"), "an obj shape needs a file"))?;
                let path = self.base.join(rel);
                if !path.is_file() {
                    return Err(self.err(format!("{field}.file"), format!("OBJ file {} not found", path.display())));
                }
                let obj = load_obj(&path).map_err(|e| self.err(format!("{field}.file"), e.to_string()))?;
                (obj.parts, obj.part_mtl)
            }
            other => {
                return Err(self.err(
                    format!("{field}.type"),
                    format!("unknown shape type '{other}' (obj, rectangle, box, sphere)"),
                ))
            }
        };
        for (name, _) in s.part_materials.iter() {
            if !parts.iter().any(|p| &p.name == name) {
                let known: Vec<_> = parts.iter().map(|p| p.name.as_str()).collect();
                return Err(
                    self.err(format!("{field}.part_materials.{name}"), format!("no such part; parts are {known:?}"))
                );
            }
        }
        let file = self.file;
        let find = |name: &str, f: &str, materials: &[Material]| {
            materials
                .iter()
                .position(|m| m.name == name)
                .ok_or_else(|| Error::scene(file, f, format!("unknown material '{name}'")))
        };
        for (k, part) in parts.iter_mut().enumerate() {
            part.material = if let Some(m) = s.part_materials.get(&part.name) {
                find(m, &format!("{field}.part_materials.{}", part.name), materials)?
            } else if let Some(m) = &s.material {
                find(m, &format!("{field}.material"), materials)?
            } else if let Some(mtl) = &mtls[k] {
                // Fall back to the OBJ's own MTL material, named "<shape>/<mtl>".
                self.mtl_material(s, mtl, materials, field)?
            } else {
                return Err(self.err(format!("{field}.material"), format!("part '{}' has no material", part.name)));
            };
        }
        if let Some(angle) = s.smooth_angle {
            if !(0.0..=180.0).contains(&angle) {
                return Err(self.err(format!("{field}.smooth_angle"), format!("{angle} is not in 0..180 degrees")));
            }
            for part in parts.iter_mut().filter(|p| p.normals.is_none()) {
                *part = super::auto_smooth(part, angle);
            }
        }
        let pose = self.pose(s.transform.as_ref(), &format!("{field}.transform"))?;
        let emitter = match &s.emitter {
            None => None,
            Some(e) => {
                let radiance = match e.radiance {
                    ValueFile::Number(x) => Vec3::splat(x),
                    ValueFile::Rgb(c) => Vec3::from(c),
                    ValueFile::Texture(_) => {
                        return Err(self.err(
                            format!("{field}.emitter.radiance"),
                            "textured emitters are not supported; give an RGB triple",
                        ))
                    }
                };
                let sky_gradient = e.sky_gradient.map_or(Vec3::ZERO, Vec3::from);
                Some(Emitter { radiance, two_sided: e.two_sided, sky_gradient })
            }
        };
        Ok(Object { name: s.name.clone(), parts, pose, emitter })
    }

    fn mtl_material(
        &mut self,
        s: &ShapeFile,
        mtl: &super::obj::MtlMaterial,
        materials: &mut Vec<Material>,
        field: &str,
    ) -> Result<usize> {
        let name = format!("{}/{}", s.name, mtl.name);
        if let Some(i) = materials.iter().position(|m| m.name == name) {
            return Ok(i);
        }
        let mut m = Material::diffuse(&name, mtl.diffuse.unwrap_or(Vec3::splat(0.5)).clamp(Vec3::ZERO, Vec3::ONE));
        m.roughness = Scalar::Constant(0.5);
        m.specular = Scalar::Constant(0.5);
        if let Some(tex) = &mtl.diffuse_texture {
            let obj_dir =
                self.base.join(s.file.as_deref().unwrap_or("")).parent().map(Path::to_path_buf).unwrap_or_default();
            let rel = obj_dir.join(tex);
            let rel = rel.strip_prefix(&self.base).map(Path::to_path_buf).unwrap_or(rel);
            m.albedo = Color::Texture(self.texture(
                &rel.to_string_lossy(),
                &format!("{field}.file (map_Kd of '{}')", mtl.name),
                true,
                3,
            )?);
        }
        materials.push(m);
        Ok(materials.len() - 1)
    }

    fn pose(&self, t: Option<&TransformFile>, field: &str) -> Result<Pose> {
        let Some(t) = t else { return Ok(Pose::default()) };
        let translation = match t.translation {
            Some(v) => finite3(v).ok_or_else(|| self.err(format!("{field}.translation"), "not finite"))?,
            None => Vec3::ZERO,
        };
        let rotation = match (t.rotation_deg, t.quaternion) {
            (Some(_), Some(_)) => return Err(self.err(field, "give rotation_deg or quaternion, not both")),
            (Some(r), None) => {
                let r = finite3(r).ok_or_else(|| self.err(format!("{field}.rotation_deg"), "not finite"))?;
                Quat::from_euler(EulerRot::ZYX, r.z.to_radians(), r.y.to_radians(), r.x.to_radians())
            }
            (None, Some(q)) => {
                let q = Quat::from_array(q);
                if !q.is_finite() || (q.length() - 1.0).abs() > 1e-3 {
                    return Err(
                        self.err(format!("{field}.quaternion"), "must be a finite unit quaternion [x, y, z, w]")
                    );
                }
                q.normalize()
            }
            (None, None) => Quat::IDENTITY,
        };
        let scale = match t.scale.as_deref() {
            None => Vec3::ONE,
            Some([s]) => Vec3::splat(*s),
            Some([a, b, c]) => Vec3::new(*a, *b, *c),
            Some(_) => return Err(self.err(format!("{field}.scale"), "expected 1 or 3 numbers")),
        };
        if !scale.is_finite() || scale.x * scale.y * scale.z == 0.0 {
            return Err(self.err(format!("{field}.scale"), format!("{scale} must be finite and non-zero")));
        }
        Ok(Pose { translation, rotation, scale })
    }
}
