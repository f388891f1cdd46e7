//! Photo textures (`stages::apply_photo_textures`, the last step of room.rhai's material stage), on the
//! known-geometry room at 256 x 192 whose floor wears planks no library material has (a tone per plank from a
//! hash, a fine grain along them), started where the homogeneous pass leaves it (the floor's mean albedo as a
//! constant, the true lights): the floor takes the photo's pattern, pixel by pixel in phase with the truth's
//! albedo (its correlation over the floor's pixels at least 0.75, its albedo error at most 0.7 of the
//! constant's; measured 0.83 and 0.57 with the default 1 m window, 0.91 and 0.44 with 3 m: the window takes
//! the planks' tones that vary slower than it with the lights),
//! its mean kept (within 3 %: the lights fitted to the constant stay right), the render closer to the photo at
//! the working size and no farther at 1/8 size; the texels the photo does not show keep the constant; the
//! walls' material, on four planes, the furniture's and the ceiling its lights hang on are left homogeneous.

use glam::{Vec2, Vec3};
use psdr::backend::CpuBackend;
use psdr::render::{render_cpu, Frame, SceneData};
use psdr::scene::{Color, Scene, Texture, UvTransform};
use psdr::stages::{apply_photo_textures, relative_rmse_downsampled, PhotoTextureOptions, Segment};
use psdr_tests::known_geometry::truth_room;

fn render(s: &Scene, spp: u32) -> Frame {
    let mut settings = s.settings.clone();
    settings.spp = spp;
    render_cpu(&SceneData::build(s).unwrap(), &settings, &|_, _| {})
}

/// Planks 0.15 m wide along v, each a tone of its own (0.7-1.3 of the base) with a grain of 2 cm stripes
/// across it, on a 4 m square of texels (uv in metres: scale 0.25 repeats per metre).
fn planks(base: Vec3) -> Texture {
    let n = 400usize;
    let mut texels = Vec::with_capacity(n * n * 3);
    for j in 0..n {
        for i in 0..n {
            let (u, v) = ((i as f32 + 0.5) * 0.01, (j as f32 + 0.5) * 0.01);
            let plank = (u / 0.15).floor() as u32;
            let tone = 0.7 + 0.6 * ((plank.wrapping_mul(2_654_435_761) >> 16) % 1000) as f32 / 1000.0;
            let grain = 1.0 + 0.08 * (v * std::f32::consts::TAU / 0.02).sin();
            texels.extend_from_slice(&(base * tone * grain).min(Vec3::splat(0.95)).to_array());
        }
    }
    Texture { path: None, width: n as u32, height: n as u32, channels: 3, texels }
}

