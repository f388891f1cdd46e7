//! A retrieved model's own pictures back on its parts (the books on a shelf, a fabric's print, a desk's grain):
//! the fits work with one constant albedo per part, which the albedo division and the light-scale search set
//! from the photo; each part whose model has a picture (`Material::model_look`, from its MTL's map_Kd) then gets
//! that picture tinted per colour channel so that its mean over the part's photo pixels is that albedo, but only
//! where it is closer to the photo than the constant: the photo's albedo (photo over the shading) in blocks of
//! the part's pixels, each compared with the tinted picture at the uv the fitted pose puts there, the squared
//! colour error below `max_error_ratio` times the constant's (a model held out of the database brings another
//! model's picture, whose print may be nowhere in the photo). A part the photo does not show (no segment: the
//! fits left it grey) gets the model's own colour, with its picture where it has one: the model's look is the
//! best guess there; one shown on too few blocks to tell gets its picture at the fitted albedo.

use super::albedo_division::Segment;
use super::surface_textures::blurred;
use super::texture_registration::{Cells, TexelMips};
use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::render::SceneData;
use crate::scene::{Color, ModelLook, Scene, Texture, TextureEncoding};
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct ObjectPictureOptions {
    /// Samples per pixel of the render the shading is taken from.
    pub spp: u32,
    /// A picture goes on where its squared error against the photo's albedo is below this times the constant's.
    pub max_error_ratio: f32,
    /// The part's pixels are compared in at most about this many blocks.
    pub max_cells: usize,
    /// Fewer blocks than this do not decide: the picture goes on at the albedo's mean.
    pub min_cells: usize,
    /// The longest side (texels) a picture keeps on the renderer: resampled to a square power of two at most this.
    pub max_size: usize,
}

impl Default for ObjectPictureOptions {
    fn default() -> Self {
        ObjectPictureOptions { spp: 64, max_error_ratio: 0.9, max_cells: 4096, min_cells: 16, max_size: 512 }
    }
}

/// What was decided for one part (result.json's `object_pictures`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct ObjectPicture {
    pub material: String,
    pub picture: Option<String>,
    /// Blocks of the part's photo pixels compared (0: not shown, or no uvs there).
    pub cells: usize,
    /// The tinted picture's squared error against the photo's albedo over the constant's (None: not compared).
    pub error_ratio: Option<f32>,
    /// The per-channel gain on the picture's linear texels.
    pub tint: [f32; 3],
    pub applied: bool,
    pub decision: String,
}

