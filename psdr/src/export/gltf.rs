//! glTF 2.0 binary (`.glb`) export, for Blender and the web: one node per object (its pose as TRS), one mesh
//! primitive per part (positions, normals and uvs where the part has them, u32 indices), PBR materials
//! (metallic 0; base colour and roughness as factors, or as PNG textures baked from the scene's textures, the uv
//! transform as `KHR_texture_transform`), emitters as emissive materials (`KHR_materials_emissive_strength`), and
//! the camera. Area lights have no core glTF equivalent; their emission shows on their surfaces.

use crate::error::{Error, Result};
use crate::scene::{Color, Scalar, Scene, Texture};
use glam::{Mat3, Quat};
use serde_json::{json, Value};
use std::path::Path;

/// Accumulates the binary chunk and the accessors and buffer views that point into it.
#[derive(Default)]
struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.data.len().is_multiple_of(4) {
            self.data.push(0);
        }
        let mut v = json!({ "buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len() });
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.data.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    /// A float VECn accessor (with min/max, which glTF requires for positions).
    fn floats(&mut self, values: &[f32], n: usize, kind: &str) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34962));
        let (mut lo, mut hi) = (vec![f32::MAX; n], vec![f32::MIN; n]);
        for c in values.chunks(n) {
            for k in 0..n {
                lo[k] = lo[k].min(c[k]);
                hi[k] = hi[k].max(c[k]);
            }
        }
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5126, "count": values.len() / n, "type": kind, "min": lo, "max": hi,
        }));
        self.accessors.len() - 1
    }

    fn indices(&mut self, values: &[u32]) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34963));
        self.accessors
            .push(json!({ "bufferView": view, "componentType": 5125, "count": values.len(), "type": "SCALAR" }));
        self.accessors.len() - 1
    }
}

/// A texture as PNG bytes (colour textures sRGB-encoded, data linear).
fn png(t: &Texture, srgb: bool) -> Result<Vec<u8>> {
    let enc = |v: f32| {
        let v = if srgb { crate::base::linear_to_srgb(v.clamp(0.0, 1.0)) } else { v.clamp(0.0, 1.0) };
        (v * 255.0 + 0.5) as u8
    };
    let rgb: Vec<u8> = (0..(t.width * t.height) as usize)
        .flat_map(|p| {
            let c = t.channels as usize;
            let at = |k: usize| t.texels[p * c + k.min(c - 1)];
            [enc(at(0)), enc(at(1)), enc(at(2))]
        })
        .collect();
    let mut out = vec![];
    let img = image::RgbImage::from_raw(t.width, t.height, rgb).ok_or_else(|| Error::Invalid("texture size".into()))?;
    img.write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .map_err(|e| Error::Invalid(format!("glTF export: encoding a texture: {e}")))?;
    Ok(out)
}

