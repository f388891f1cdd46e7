//! `Scene` -> scene file: what every pipeline stage writes (`stages/NN_name/scene.json`), readable by
//! `psdr render` and `load_scene`. Self-contained: each object's mesh goes to `meshes/` as OBJ + MTL (object
//! space, its pose in the transform; `obj_write`) and each texture to `textures/` as linear EXR, so a stage's output never
//! depends on where its inputs came from. Numbers are written in Rust's shortest round-trip form, so loading
//! the file gives back the same floats (normals and quaternions are renormalised on load).

use super::file::*;
use super::obj_write::obj_text;
use super::{Color, Scalar, Scene};
use crate::base::{write_atomically, write_exr_channels};
use crate::error::{Error, Result};
use glam::Vec3;
use std::collections::BTreeMap;
use std::path::Path;

/// Writes `scene` to `path` (JSON) with its meshes and textures in `meshes/` and `textures/` beside it.
pub fn save_scene(scene: &Scene, path: &Path) -> Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let texture_file = |i: usize| format!("textures/t{i:03}.exr");
    for (i, t) in scene.textures.iter().enumerate() {
        let n = (t.width * t.height) as usize;
        let c = t.channels as usize;
        let channel = |k: usize| (0..n).map(|p| t.texels[p * c + k.min(c - 1)]).collect::<Vec<f32>>();
        let channels =
            vec![("R".to_string(), channel(0)), ("G".to_string(), channel(1)), ("B".to_string(), channel(2))];
        let file = dir.join(texture_file(i));
        write_atomically(&file, |tmp| write_exr_channels(tmp, t.width, t.height, &channels))?;
    }
    let value = |c: Color| match c {
        Color::Constant(v) => ValueFile::Rgb(v.to_array()),
        Color::Texture(t) => ValueFile::Texture(TextureRef { texture: texture_file(t), srgb: Some(false) }),
    };
    let scalar = |s: Scalar| match s {
        Scalar::Constant(v) => ValueFile::Number(v),
        Scalar::Texture(t) => ValueFile::Texture(TextureRef { texture: texture_file(t), srgb: Some(false) }),
    };
    let materials = scene
        .materials
        .iter()
        .map(|m| -> Result<MaterialFile> {
            Ok(MaterialFile {
                name: m.name.clone(),
                albedo: Some(value(m.albedo)),
                roughness: Some(scalar(m.roughness)),
                specular: Some(scalar(m.specular)),
                normal_map: m.normal_map.map(texture_file),
                uv_transform: Some(UvTransformFile {
                    scale: Some(m.uv_transform.scale.to_array().to_vec()),
                    rotation_deg: Some(m.uv_transform.rotation_deg),
                    offset: Some(m.uv_transform.offset.to_array()),
                }),
                procedural: m.procedural.as_ref().map(procedural_file).transpose()?,
                model_look: m.model_look.as_ref().map(|l| super::file::ModelLookFile {
                    albedo: l.albedo.to_array(),
                    picture: l.picture.as_ref().map(|p| p.to_string_lossy().into_owned()),
                }),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let mut shapes = vec![];
    for (i, o) in scene.objects.iter().enumerate() {
        let stem = format!("meshes/{i:03}_{}", file_safe(&o.name));
        let (rel, mtl_rel) = (format!("{stem}.obj"), format!("{stem}.mtl"));
        let mtl_name = Path::new(&mtl_rel).file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
        let diffuse = |k: usize| match scene.materials[o.parts[k].material].albedo {
            Color::Constant(c) => c,
            Color::Texture(_) => Vec3::splat(0.8),
        };
        let text = obj_text(&o.parts, &mtl_name, &diffuse);
        write_atomically(&dir.join(&mtl_rel), |tmp| std::fs::write(tmp, &text.mtl).map_err(|e| Error::io(tmp, e)))?;
        write_atomically(&dir.join(&rel), |tmp| std::fs::write(tmp, &text.obj).map_err(|e| Error::io(tmp, e)))?;
        let part_materials: BTreeMap<String, String> = o
            .parts
            .iter()
            .zip(&text.names)
            .filter(|(p, _)| !p.indices.is_empty())
            .map(|(p, n)| (n.clone(), scene.materials[p.material].name.clone()))
            .collect();
        shapes.push(ShapeFile {
            name: o.name.clone(),
            kind: "obj".into(),
            file: Some(rel),
            size: None,
            radius: None,
            rings: None,
            segments: None,
            inward: None,
            smooth_angle: None,
            material: None,
            part_materials,
            transform: Some(TransformFile {
                translation: Some(o.pose.translation.to_array()),
                rotation_deg: None,
                quaternion: Some(o.pose.rotation.to_array()),
                scale: Some(o.pose.scale.to_array().to_vec()),
            }),
            emitter: o.emitter.map(|e| EmitterFile {
                radiance: ValueFile::Rgb(e.radiance.to_array()),
                two_sided: e.two_sided,
                sky_gradient: (e.sky_gradient != Vec3::ZERO).then(|| e.sky_gradient.to_array()),
            }),
        });
    }
    let c = &scene.camera;
    let (right, up, back) = (c.right(), c.up, -c.forward);
    let to_world = [
        [right.x, up.x, back.x, c.origin.x],
        [right.y, up.y, back.y, c.origin.y],
        [right.z, up.z, back.z, c.origin.z],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let file = SceneFile {
        format: FORMAT.into(),
        version: VERSION,
        camera: CameraFile {
            origin: None,
            target: None,
            up: None,
            to_world: Some(to_world),
            fov_y: c.fov_y_deg,
            width: c.width,
            height: c.height,
        },
        render: RenderFile {
            spp: Some(scene.settings.spp),
            max_depth: Some(scene.settings.max_depth),
            rr_depth: Some(scene.settings.rr_depth),
            seed: Some(scene.settings.seed),
        },
        materials,
        shapes,
        requires_grad: scene.requires_grad.iter().map(|p| p.to_string()).collect(),
    };
    let text = serde_json::to_string_pretty(&file).map_err(|e| Error::io(path, e))?;
    write_atomically(path, |tmp| std::fs::write(tmp, &text).map_err(|e| Error::io(tmp, e)))
}

/// A procedural albedo's source: every parameter by name, so the file reads without the graph's defaults.
fn procedural_file(p: &super::Procedural) -> Result<ProceduralFile> {
    let g = p.load_graph()?;
    let params = g
        .params
        .iter()
        .map(|info| {
            let v = match info.kind {
                psdr_materials::ParamKind::Int => serde_json::json!(p.params.ints[info.offset]),
                _ if info.len == 1 => serde_json::json!(p.params.floats[info.offset]),
                _ => serde_json::json!(p.params.floats[info.offset..info.offset + info.len]),
            };
            (info.name.clone(), v)
        })
        .collect();
    Ok(ProceduralFile { graph: p.graph.clone(), params, size: Some(p.size), tint: Some(p.tint.to_array()) })
}

/// A file-name-safe form of an object name.
fn file_safe(name: &str) -> String {
    name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).take(48).collect()
}
