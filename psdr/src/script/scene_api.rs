//! Scenes, renders and images in scripts: `load_scene`, `scene.get/set`, `render`, `load_image`,
//! `load_photo`, `save_image`, and the JSON summaries `result.json` holds.

use super::api_support::{rhai_err, Rr, RunRef};
use crate::error::{Error, Result};
use crate::loss::{Image, Tensor};
use crate::optim::{select, Rendered};
use crate::scene::ParamPath;
use crate::scene::{load_scene, save_scene, srgb_to_linear, Scene};
use glam::EulerRot;
use rhai::{Array, Dynamic, Engine};
use serde_json::{json, Value};
use std::path::Path;
use std::rc::Rc;

/// A scene in a script (cloned when assigned; `optimize` and `set` change it in place).
#[derive(Clone)]
pub struct SceneHandle(pub Scene);

/// A render (or, inside a loss closure, the iteration's render whose outputs carry gradients).
#[derive(Clone)]
pub struct RenderHandle(pub Rc<Rendered>);

/// Floats of a script value: a number, or an array of numbers.
pub fn floats(v: &Dynamic, what: &str) -> Result<Vec<f32>> {
    let one = |x: &Dynamic| -> Option<f32> {
        x.as_float().ok().map(|f| f as f32).or_else(|| x.as_int().ok().map(|i| i as f32))
    };
    if let Some(x) = one(v) {
        return Ok(vec![x]);
    }
    if let Some(arr) = v.clone().try_cast::<Array>() {
        return arr
            .iter()
            .map(|x| one(x).ok_or_else(|| Error::Invalid(format!("{what}: {} is not a number", x.type_name()))))
            .collect();
    }
    Err(Error::Invalid(format!("{what}: expected a number or an array of numbers, found {}", v.type_name())))
}

fn to_array(v: &[f32]) -> Array {
    v.iter().map(|&x| Dynamic::from_float(x as f64)).collect()
}

/// Reads an image as linear RGB: PNG/JPEG decoded from sRGB, EXR as stored.
pub fn read_image(path: &Path) -> Result<Image> {
    if !path.is_file() {
        return Err(Error::io(path, "image not found"));
    }
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let (w, h, data) = if ext == "exr" {
        crate::base::read_exr_rgb(path)?
    } else {
        let img = image::open(path).map_err(|e| Error::io(path, e))?.to_rgb32f();
        let (w, h) = img.dimensions();
        (w, h, img.into_raw().into_iter().map(srgb_to_linear).collect())
    };
    Image::new(w as usize, h as usize, 3, data).map_err(|e| Error::io(path, e))
}

/// Writes a tensor as an image: `.exr` linear (any channel count), otherwise 8-bit sRGB PNG (1 or 3 channels).
pub fn write_image(t: &Image, path: &Path) -> Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if ext == "exr" {
        let n = t.width * t.height;
        let names = ["R", "G", "B", "A"];
        let channels = (0..t.channels)
            .map(|c| {
                let name = names.get(c).map_or(format!("C{c}"), |s| s.to_string());
                (name, (0..n).map(|p| t.data[p * t.channels + c]).collect())
            })
            .collect::<Vec<_>>();
        return crate::output::write_atomically(path, |tmp| {
            crate::output::write_exr_channels(tmp, t.width as u32, t.height as u32, &channels)
        });
    }
    let rgb: Vec<f32> = match t.channels {
        3 => t.data.clone(),
        1 => t.data.iter().flat_map(|&v| [v, v, v]).collect(),
        c => return Err(Error::io(path, format!("a PNG takes 1 or 3 channels, the image has {c}"))),
    };
    crate::output::write_png_srgb(path, t.width as u32, t.height as u32, &rgb)
}

/// Camera as `result.json` reports it.
pub fn camera_json(scene: &Scene) -> Value {
    let c = &scene.camera;
    json!({
        "width": c.width, "height": c.height, "fov_y_deg": c.fov_y_deg,
        "origin": c.origin.to_array(), "forward": c.forward.to_array(), "up": c.up.to_array(),
    })
}