/// Writes `scene` as a `.glb` at `path` (atomically).
pub fn export_glb(scene: &Scene, path: &Path) -> Result<()> {
    let mut bin = Bin::default();
    let (mut images, mut textures, mut materials, mut meshes, mut nodes) = (vec![], vec![], vec![], vec![], vec![]);
    let mut texture_of = std::collections::BTreeMap::new();
    let mut texture = |bin: &mut Bin, i: usize, srgb: bool| -> Result<usize> {
        if let Some(&k) = texture_of.get(&(i, srgb)) {
            return Ok(k);
        }
        let t = scene.textures.get(i).ok_or_else(|| Error::Invalid(format!("glTF export: no texture {i}")))?;
        let view = bin.view(&png(t, srgb)?, None);
        images.push(json!({ "bufferView": view, "mimeType": "image/png" }));
        textures.push(json!({ "source": images.len() - 1 }));
        texture_of.insert((i, srgb), textures.len() - 1);
        Ok(textures.len() - 1)
    };
    for m in &scene.materials {
        let r = m.uv_transform.rows();
        let transform = json!({ "KHR_texture_transform": {
            "offset": [r[0][2], r[1][2]], "rotation": m.uv_transform.rotation_deg.to_radians(),
            "scale": [m.uv_transform.scale.x, m.uv_transform.scale.y],
        }});
        let mut pbr = json!({ "metallicFactor": 0.0 });
        match m.albedo {
            Color::Constant(c) => pbr["baseColorFactor"] = json!([c.x, c.y, c.z, 1.0]),
            Color::Texture(i) => {
                pbr["baseColorTexture"] =
                    json!({ "index": texture(&mut bin, i, true)?, "extensions": transform.clone() })
            }
        }
        match m.roughness {
            Scalar::Constant(v) => pbr["roughnessFactor"] = json!(v),
            Scalar::Texture(i) => {
                // glTF reads roughness from the green channel; psdr's scalar textures are grey.
                pbr["metallicRoughnessTexture"] =
                    json!({ "index": texture(&mut bin, i, false)?, "extensions": transform.clone() });
            }
        }
        let mut mat = json!({ "name": m.name, "pbrMetallicRoughness": pbr });
        if let Some(i) = m.normal_map {
            mat["normalTexture"] = json!({ "index": texture(&mut bin, i, false)?, "extensions": transform });
        }
        materials.push(mat);
    }
    for o in &scene.objects {
        let mut prims = vec![];
        for p in &o.parts {
            let pos: Vec<f32> = p.positions.iter().flat_map(|v| v.to_array()).collect();
            let mut attributes = json!({ "POSITION": bin.floats(&pos, 3, "VEC3") });
            if let Some(n) = &p.normals {
                let n: Vec<f32> = n.iter().flat_map(|v| v.normalize_or_zero().to_array()).collect();
                attributes["NORMAL"] = json!(bin.floats(&n, 3, "VEC3"));
            }
            if let Some(uv) = &p.uvs {
                // glTF's uv origin is the top-left of the image, psdr's the bottom-left.
                let uv: Vec<f32> = uv.iter().flat_map(|t| [t.x, 1.0 - t.y]).collect();
                attributes["TEXCOORD_0"] = json!(bin.floats(&uv, 2, "VEC2"));
            }
            let idx: Vec<u32> = p.indices.iter().flatten().copied().collect();
            let mut material = p.material;
            if let Some(radiance) = o.uniform_equivalent_radiance() {
                // An emitter gets its own material: the surface's emission (glTF's has no directional
                // profile: a sky gradient becomes the uniform radiance of the same power).
                let strength = radiance.max_element().max(1e-6);
                let mut m = materials.get(p.material).cloned().unwrap_or(json!({}));
                m["name"] = json!(format!("{}_emission", o.name));
                m["emissiveFactor"] = json!((radiance / strength).to_array());
                m["extensions"] = json!({ "KHR_materials_emissive_strength": { "emissiveStrength": strength } });
                materials.push(m);
                material = materials.len() - 1;
            }
            prims.push(json!({ "attributes": attributes, "indices": bin.indices(&idx), "material": material }));
        }
        meshes.push(json!({ "name": o.name, "primitives": prims }));
        let q = o.pose.rotation;
        nodes.push(json!({
            "name": o.name, "mesh": meshes.len() - 1,
            "translation": o.pose.translation.to_array(), "rotation": [q.x, q.y, q.z, q.w],
            "scale": o.pose.scale.to_array(),
        }));
    }
    // The camera: glTF cameras look down their -z with +y up.
    let c = &scene.camera;
    let rot = Quat::from_mat3(&Mat3::from_cols(c.right(), c.up, -c.forward)).normalize();
    nodes.push(json!({
        "name": "camera", "camera": 0, "translation": c.origin.to_array(), "rotation": [rot.x, rot.y, rot.z, rot.w],
    }));
    let cameras = json!([{ "type": "perspective", "perspective": {
        "yfov": c.fov_y_deg.to_radians(), "aspectRatio": c.width as f32 / c.height.max(1) as f32, "znear": 0.01,
    }}]);
    while !bin.data.len().is_multiple_of(4) {
        bin.data.push(0);
    }
    let used: Vec<&str> = ["KHR_texture_transform", "KHR_materials_emissive_strength"]
        .into_iter()
        .filter(|x| {
            let m = serde_json::to_string(&materials).unwrap_or_default();
            m.contains(x)
        })
        .collect();
    let mut doc = json!({
        "asset": { "version": "2.0", "generator": "psdr" },
        "scene": 0,
        "scenes": [{ "nodes": (0..nodes.len()).collect::<Vec<_>>() }],
        "nodes": nodes, "meshes": meshes, "materials": materials, "cameras": cameras,
        "accessors": bin.accessors, "bufferViews": bin.views,
        "buffers": [{ "byteLength": bin.data.len() }],
    });
    if !images.is_empty() {
        doc["images"] = json!(images);
        doc["textures"] = json!(textures);
        doc["samplers"] = json!([{ "wrapS": 10497, "wrapT": 10497 }]);
        for t in doc["textures"].as_array_mut().into_iter().flatten() {
            t["sampler"] = json!(0);
        }
    }
    if !used.is_empty() {
        doc["extensionsUsed"] = json!(used);
    }
    let mut text = serde_json::to_vec(&doc).map_err(|e| Error::Invalid(e.to_string()))?;
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let total = 12 + 8 + text.len() + 8 + bin.data.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(&(bin.data.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin.data);
    crate::output::write_atomically(path, |tmp| std::fs::write(tmp, &out).map_err(|e| Error::io(tmp, e)))
}
