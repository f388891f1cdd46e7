//! Materials in scripts: `material_segments(s, obs, #{min_pixels})` maps each material the photo shows to its
//! mask (`stages::material_segments`); `geometry_agreement(s, obs)` is the mask of the pixels where the fitted
//! scene shows what the segmentation says (the fits' `agreement` option).
//! Albedos from shading (`stages::albedo_division`): `divide_albedos(s, photo, segments, #{rounds,
//! spp, tolerance, direct_spp})` and `light_scale_search(s, photo, segments, #{range, steps, rounds, spp, tolerance, direct_spp, downsample,
//! per_channel, channel_min_gain, extend, resolution, ...})`, where
//! `segments` maps a homogeneous material's name to the mask of the photo's pixels that show it. Both change
//! the scene in place; the search is recorded in result.json as `light_scale` and returned.
//! `texture_surfaces(s, photo, segments, #{spp, top_k, colour_weight, min_contrast, min_crop, max_crop,
//! samples, library_size, graph_iters, graph_lr, embedding, embedding_weight, register, max_error_ratio,
//! register_rotation_step, register_scale_octaves, register_scale_steps, aligned_iters, aligned_lr, aligned_max_cells,
//! detail})` gives the segments that
//! show a texture (ranked with an ONNX image encoder's similarity too when `embedding` names one; crops cut from `detail`, the photo at more pixels, when given) a procedural material
//! from the library, its graph fitted to the crop (`stages::surface_textures`, `stages::graph_fit`) and, unless
//! `register` is false, registered on the segment's pixels (taken back, homogeneous, where the registered
//! texture's squared error against the photo's albedo is not below `max_error_ratio` times the flat albedo's;
//! rotations tried every `register_rotation_step` degrees, scales `register_scale_octaves` either side of the
//! search's in `register_scale_steps` per octave), recorded as `surface_textures` (crops, top matches,
//! decisions, the graph fits, the registrations).
//! `object_pictures(s, photo, segments, #{spp, max_error_ratio, max_cells, min_cells, max_size})` puts a
//! retrieved model's own pictures back on its parts where, tinted to the fitted albedo, they are closer to the
//! photo's albedo than it (`stages::object_pictures`), recorded as `object_pictures` and returned.
//! `photo_textures(s, photo, segments, #{spp, window, max_ratio, max_size, erode, detail})` gives each segment
//! whose material is one plane the photo's own pattern as its albedo texture around the fitted constant
//! (`stages::photo_textures`), recorded as `photo_textures` and returned.
//! `fit_gloss(s, photo, segments, #{spp, roughness, specular, min_gain, block, min_pixels})` gives each segment
//! whose pixels a specular lobe reproduces clearly better than a matte surface that lobe (`roughness` the
//! candidate roughnesses; `stages::gloss_fit`), the rest matte; recorded as `gloss` and returned.
//! `own_materials(s, objects)` gives each listed object's parts a material of their own where they share one
//! (the room's four walls), and `join_alike_materials(s, segments, materials, #{tolerance, name})` joins those
//! the segments show alike, and those they do not show, back into one (`stages::own_materials`); both
//! recorded and returned.

use super::api_support::{check_photo, on_backend, option_number, rhai_err, Rr, RunRef};
use super::scene_api::SceneHandle;
use super::vision_api::ObsHandle;
use crate::error::Error;
use crate::loss::{Image, Tensor};
use crate::stages::{
    agreeing_blocks, apply_object_pictures, apply_photo_textures, divide_albedos, fit_gloss, geometry_agreement,
    join_alike_materials, library_textures, material_segments, own_materials, search_light_scale, texture_surfaces,
    Division, GlossOptions, LightFitOptions, LightScaleOptions, ObjectPictureOptions, PhotoTextureOptions, Segment,
    SurfaceTextureOptions,
};
use rhai::{Array, Dynamic, Engine, Map};