/// Objects (pose), materials (constant values) and lights of a scene, for `result.json`.
pub fn scene_summary(scene: &Scene) -> Value {
    let objects: Vec<Value> = scene
        .objects
        .iter()
        .map(|o| {
            let (yaw, pitch, roll) = o.pose.rotation.to_euler(EulerRot::YXZ);
            json!({
                "name": o.name,
                "translation": o.pose.translation.to_array(),
                "yaw_deg": yaw.to_degrees(), "pitch_deg": pitch.to_degrees(), "roll_deg": roll.to_degrees(),
                "scale": o.pose.scale.to_array(),
                "triangles": o.parts.iter().map(|p| p.indices.len()).sum::<usize>(),
                "emitter": o.emitter.map(|e| json!({"radiance": e.radiance.to_array(), "two_sided": e.two_sided})),
            })
        })
        .collect();
    let value = |p: ParamPath| p.get(scene).ok();
    let materials: Vec<Value> = scene
        .materials
        .iter()
        .map(|m| {
            let n = || m.name.clone();
            json!({
                "name": m.name,
                "albedo": value(ParamPath::MaterialAlbedo(n())).map_or(json!("texture"), |v| json!(v)),
                "roughness": value(ParamPath::MaterialRoughness(n())).map_or(json!("texture"), |v| json!(v[0])),
                "specular": value(ParamPath::MaterialSpecular(n())).map_or(json!("texture"), |v| json!(v[0])),
                "uv_scale": m.uv_transform.scale.to_array(), "uv_rotation_deg": m.uv_transform.rotation_deg,
            })
        })
        .collect();
    json!({ "objects": objects, "materials": materials })
}

/// Renders `scene` with options `#{spp, seed, max_depth}` on the run's backend.
fn render(run: &RunRef, scene: &Scene, opts: &rhai::Map) -> Result<Rendered> {
    let mut settings = scene.settings.clone();
    for (k, v) in opts {
        let n = v.as_int().map_err(|_| Error::Invalid(format!("render: option '{k}' must be an integer")))?;
        let n = u32::try_from(n).map_err(|_| Error::Invalid(format!("render: option '{k}' = {n} is out of range")))?;
        match k.as_str() {
            "spp" => settings.spp = n,
            "seed" => settings.seed = n,
            "max_depth" => settings.max_depth = n,
            _ => return Err(Error::Invalid(format!("render: unknown option '{k}' (spp, seed, max_depth)"))),
        }
    }
    crate::backend::check_settings(&settings)?;
    let mut ctx = run.borrow_mut();
    let backend = ctx
        .backend
        .as_mut()
        .ok_or_else(|| Error::Invalid("render() cannot be called inside a loss closure; use its argument".into()))?;
    let data = crate::render::SceneData::build(scene)?;
    let frame = backend.render(&data, &settings, &|_, _| {})?;
    Ok(Rendered::constant(frame, scene.objects.iter().map(|o| o.name.clone()).collect()))
}

/// A path length in vertices from a script: at least 1.
fn path_vertices(what: &str, n: i64) -> Rr<u32> {
    u32::try_from(n)
        .ok()
        .filter(|&v| v >= 1)
        .ok_or_else(|| rhai_err(Error::Invalid(format!("{what} = {n}: a path has at least 1 vertex"))))
}

