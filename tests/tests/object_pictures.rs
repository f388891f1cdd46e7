//! A retrieved model's own picture back on its part (`stages::apply_object_pictures`, room.rhai's material
//! stage): the known-geometry room at 128 x 96 whose cabinet wears a striped picture (two paint colours in
//! bands, as a shelf of books shows) tinted by a known gain, started where the fits leave it (the tinted
//! picture's mean as a constant, the picture's path kept). The picture goes back on, its tint within 10 % of
//! the truth's per channel, and the render is closer to the photo on the cabinet's pixels than the constant's.
//! Where the photo's cabinet is plain, the same picture is farther from it than the constant and stays off; a
//! part the photo does not show gets its picture at the model's own colour.

use glam::Vec3;
use psdr::backend::CpuBackend;
use psdr::render::{render_cpu, SceneData};
use psdr::scene::{srgb_to_linear, Color, ModelLook, Scene, Texture, TextureEncoding};
use psdr::stages::{apply_object_pictures, ObjectPictureOptions, Segment};
use psdr_tests::known_geometry::truth_room;
use std::path::{Path, PathBuf};

/// A 64 x 64 picture of four horizontal bands, pale and dark in turn (sRGB 8-bit, as a model's JPEG).
fn write_bands(dir: &Path) -> PathBuf {
    let mut img = image::RgbImage::new(64, 64);
    for (x, y, p) in img.enumerate_pixels_mut() {
        let _ = x;
        *p = if (y / 16) % 2 == 0 { image::Rgb([230, 210, 160]) } else { image::Rgb([70, 40, 30]) };
    }
    let path = dir.join("bands.png");
    img.save(&path).unwrap();
    path
}

fn picture(path: &Path) -> Texture {
    Texture::load(path, TextureEncoding::Srgb, 3).unwrap()
}

fn mean(t: &Texture) -> Vec3 {
    t.texels.chunks(3).fold(Vec3::ZERO, |s, c| s + Vec3::new(c[0], c[1], c[2])) / (t.width * t.height) as f32
}

/// The room with the cabinet's albedo `albedo`, its photo (128 spp) and the cabinet's segment.
fn photo_of(truth: &Scene, cabinet: usize) -> (Vec<f32>, Segment) {
    let mut s = truth.clone();
    s.settings.spp = 128;
    let f = render_cpu(&SceneData::build(&s).unwrap(), &s.settings, &|_, _| {});
    let object = s.objects.iter().position(|o| o.name == "cabinet_7").unwrap() as u32;
    let mask = f.object_id.iter().map(|&o| f32::from(u8::from(o == object))).collect();
    (f.radiance, Segment { material: cabinet, mask })
}

/// Squared error of `s` rendered at 64 spp against `photo` over `mask`.
fn error_on(s: &Scene, photo: &[f32], mask: &[f32]) -> f64 {
    let mut settings = s.settings.clone();
    settings.spp = 64;
    let r = render_cpu(&SceneData::build(s).unwrap(), &settings, &|_, _| {}).radiance;
    (0..photo.len()).filter(|&i| mask[i / 3] > 0.5).map(|i| (r[i] as f64 - photo[i] as f64).powi(2)).sum()
}

#[test]
fn a_models_picture_goes_back_on_where_the_photo_shows_it() {
    let dir = std::env::temp_dir().join(format!("psdr-object-pictures-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = write_bands(&dir);
    let bands = picture(&path);
    let (mut truth, _) = truth_room();
    let cabinet = truth.materials.iter().position(|m| m.name == "cabinet_7").unwrap();
    let tint = Vec3::new(0.9, 0.7, 0.5);
    let mut tinted = bands.clone();
    tinted.texels.chunks_mut(3).for_each(|c| (0..3).for_each(|k| c[k] *= tint[k]));
    tinted.path = None;
    truth.textures.push(tinted);
    truth.materials[cabinet].albedo = Color::Texture(truth.textures.len() - 1);
    // What the fits leave: the tinted picture's mean as a constant, the picture waiting.
    let mut start = truth.clone();
    start.textures.pop();
    start.materials[cabinet].albedo = Color::Constant(mean(&bands) * tint);
    start.materials[cabinet].model_look = Some(ModelLook { albedo: mean(&bands), picture: Some(path.clone()) });
    // A part the photo does not show (no segment; the fits left it grey): the table's, with the same picture
    // under another colour.
    let table = start.materials.iter().position(|m| m.name == "table_8").unwrap();
    let table_albedo = Vec3::new(0.3, 0.2, 0.1);
    start.materials[table].albedo = Color::Constant(Vec3::splat(0.5));
    start.materials[table].model_look = Some(ModelLook { albedo: table_albedo, picture: Some(path.clone()) });

    let (photo, segment) = photo_of(&truth, cabinet);
    let mut fitted = start.clone();
    let opts = ObjectPictureOptions { spp: 64, ..Default::default() };
    let found =
        apply_object_pictures(&mut CpuBackend, &mut fitted, &photo, std::slice::from_ref(&segment), &opts).unwrap();
    eprintln!("{}", serde_json::to_string_pretty(&found).unwrap());
    let cab = found.iter().find(|p| p.material == "cabinet_7").unwrap();
    assert!(cab.applied && cab.error_ratio.unwrap() < 0.5, "{cab:?}");
    for c in 0..3 {
        assert!((cab.tint[c] / tint[c] - 1.0).abs() < 0.1, "channel {c}: tint {} for {}", cab.tint[c], tint[c]);
    }
    assert!(
        matches!(fitted.materials[cabinet].albedo, Color::Texture(_)) && fitted.materials[cabinet].model_look.is_none()
    );
    let (before, after) = (error_on(&start, &photo, &segment.mask), error_on(&fitted, &photo, &segment.mask));
    assert!(after < 0.5 * before, "the cabinet's squared error {before} -> {after}");
    // The unseen table: its picture at the model's colour.
    let tab = found.iter().find(|p| p.material == "table_8").unwrap();
    assert!(tab.applied && tab.cells == 0, "{tab:?}");
    let Color::Texture(t) = fitted.materials[table].albedo else { panic!("the table's picture is not on") };
    let m = mean(&fitted.textures[t]);
    assert!((m - table_albedo).abs().max_element() < 0.01 * table_albedo.max_element() + 2e-3, "{m} vs {table_albedo}");

    // The photo's cabinet plain (the truth's mean colour): the picture is farther from it and stays off.
    let mut plain = truth.clone();
    plain.textures.pop();
    plain.materials[cabinet].albedo = Color::Constant(mean(&bands) * tint);
    let (photo, segment) = photo_of(&plain, cabinet);
    let mut fitted = start.clone();
    let found =
        apply_object_pictures(&mut CpuBackend, &mut fitted, &photo, std::slice::from_ref(&segment), &opts).unwrap();
    let cab = found.iter().find(|p| p.material == "cabinet_7").unwrap();
    assert!(!cab.applied && cab.error_ratio.unwrap() > 1.0, "{cab:?}");
    assert_eq!(fitted.materials[cabinet].albedo, start.materials[cabinet].albedo);
    // (The bands' colours: sRGB 230 and 70 in red.)
    assert!((srgb_to_linear(230.0 / 255.0) - bands.texels[0]).abs() < 1e-3);
    let _ = std::fs::remove_dir_all(&dir);
}