pub(super) fn segments(
    what: &str,
    scene: &SceneHandle,
    photo: &Tensor,
    map: &Map,
) -> crate::Result<(Vec<f32>, Vec<Segment>)> {
    let img = photo.value();
    check_photo(what, &scene.0, img)?;
    let (w, h) = (img.width, img.height);
    let mut out = vec![];
    for (name, mask) in map {
        let material = scene.0.materials.iter().position(|m| m.name == name.as_str()).ok_or_else(|| {
            Error::Invalid(format!("{what}: the scene has no material '{name}' (segments map material names to masks)"))
        })?;
        let mask = mask
            .clone()
            .try_cast::<Tensor>()
            .ok_or_else(|| Error::Invalid(format!("{what}: the segment '{name}' is not a mask (a tensor)")))?;
        let m = mask.value();
        if (m.width, m.height) != (w, h) {
            return Err(Error::Invalid(format!(
                "{what}: the mask of '{name}' is {}x{}, not {w}x{h}",
                m.width, m.height
            )));
        }
        out.push(Segment { material, mask: m.data.iter().step_by(m.channels).copied().collect() });
    }
    Ok((img.data.clone(), out))
}

fn divide(run: &RunRef, scene: &mut SceneHandle, photo: &Tensor, map: &Map, opts: &Map) -> crate::Result<()> {
    let mut d = Division::default();
    for (k, v) in opts {
        let n = option_number("divide_albedos", k, v)?;
        match k.as_str() {
            "rounds" => d.rounds = n.max(0.0) as usize,
            "spp" => d.spp = n.max(1.0) as u32,
            "tolerance" => d.tolerance = n.max(0.0) as f32,
            "direct_spp" => d.direct_spp = n.max(0.0) as u32,
            other => {
                return Err(Error::Invalid(format!(
                    "divide_albedos: unknown option '{other}' (rounds, spp, tolerance, direct_spp)"
                )))
            }
        }
    }
    let (photo, segs) = segments("divide_albedos", scene, photo, map)?;
    on_backend(run, "divide_albedos", |b| divide_albedos(b, &mut scene.0, &photo, &segs, &d).map(|_| ()))
}

fn scale_search(run: &RunRef, scene: &mut SceneHandle, photo: &Tensor, map: &Map, opts: &Map) -> crate::Result<Map> {
    let mut o = LightScaleOptions::default();
    let mut split = LightFitOptions::default();
    let mut split_spp = 0u32;
    for (k, v) in opts {
        let what = "light_scale_search";
        match k.as_str() {
            "split_spp" => split_spp = option_number(what, k, v)?.max(0.0) as u32,
            "split_rounds" => o.split_rounds = option_number(what, k, v)?.max(0.0) as usize,
            "split_downsample" => split.downsample = option_number(what, k, v)?.max(1.0) as usize,
            "tint_prior" => split.tint_prior = option_number(what, k, v)?.max(0.0) as f32,
            "agreement" | "min_agreement" => {} // read below
            "range" => {
                let r =
                    v.clone().into_array().map_err(|_| Error::Invalid(format!("{what}: 'range' is [low, high]")))?;
                let f = |i: usize| r.get(i).map(|x| option_number(what, "range", x)).unwrap_or(Ok(f64::NAN));
                o.range = (f(0)? as f32, f(1)? as f32);
            }
            "steps" => o.steps = option_number(what, k, v)?.max(0.0) as usize,
            "rounds" => o.rounds = option_number(what, k, v)?.max(0.0) as usize,
            "spp" => o.spp = option_number(what, k, v)?.max(1.0) as u32,
            "tolerance" => o.tolerance = option_number(what, k, v)?.max(0.0) as f32,
            "direct_spp" => o.direct_spp = option_number(what, k, v)?.max(0.0) as u32,
            "downsample" => o.downsample = option_number(what, k, v)?.max(1.0) as usize,
            "extend" => o.extend = option_number(what, k, v)?.max(0.0) as usize,
            "resolution" => o.resolution = option_number(what, k, v)? as f32,
            "bounce_spp" => o.bounce_spp = option_number(what, k, v)?.max(0.0) as u32,
            "bounce_step" => o.bounce_step = option_number(what, k, v)? as f32,
            "bounce_l1" => {
                o.bounce_l1 = v.as_bool().map_err(|_| Error::Invalid(format!("{what}: 'bounce_l1' is true or false")))?
            }
            "bounce_passes" => o.bounce_passes = option_number(what, k, v)?.max(1.0) as usize,
            "channel_min_gain" => o.channel_min_gain = option_number(what, k, v)?.max(0.0) as f32,
            "per_channel" => {
                o.per_channel =
                    v.as_bool().map_err(|_| Error::Invalid(format!("{what}: 'per_channel' is true or false")))?
            }
            other => {
                return Err(Error::Invalid(format!(
                    "{what}: unknown option '{other}' (range, steps, rounds, spp, tolerance, direct_spp, \
                     downsample, per_channel, channel_min_gain, extend, resolution, bounce_spp, bounce_step, bounce_passes, bounce_l1, split_spp, split_rounds, split_downsample, tint_prior, agreement, min_agreement)"
                )))
            }
        }
    }
    let agreement = super::light_api::agreement("light_scale_search", scene, opts)?;
    o.agreement = agreement.mask.clone();
    split.agreement = agreement;
    if split_spp > 0 {
        split.spp = split_spp;
        o.split = Some(split);
    }
    let (photo, segs) = segments("light_scale_search", scene, photo, map)?;
    let found = on_backend(run, "light_scale_search", |b| search_light_scale(b, &mut scene.0, &photo, &segs, &o))?;
    let v = serde_json::to_value(&found).map_err(|e| Error::Invalid(e.to_string()))?;
    let mut c = run.borrow_mut();
    c.recorded.insert("light_scale".into(), v.clone());
    // A scale at the range's end is where the search stopped, not a minimum: the photo did not separate the
    // lights' brightness from the albedos there, and the report says so.
    // (The searched range per channel: `range`, and the steps past its ends where `extend` took the search.)
    let span = |c: usize| {
        let f = found.factors.iter().map(|f| f[c]);
        (f.clone().fold(o.range.0, f32::min), f.fold(o.range.1, f32::max))
    };
    let edge: Vec<String> = ["R", "G", "B"]
        .into_iter()
        .zip(found.chosen)
        .enumerate()
        .filter(|&(c, (_, f))| f <= span(c).0 * 1.001 || f >= span(c).1 * 0.999)
        .map(|(c, (name, _))| format!("{name} ({:.2}..{:.2})", span(c).0, span(c).1))
        .collect();
    if !edge.is_empty() && !found.factors.is_empty() {
        c.report.notes.push(format!(
            "light_scale_search: the scale of {} ended at the searched range's end; the photo did not \
             tell the lights' brightness from the albedos there, so both may be off by that factor",
            edge.join(", ")
        ));
    }
    drop(c);
    rhai::serde::to_dynamic(v)
        .map_err(|e| Error::Invalid(e.to_string()))?
        .try_cast::<Map>()
        .ok_or_else(|| Error::Invalid("light_scale_search: result is not a map".into()))
}