pub fn register(engine: &mut Engine, run: &RunRef) {
    engine.register_type_with_name::<SceneHandle>("Scene");
    engine.register_type_with_name::<RenderHandle>("Render");

    engine.register_fn("load_scene", |path: &str| -> Rr<SceneHandle> {
        load_scene(Path::new(path)).map(SceneHandle).map_err(rhai_err)
    });
    engine.register_fn("save", |s: &mut SceneHandle, path: &str| -> Rr<()> {
        save_scene(&s.0, Path::new(path)).map_err(rhai_err)
    });
    engine.register_fn("get", |s: &mut SceneHandle, path: &str| -> Rr<Array> {
        let p: ParamPath = path.parse().map_err(rhai_err)?;
        p.get(&s.0).map(|v| to_array(&v)).map_err(rhai_err)
    });
    engine.register_fn("set", |s: &mut SceneHandle, path: &str, value: Dynamic| -> Rr<()> {
        let p: ParamPath = path.parse().map_err(rhai_err)?;
        let v = floats(&value, path).map_err(rhai_err)?;
        p.set(&mut s.0, &v).map_err(rhai_err)?;
        crate::scene::validate::validate(&s.0).map_err(|(f, m)| rhai_err(Error::Invalid(format!("{path}: {f}: {m}"))))
    });
    engine.register_fn("params", |s: &mut SceneHandle, pattern: &str| -> Rr<Array> {
        let v = select(&s.0, pattern).map_err(rhai_err)?;
        Ok(v.iter().map(|p| Dynamic::from(p.to_string())).collect())
    });
    engine.register_fn("objects", |s: &mut SceneHandle| -> Array {
        s.0.objects.iter().map(|o| Dynamic::from(o.name.clone())).collect()
    });
    engine.register_fn("lights", |s: &mut SceneHandle| -> Array {
        s.0.objects.iter().filter(|o| o.emitter.is_some()).map(|o| Dynamic::from(o.name.clone())).collect()
    });
    engine.register_fn("materials", |s: &mut SceneHandle| -> Array {
        s.0.materials.iter().map(|m| Dynamic::from(m.name.clone())).collect()
    });
    engine.register_get("width", |s: &mut SceneHandle| s.0.camera.width as i64);
    engine.register_get("height", |s: &mut SceneHandle| s.0.camera.height as i64);
    // The path length every render of the scene uses unless told otherwise (vertices: 1 = emitters seen
    // directly, 2 = direct light, 3 = one bounce more...) and the vertex from which Russian roulette may end a
    // path: the fits must model as many bounces as the photo records.
    engine.register_get("max_depth", |s: &mut SceneHandle| s.0.settings.max_depth as i64);
    engine.register_set("max_depth", |s: &mut SceneHandle, n: i64| -> Rr<()> {
        s.0.settings.max_depth = path_vertices("max_depth", n)?;
        Ok(())
    });
    engine.register_get("rr_depth", |s: &mut SceneHandle| s.0.settings.rr_depth as i64);
    engine.register_set("rr_depth", |s: &mut SceneHandle, n: i64| -> Rr<()> {
        s.0.settings.rr_depth = path_vertices("rr_depth", n)?;
        Ok(())
    });
    engine.register_fn("set_resolution", |s: &mut SceneHandle, w: i64, h: i64| -> Rr<()> {
        if !(1..=u32::MAX as i64).contains(&w) || !(1..=u32::MAX as i64).contains(&h) {
            return Err(rhai_err(Error::Invalid(format!("set_resolution: {w}x{h} is not a usable image size"))));
        }
        s.0.camera.width = w as u32;
        s.0.camera.height = h as u32;
        Ok(())
    });

    let r = run.clone();
    engine.register_fn("render", move |s: &mut SceneHandle, opts: rhai::Map| -> Rr<RenderHandle> {
        render(&r, &s.0, &opts).map(|x| RenderHandle(Rc::new(x))).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn("render", move |s: &mut SceneHandle| -> Rr<RenderHandle> {
        render(&r, &s.0, &rhai::Map::new()).map(|x| RenderHandle(Rc::new(x))).map_err(rhai_err)
    });
    engine.register_get("radiance", |r: &mut RenderHandle| r.0.radiance().map_err(rhai_err));
    engine.register_get("depth", |r: &mut RenderHandle| r.0.depth().map_err(rhai_err));
    engine.register_get("albedo", |r: &mut RenderHandle| r.0.albedo().map_err(rhai_err));
    engine.register_get("normal", |r: &mut RenderHandle| r.0.normal().map_err(rhai_err));
    engine.register_fn("mask", |r: &mut RenderHandle, object: &str| r.0.mask(object).map_err(rhai_err));

    engine.register_fn("load_image", |path: &str| -> Rr<Tensor> {
        read_image(Path::new(path)).map(Tensor::constant).map_err(rhai_err)
    });
    engine.register_fn("load_photo", |path: &str, s: SceneHandle| -> Rr<Tensor> {
        let img = read_image(Path::new(path)).map_err(rhai_err)?;
        let (w, h) = (s.0.camera.width as usize, s.0.camera.height as usize);
        if (img.width, img.height) != (w, h) {
            return Err(rhai_err(Error::io(
                Path::new(path),
                format!(
                    "the photo is {}x{} but the scene's camera renders {w}x{h}; resize one \
                     (scene.set_resolution({}, {}) keeps the field of view)",
                    img.width, img.height, img.width, img.height
                ),
            )));
        }
        Ok(Tensor::constant(img))
    });
    engine.register_fn("save_image", |t: Tensor, path: &str| -> Rr<()> {
        write_image(t.value(), Path::new(path)).map_err(rhai_err)
    });
}