#[test]
fn a_plank_floor_takes_the_photos_pattern_in_phase_and_keeps_its_mean() {
    let (mut truth, _) = truth_room();
    (truth.camera.width, truth.camera.height) = (256, 192);
    let floor = truth.materials.iter().position(|m| m.name == "floor").unwrap();
    let Color::Constant(base) = truth.materials[floor].albedo else { panic!("the floor is a constant") };
    let tex = planks(base);
    let n = (tex.width * tex.height) as f32;
    let mean = Vec3::from_array(std::array::from_fn(|c| tex.texels.iter().skip(c).step_by(3).sum::<f32>() / n));
    truth.textures.push(tex);
    let m = &mut truth.materials[floor];
    m.albedo = Color::Texture(truth.textures.len() - 1);
    m.uv_transform = UvTransform { scale: Vec2::splat(0.25), rotation_deg: 0.0, offset: Vec2::ZERO };
    let photo = render(&truth, 128);
    // What the homogeneous pass leaves: the floor's mean as a constant.
    let mut start = truth.clone();
    start.materials[floor].albedo = Color::Constant(mean);
    start.materials[floor].uv_transform = UvTransform::default();
    start.textures.clear();
    // Segments from the truth's object ids (a segmenter's masks): the floor, the walls and a cabinet.
    let segment = |name: &str| {
        let m = start.materials.iter().position(|x| x.name == name).unwrap();
        let mask = photo
            .object_id
            .iter()
            .map(|&o| f32::from(u8::from(start.objects.get(o as usize).is_some_and(|x| x.parts[0].material == m))))
            .collect();
        Segment { material: m, mask }
    };
    let segments = [segment("floor"), segment("wall"), segment("cabinet_7"), segment("ceiling")];
    let before = render(&start, 64);
    let mut fitted = start.clone();
    let t = std::time::Instant::now();
    let done = apply_photo_textures(
        &mut CpuBackend,
        &mut fitted,
        &photo.radiance,
        None,
        &segments,
        &PhotoTextureOptions::default(),
    )
    .unwrap();
    eprintln!("apply_photo_textures: {:.1} s", t.elapsed().as_secs_f32());
    eprintln!("{}", serde_json::to_string_pretty(&done).unwrap());
    assert!(done[0].applied, "{}", done[0].decision);
    assert!(matches!(fitted.materials[floor].albedo, Color::Texture(_)));
    for d in &done[1..] {
        assert!(!d.applied, "{}: {}", d.material, d.decision);
    }
    assert!(done[3].decision.starts_with("lights lie on this plane"), "ceiling: {}", done[3].decision);
    assert_eq!(fitted.materials[segments[1].material].albedo, start.materials[segments[1].material].albedo);
    assert_eq!(fitted.materials[segments[2].material].albedo, start.materials[segments[2].material].albedo);

    // The albedo the camera sees on the floor's pixels (the renders' albedo AOV), against the truth's.
    let after = render(&fitted, 64);
    let on_floor: Vec<usize> = (0..segments[0].mask.len()).filter(|&p| segments[0].mask[p] > 0.5).collect();
    let lum =
        |f: &Frame, p: usize| 0.2126 * f.albedo[3 * p] + 0.7152 * f.albedo[3 * p + 1] + 0.0722 * f.albedo[3 * p + 2];
    let (t, a): (Vec<f64>, Vec<f64>) = on_floor.iter().map(|&p| (lum(&photo, p) as f64, lum(&after, p) as f64)).unzip();
    let k = t.len() as f64;
    let (mt, ma) = (t.iter().sum::<f64>() / k, a.iter().sum::<f64>() / k);
    let cov = t.iter().zip(&a).map(|(x, y)| (x - mt) * (y - ma)).sum::<f64>();
    let (vt, va) = (t.iter().map(|x| (x - mt).powi(2)).sum::<f64>(), a.iter().map(|y| (y - ma).powi(2)).sum::<f64>());
    let correlation = cov / (vt * va).sqrt().max(1e-12);
    let error = |f: &Frame| {
        let e: f64 = on_floor
            .iter()
            .map(|&p| (0..3).map(|c| (f.albedo[3 * p + c] - photo.albedo[3 * p + c]).powi(2) as f64).sum::<f64>())
            .sum();
        (e / k).sqrt()
    };
    let (flat, textured) = (error(&before), error(&after));
    eprintln!("floor albedo: correlation {correlation:.3}, RMS error flat {flat:.4}, textured {textured:.4}; means {ma:.4} vs flat {:.4}", {
        let b: f64 = on_floor.iter().map(|&p| lum(&before, p) as f64).sum();
        b / k
    });
    assert!(correlation >= 0.75, "correlation {correlation}");
    assert!(textured <= 0.7 * flat, "albedo error {textured} against the constant's {flat}");
    let flat_mean: f64 = on_floor.iter().map(|&p| lum(&before, p) as f64).sum::<f64>() / k;
    assert!((ma / flat_mean - 1.0).abs() < 0.03, "mean {ma} against the constant's {flat_mean}");

    // The render against the photo.
    let (w, h) = (256, 192);
    let (f0, f1) = (
        relative_rmse_downsampled(&before.radiance, &photo.radiance, w, h, 1),
        relative_rmse_downsampled(&after.radiance, &photo.radiance, w, h, 1),
    );
    let (e0, e1) = (
        relative_rmse_downsampled(&before.radiance, &photo.radiance, w, h, 8),
        relative_rmse_downsampled(&after.radiance, &photo.radiance, w, h, 8),
    );
    eprintln!("image RMSE: working size flat {f0:.4}, textured {f1:.4}; 1/8 size flat {e0:.4}, textured {e1:.4}");
    assert!(f1 < f0, "working size: textured {f1} against flat {f0}");
    assert!(e1 <= e0 + 0.002, "1/8 size: textured {e1} against flat {e0}");

    // The texels the photo does not show are the constant itself.
    let Color::Texture(i) = fitted.materials[floor].albedo else { unreachable!() };
    let texels = &fitted.textures[i].texels;
    let constant = texels.chunks(3).filter(|t| Vec3::from_slice(t) == mean).count();
    let unseen = (1.0 - done[0].seen) * (texels.len() / 3) as f32;
    assert!(done[0].seen > 0.2 && done[0].seen < 1.0, "seen {}", done[0].seen);
    assert!(constant as f32 >= unseen - 1.0, "{constant} texels at the constant, {unseen} unseen");
}