/// A `detail` option's image (the photo at more pixels, `obs.photo_detail(working, long_side)`).
fn detail_image(what: &str, v: &Dynamic) -> crate::Result<Image> {
    let t = v.clone().try_cast::<Tensor>().ok_or_else(|| {
        Error::Invalid(format!("{what}: 'detail' is an image (obs.photo_detail(working, long_side))"))
    })?;
    Ok(t.value().clone())
}

fn textures(run: &RunRef, scene: &mut SceneHandle, photo: &Tensor, map: &Map, opts: &Map) -> crate::Result<Dynamic> {
    let what = "texture_surfaces";
    let mut o = SurfaceTextureOptions::default();
    let mut library_size = 128usize;
    let mut detail: Option<Image> = None;
    for (k, v) in opts {
        if k == "detail" {
            detail = Some(detail_image(what, v)?);
            continue;
        }
        if k == "register" {
            o.register = v
                .as_bool()
                .or_else(|_| v.as_int().map(|n| n != 0))
                .map_err(|_| Error::Invalid(format!("{what}: 'register' is true or false")))?;
            continue;
        }
        if k == "embedding" {
            let path = v.clone().into_string().map_err(|_| Error::Invalid(format!("{what}: 'embedding' is a path")))?;
            o.embedding = (!path.is_empty()).then(|| std::path::PathBuf::from(path));
            continue;
        }
        let n = option_number(what, k, v)?;
        match k.as_str() {
            "spp" => o.spp = n.max(1.0) as u32,
            "top_k" => o.top_k = n.max(1.0) as usize,
            "colour_weight" => o.colour_weight = n.max(0.0) as f32,
            "min_contrast" => o.min_contrast = n.max(0.0) as f32,
            "min_crop" => o.min_crop = n.max(24.0) as usize,
            "max_crop" => o.max_crop = n.max(24.0) as usize,
            "samples" => o.samples = n.clamp(1.0, 8.0) as usize,
            "contrast_tolerance" => o.contrast_tolerance = n.max(0.0) as f32,
            "library_size" => library_size = n.clamp(16.0, 1024.0) as usize,
            "graph_iters" => o.graph_fit.iters = n.max(0.0) as usize,
            "graph_lr" => o.graph_fit.lr = n.max(0.0),
            "embedding_weight" => o.embedding_weight = n.max(0.0) as f32,
            "max_error_ratio" => o.registration.max_error_ratio = n.max(0.0) as f32,
            "register_rotation_step" => o.registration.rotation_step = n.clamp(1.0, 360.0) as f32,
            "register_scale_octaves" => o.registration.scale_octaves = n.clamp(0.0, 4.0) as f32,
            "register_scale_steps" => o.registration.scale_steps = n.clamp(1.0, 96.0) as usize,
            "aligned_iters" => o.aligned_fit.iters = n.max(0.0) as usize,
            "aligned_lr" => o.aligned_fit.lr = n.max(0.0),
            "aligned_max_cells" => o.aligned_max_cells = n.max(16.0) as usize,
            other => {
                return Err(Error::Invalid(format!(
                    "{what}: unknown option '{other}' (spp, top_k, colour_weight, min_contrast, min_crop, max_crop, \
                     samples, contrast_tolerance, library_size, graph_iters, graph_lr, embedding, embedding_weight, \
                     register, max_error_ratio, register_rotation_step, register_scale_octaves, \
                     register_scale_steps, aligned_iters, aligned_lr, aligned_max_cells, detail)"
                )))
            }
        }
    }
    let (photo, segs) = segments(what, scene, photo, map)?;
    let library = library_textures(library_size)?;
    let found =
        on_backend(run, what, |b| texture_surfaces(b, &mut scene.0, &photo, detail.as_ref(), &segs, &library, &o))?;
    record_value(run, "surface_textures", &found)
}