/// Every material with a model's look and a constant albedo: the parts no segment shows get the model's colour
/// (its picture at that mean, where it has one); the pictures of the others are decided as above. In place.
pub fn apply_object_pictures(
    backend: &mut dyn Backend,
    scene: &mut Scene,
    photo: &[f32],
    segments: &[Segment],
    opts: &ObjectPictureOptions,
) -> Result<Vec<ObjectPicture>> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    if photo.len() != w * h * 3 {
        return Err(Error::Invalid(format!("object_pictures: the photo is not the camera's {w}x{h} RGB")));
    }
    let segment_of = |m: usize| segments.iter().find(|s| s.material == m);
    // (material, the model's look, its segment)
    let todo: Vec<(usize, ModelLook, Option<&Segment>)> = (0..scene.materials.len())
        .filter(|&m| matches!(scene.materials[m].albedo, Color::Constant(_)))
        .filter_map(|m| Some((m, scene.materials[m].model_look.clone()?, segment_of(m))))
        .filter(|(_, look, seg)| seg.is_none() || look.picture.is_some())
        .collect();
    if todo.is_empty() {
        return Ok(vec![]);
    }
    let progress = crate::progress::activity(
        format!("object pictures: the shading at {} spp, then each part's picture compared", opts.spp.max(1)),
        Some(todo.len()),
    );
    let data = SceneData::build(scene)?;
    let shading = if todo.iter().any(|(_, _, seg)| seg.is_some()) {
        let mut settings = scene.settings.clone();
        settings.spp = opts.spp.max(1);
        blurred(&backend.render(&data, &settings, &|_, _| {})?.radiance, w, h)
    } else {
        vec![]
    };
    let mut out = vec![];
    for (m, look, seg) in todo {
        progress.advance();
        let material = &scene.materials[m];
        let Color::Constant(albedo) = material.albedo else { continue };
        let mut entry = ObjectPicture {
            material: material.name.clone(),
            picture: look.picture.as_ref().map(|p| p.display().to_string()),
            cells: 0,
            error_ratio: None,
            tint: [1.0; 3],
            applied: false,
            decision: String::new(),
        };
        let picture = match look.picture.as_deref().map(|p| Texture::load(p, TextureEncoding::Srgb, 3)) {
            None => None,
            Some(Ok(t)) => Some(square(&t, opts.max_size)),
            Some(Err(e)) if seg.is_some() => {
                entry.decision = format!("the picture does not read ({e}): the fitted constant");
                out.push(entry);
                continue;
            }
            Some(Err(_)) => None,
        };
        let Some(picture) = picture else {
            // Unseen, without a picture: the model's colour.
            scene.materials[m].albedo = Color::Constant(look.albedo);
            scene.materials[m].model_look = None;
            entry.applied = true;
            entry.decision = "not shown: the model's colour".into();
            out.push(entry);
            continue;
        };
        let size = picture.width as usize;
        let transform = material.uv_transform.texture_transform().prepared();
        let cells = seg.map(|seg| {
            let pixels = seg.mask.iter().filter(|&&v| v > 0.5).count();
            let side = ((pixels as f64 / opts.max_cells.max(1) as f64).sqrt().ceil() as usize).max(1);
            let map: Vec<f32> =
                (0..w * h * 3).map(|i| (photo[i] * albedo[i % 3] / shading[i].max(1e-4)).clamp(0.0, 1.0)).collect();
            Cells::gather(&data, m as u32, &seg.mask, &map, side)
        });
        entry.cells = cells.as_ref().map_or(0, Cells::len);
        let tint = match cells.as_ref().filter(|c| c.len() >= opts.min_cells.max(1)) {
            Some(cells) => {
                let mips = TexelMips::rgb(size, &picture.texels);
                let texels: Vec<[f64; 3]> =
                    (0..cells.len()).map(|i| mips.sample_rgb(&transform, cells.uv[i], cells.footprint[i])).collect();
                // The tint that keeps the part's mean colour where the fits put it.
                let tint: [f64; 3] = std::array::from_fn(|c| {
                    let want = albedo[c] as f64 * cells.len() as f64;
                    want / texels.iter().map(|t| t[c]).sum::<f64>().max(1e-9)
                });
                let (mut pictured, mut constant) = (0.0, 0.0);
                for (colour, texel) in cells.colour.iter().zip(&texels) {
                    for c in 0..3 {
                        pictured += (colour[c] - (tint[c] * texel[c]).min(1.0)).powi(2);
                        constant += (colour[c] - albedo[c] as f64).powi(2);
                    }
                }
                let ratio = (pictured / constant.max(1e-12)) as f32;
                entry.error_ratio = Some(ratio);
                entry.applied = ratio < opts.max_error_ratio;
                entry.decision = if entry.applied {
                    format!(
                        "the picture is closer to the photo's albedo on {} blocks: error {ratio:.2} of the constant's",
                        cells.len()
                    )
                } else {
                    format!(
                        "the picture is not closer to the photo's albedo on {} blocks (error {ratio:.2} of the \
                         constant's, not below {}): the fitted constant",
                        cells.len(),
                        opts.max_error_ratio
                    )
                };
                tint.map(|v| v as f32)
            }
            None => {
                // Unseen: the model's own colour; shown on too few blocks to tell: the fitted albedo.
                let (want, why) = match seg {
                    None => (look.albedo, "not shown: the picture at the model's colour".to_string()),
                    Some(_) => (
                        albedo,
                        format!(
                            "shown on {} blocks, fewer than {}: the picture at the fitted albedo",
                            entry.cells, opts.min_cells
                        ),
                    ),
                };
                entry.applied = true;
                entry.decision = why;
                (want / crate::stages::objects::picture_mean(&picture).max(Vec3::splat(1e-6))).to_array()
            }
        };
        entry.tint = tint;
        if entry.applied {
            let texels = picture.texels.chunks(3).flat_map(|p| (0..3).map(move |c| (p[c] * tint[c]).clamp(0.0, 1.0)));
            scene.textures.push(Texture { path: None, texels: texels.collect(), ..picture });
            let material = &mut scene.materials[m];
            material.albedo = Color::Texture(scene.textures.len() - 1);
            material.model_look = None;
        }
        out.push(entry);
    }
    Ok(out)
}

/// The picture resampled (the image crate's bilinear filter) to a square power of two no larger than
/// `max_size` nor than its longer side: the registration's mip chains are square, and a few megatexels of print
/// on a sofa are not what a 512-pixel photo shows.
fn square(t: &Texture, max_size: usize) -> Texture {
    let longest = t.width.max(t.height) as usize;
    let n = longest.next_power_of_two().min(max_size.max(1).next_power_of_two());
    let n = if n > longest { n / 2 } else { n }.max(1) as u32;
    let img = image::Rgb32FImage::from_raw(t.width, t.height, t.texels.clone()).expect("RGB texels of its size");
    let texels = image::imageops::resize(&img, n, n, image::imageops::FilterType::Triangle).into_raw();
    Texture { path: t.path.clone(), width: n, height: n, channels: 3, texels }
}