fn pictures(run: &RunRef, scene: &mut SceneHandle, photo: &Tensor, map: &Map, opts: &Map) -> crate::Result<Dynamic> {
    let what = "object_pictures";
    let mut o = ObjectPictureOptions::default();
    for (k, v) in opts {
        let n = option_number(what, k, v)?;
        match k.as_str() {
            "spp" => o.spp = n.max(1.0) as u32,
            "max_error_ratio" => o.max_error_ratio = n.max(0.0) as f32,
            "max_cells" => o.max_cells = n.max(1.0) as usize,
            "min_cells" => o.min_cells = n.max(1.0) as usize,
            "max_size" => o.max_size = n.clamp(1.0, 8192.0) as usize,
            other => {
                return Err(Error::Invalid(format!(
                    "{what}: unknown option '{other}' (spp, max_error_ratio, max_cells, min_cells, max_size)"
                )))
            }
        }
    }
    let (photo, segs) = segments(what, scene, photo, map)?;
    let found = on_backend(run, what, |b| apply_object_pictures(b, &mut scene.0, &photo, &segs, &o))?;
    record_value(run, what, &found)
}

fn gloss(run: &RunRef, scene: &mut SceneHandle, photo: &Tensor, map: &Map, opts: &Map) -> crate::Result<Dynamic> {
    let what = "fit_gloss";
    let mut o = GlossOptions::default();
    for (k, v) in opts {
        if k == "roughness" {
            let list = v
                .clone()
                .into_typed_array::<f64>()
                .map_err(|t| Error::Invalid(format!("{what}: roughness is a list of numbers, got {t}")))?;
            o.roughness = list.into_iter().map(|r| r as f32).collect();
            continue;
        }
        let n = option_number(what, k, v)?;
        match k.as_str() {
            "spp" => o.spp = n.max(1.0) as u32,
            "specular" => o.specular = n as f32,
            "min_gain" => o.min_gain = n.clamp(0.0, 1.0) as f32,
            "block" => o.block = n.clamp(1.0, 64.0) as usize,
            "min_pixels" => o.min_pixels = n.max(0.0) as f32,
            other => {
                return Err(Error::Invalid(format!(
                    "{what}: unknown option '{other}' (spp, roughness, specular, min_gain, block, min_pixels)"
                )))
            }
        }
    }
    let (photo, segs) = segments(what, scene, photo, map)?;
    let found = on_backend(run, what, |b| fit_gloss(b, &mut scene.0, &photo, &segs, &o))?;
    record_value(run, "gloss", &found)
}

fn photo_textures(
    run: &RunRef,
    scene: &mut SceneHandle,
    photo: &Tensor,
    map: &Map,
    opts: &Map,
) -> crate::Result<Dynamic> {
    let what = "photo_textures";
    let mut o = PhotoTextureOptions::default();
    let mut detail: Option<Image> = None;
    for (k, v) in opts {
        if k == "detail" {
            detail = Some(detail_image(what, v)?);
            continue;
        }
        let n = option_number(what, k, v)?;
        match k.as_str() {
            "spp" => o.spp = n.max(1.0) as u32,
            "window" => o.window = n.max(1e-3) as f32,
            "max_ratio" => o.max_ratio = n.max(1.0) as f32,
            "max_size" => o.max_size = n.clamp(2.0, 8192.0) as usize,
            "erode" => o.erode = n.clamp(0.0, 16.0) as usize,
            other => {
                return Err(Error::Invalid(format!(
                    "{what}: unknown option '{other}' (spp, window, max_ratio, max_size, erode, detail)"
                )))
            }
        }
    }
    let (photo, segs) = segments(what, scene, photo, map)?;
    let done = on_backend(run, what, |b| apply_photo_textures(b, &mut scene.0, &photo, detail.as_ref(), &segs, &o))?;
    record_value(run, what, &done)
}

/// A script's array of names.
fn names(what: &str, list: &Array) -> crate::Result<Vec<String>> {
    list.iter()
        .map(|v| {
            v.clone().into_string().map_err(|t| Error::Invalid(format!("{what}: expected names (strings), got {t}")))
        })
        .collect()
}

/// `value` recorded in result.json under `what` and returned to the script.
fn record_value<T: serde::Serialize>(run: &RunRef, what: &str, value: &T) -> crate::Result<Dynamic> {
    let v = serde_json::to_value(value).map_err(|e| Error::Invalid(e.to_string()))?;
    run.borrow_mut().recorded.insert(what.into(), v.clone());
    rhai::serde::to_dynamic(v).map_err(|e| Error::Invalid(e.to_string()))
}

/// `own_materials(s, objects)`: the copies made, recorded as `own_materials`.
fn own(run: &RunRef, scene: &mut SceneHandle, objects: &Array) -> crate::Result<Dynamic> {
    let done = own_materials(&mut scene.0, &names("own_materials", objects)?)?;
    record_value(run, "own_materials", &done)
}

/// `join_alike_materials(s, segments, materials, #{tolerance, name})`: the listed materials the segments show
/// alike (albedo within `tolerance`, 0.4, of the most seen's; a segment's pixels: its mask's sum) and those
/// they do not show, joined into one named `name` ("wall"), recorded as `joined_materials` (() where nothing
/// was joined).
fn join_alike(run: &RunRef, scene: &mut SceneHandle, map: &Map, group: &Array, opts: &Map) -> crate::Result<Dynamic> {
    const WHAT: &str = "join_alike_materials";
    let (mut tolerance, mut name) = (0.4f32, "wall".to_string());
    for (k, v) in opts {
        match k.as_str() {
            "tolerance" => tolerance = option_number(WHAT, k, v)?.max(0.0) as f32,
            "name" => {
                name = v
                    .clone()
                    .into_string()
                    .map_err(|t| Error::Invalid(format!("{WHAT}: name must be a string, got {t}")))?
            }
            other => return Err(Error::Invalid(format!("{WHAT}: unknown option '{other}' (tolerance, name)"))),
        }
    }
    let mut seen = vec![];
    for (segment, mask) in map {
        let mask = mask
            .clone()
            .try_cast::<Tensor>()
            .ok_or_else(|| Error::Invalid(format!("{WHAT}: the segment '{segment}' is not a mask (a tensor)")))?;
        seen.push((segment.to_string(), mask.value().data.iter().map(|&v| v as f64).sum::<f64>()));
    }
    let done = join_alike_materials(&mut scene.0, &seen, &names(WHAT, group)?, tolerance, &name)?;
    record_value(run, "joined_materials", &done)
}

fn segments_of(scene: &SceneHandle, obs: &ObsHandle, opts: &Map) -> crate::Result<Map> {
    let mut min_pixels = 20usize;
    for (k, v) in opts {
        match k.as_str() {
            "min_pixels" => min_pixels = option_number("material_segments", k, v)?.max(1.0) as usize,
            other => return Err(Error::Invalid(format!("material_segments: unknown option '{other}' (min_pixels)"))),
        }
    }
    let inst = obs.0.require_instances()?;
    let mut out = Map::new();
    for (name, mask) in material_segments(&scene.0, inst, min_pixels)? {
        let t = Tensor::constant(Image::new(inst.width, inst.height, 1, mask)?);
        out.insert(name.into(), Dynamic::from(t));
    }
    Ok(out)
}

/// `geometry_agreement(s, obs, #{block, min_share})`: per photo pixel 1 where the scene's primary hit is what
/// the segmentation says the photo shows there, 0 where not (`stages::geometry_agreement`), a mask of the
/// camera's size; with `block` > 1, whole blocks of that side, 1 where at least `min_share` (default 0.75) of
/// a block's pixels agree (`stages::agreeing_blocks`).
fn agreement_of(scene: &SceneHandle, obs: &ObsHandle, opts: &Map) -> crate::Result<Tensor> {
    const WHAT: &str = "geometry_agreement";
    let (mut block, mut min_share) = (1usize, super::light_api::MIN_AGREEMENT);
    for (k, v) in opts {
        match k.as_str() {
            "block" => block = option_number(WHAT, k, v)?.max(1.0) as usize,
            "min_share" => min_share = option_number(WHAT, k, v)?.clamp(0.0, 1.0) as f32,
            other => return Err(Error::Invalid(format!("{WHAT}: unknown option '{other}' (block, min_share)"))),
        }
    }
    let inst = obs.0.require_instances()?;
    let mut mask = geometry_agreement(&scene.0, inst)?;
    if block > 1 {
        mask = agreeing_blocks(&mask, inst.width, inst.height, block, min_share);
    }
    Ok(Tensor::constant(Image::new(inst.width, inst.height, 1, mask)?))
}

pub fn register(engine: &mut Engine, run: &RunRef) {
    engine.register_fn("material_segments", |s: &mut SceneHandle, obs: ObsHandle, opts: Map| -> Rr<Map> {
        segments_of(s, &obs, &opts).map_err(rhai_err)
    });
    engine.register_fn("geometry_agreement", |s: &mut SceneHandle, obs: ObsHandle| -> Rr<Tensor> {
        agreement_of(s, &obs, &Map::new()).map_err(rhai_err)
    });
    engine.register_fn("geometry_agreement", |s: &mut SceneHandle, obs: ObsHandle, opts: Map| -> Rr<Tensor> {
        agreement_of(s, &obs, &opts).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn(
        "texture_surfaces",
        move |s: &mut SceneHandle, photo: Tensor, segments: Map, opts: Map| -> Rr<Dynamic> {
            textures(&r, s, &photo, &segments, &opts).map_err(rhai_err)
        },
    );
    let r = run.clone();
    engine.register_fn(
        "object_pictures",
        move |s: &mut SceneHandle, photo: Tensor, segments: Map, opts: Map| -> Rr<Dynamic> {
            pictures(&r, s, &photo, &segments, &opts).map_err(rhai_err)
        },
    );
    let r = run.clone();
    engine.register_fn(
        "fit_gloss",
        move |s: &mut SceneHandle, photo: Tensor, segments: Map, opts: Map| -> Rr<Dynamic> {
            gloss(&r, s, &photo, &segments, &opts).map_err(rhai_err)
        },
    );
    let r = run.clone();
    engine.register_fn(
        "photo_textures",
        move |s: &mut SceneHandle, photo: Tensor, segments: Map, opts: Map| -> Rr<Dynamic> {
            photo_textures(&r, s, &photo, &segments, &opts).map_err(rhai_err)
        },
    );
    let r = run.clone();
    engine.register_fn("own_materials", move |s: &mut SceneHandle, objects: Array| -> Rr<Dynamic> {
        own(&r, s, &objects).map_err(rhai_err)
    });
    let r = run.clone();
    engine.register_fn(
        "join_alike_materials",
        move |s: &mut SceneHandle, segments: Map, materials: Array, opts: Map| -> Rr<Dynamic> {
            join_alike(&r, s, &segments, &materials, &opts).map_err(rhai_err)
        },
    );
    let r = run.clone();
    engine.register_fn(
        "divide_albedos",
        move |s: &mut SceneHandle, photo: Tensor, segments: Map, opts: Map| -> Rr<()> {
            divide(&r, s, &photo, &segments, &opts).map_err(rhai_err)
        },
    );
    let r = run.clone();
    engine.register_fn(
        "light_scale_search",
        move |s: &mut SceneHandle, photo: Tensor, segments: Map, opts: Map| -> Rr<Map> {
            scale_search(&r, s, &photo, &segments, &opts).map_err(rhai_err)
        },
    );
}
