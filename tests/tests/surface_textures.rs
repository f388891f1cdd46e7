//! Procedural materials for the surfaces a photo shows (`stages::texture_surfaces`, the second pass of
//! room.rhai's material stage), on the known-geometry room at 256 x 192 whose floor and walls wear library
//! materials at known uv transforms (uv in metres, so a scale is repeats per metre), started where the
//! homogeneous pass leaves it (each material's mean albedo as a constant, the true lights): the true material
//! among the top 3 for each and applied, its scale within a factor 1.25 and its rotation (modulo 90 degrees:
//! planks and stripes turned by 90 differ, but the search's rotations are judged modulo what the library's
//! patterns repeat); the ceiling and the furniture (homogeneous) stay homogeneous; the applied materials keep
//! the fitted mean albedo; the textured render shows the photo's contrast in the crops, its image at 1/8
//! size stays as close to the photo as the homogeneous one's, and at the working size it is closer (the
//! textures registered in phase with the photo's).

use glam::{Vec2, Vec3};
use psdr::backend::CpuBackend;
use psdr::loss::Image;
use psdr::render::{render_cpu, SceneData};
use psdr::scene::{Color, Scene, Texture, UvTransform};
use psdr::stages::{
    contrast, library_textures, relative_rmse_downsampled, texture_surfaces, LibraryTexture, Segment,
    SurfaceTextureOptions,
};
use psdr_tests::known_geometry::truth_room;

fn render(s: &Scene, spp: u32) -> Vec<f32> {
    let mut settings = s.settings.clone();
    settings.spp = spp;
    render_cpu(&SceneData::build(s).unwrap(), &settings, &|_, _| {}).radiance
}

/// `material` of `scene` wears the library texture `tex` at `scale` repeats per metre, turned by `rotation`.
fn wear(scene: &mut Scene, material: &str, tex: &LibraryTexture, scale: f32, rotation: f32) {
    scene.textures.push(Texture {
        path: None,
        width: tex.size as u32,
        height: tex.size as u32,
        channels: 3,
        texels: tex.albedo.clone(),
    });
    let mat = scene.materials.iter_mut().find(|x| x.name == material).unwrap();
    mat.albedo = Color::Texture(scene.textures.len() - 1);
    mat.uv_transform = UvTransform { scale: Vec2::splat(scale), rotation_deg: rotation, offset: Vec2::ZERO };
}

#[test]
fn textured_floor_and_walls_get_their_library_materials() {
    let (mut truth, _) = truth_room();
    (truth.camera.width, truth.camera.height) = (256, 192);
    let library = library_textures(128).unwrap();
    // (material, library texture, repeats per metre, rotation).
    let worn = [("floor", "oak_planks", 0.5f32, 90.0f32), ("wall", "wallpaper_stripes", 1.0, 0.0)];
    for (m, name, scale, rotation) in worn {
        wear(&mut truth, m, library.iter().find(|t| t.name == name).unwrap(), scale, rotation);
    }
    let t = std::time::Instant::now();
    let frame = {
        let mut s = truth.clone();
        s.settings.spp = 128;
        render_cpu(&SceneData::build(&s).unwrap(), &s.settings, &|_, _| {})
    };
    // What the homogeneous pass leaves: each textured albedo as its mean.
    let mut start = truth.clone();
    for (m, name, _, _) in worn {
        let tex = library.iter().find(|t| t.name == name).unwrap();
        let n = (tex.size * tex.size) as f32;
        let mean = Vec3::from_array(std::array::from_fn(|c| tex.albedo.iter().skip(c).step_by(3).sum::<f32>() / n));
        let mat = start.materials.iter_mut().find(|x| x.name == m).unwrap();
        (mat.albedo, mat.uv_transform) = (Color::Constant(mean), UvTransform::default());
    }
    start.textures.clear();
    // Segments from the truth's object ids (a segmenter's masks): structure by class, furniture by object.
    let segments: Vec<Segment> = (0..start.materials.len())
        .filter(|&m| start.materials[m].name != "light")
        .map(|m| {
            let mask = frame
                .object_id
                .iter()
                .map(|&o| {
                    let shows = start.objects.get(o as usize).is_some_and(|x| x.parts[0].material == m);
                    f32::from(u8::from(shows))
                })
                .collect();
            Segment { material: m, mask }
        })
        .collect();
    let before = render(&start, 64);
    // The library's parameters as they are (the graph fit to the crop is tests/procedural_fit.rs's: on this photo,
    // whose floor is the library's oak at default parameters, it widens the seams and the render's crop
    // contrast comes out 30 % above the photo's, a bias of the descriptor recorded in the closing notes).
    let mut opts = SurfaceTextureOptions { spp: 128, ..Default::default() };
    opts.graph_fit.iters = 0;
    let found =
        texture_surfaces(&mut CpuBackend, &mut start, &frame.radiance, None, &segments, &library, &opts).unwrap();
    eprintln!("texture_surfaces: {:.1} s (with the photo's render)", t.elapsed().as_secs_f32());
    eprintln!("{}", serde_json::to_string_pretty(&found).unwrap());
    for (m, name, scale, rotation) in worn {
        let s = found.iter().find(|s| s.material == m).unwrap();
        let hit = s.matches.iter().find(|x| x.name == name).unwrap_or_else(|| panic!("{m}: {name} not in {s:?}"));
        let ratio = hit.scale / scale;
        assert!((0.8..=1.25).contains(&ratio), "{m}: scale {} vs {scale}", hit.scale);
        let turn = (hit.rotation_deg - rotation).rem_euclid(180.0);
        assert!(!(1e-3..=180.0 - 1e-3).contains(&turn), "{m}: rotation {} vs {rotation}", hit.rotation_deg);
        assert_eq!(s.chosen.as_ref().map(|c| c.name.as_str()), Some(name), "{m}: {}", s.decision);
        // The tint keeps the fitted mean albedo.
        let mat = start.materials.iter().find(|x| x.name == m).unwrap();
        let Color::Texture(i) = mat.albedo else { panic!("{m} not textured") };
        let t = &start.textures[i];
        let n = (t.width * t.height) as f32;
        let tex = library.iter().find(|t| t.name == name).unwrap();
        for c in 0..3 {
            let want = tex.albedo.iter().skip(c).step_by(3).sum::<f32>() / n;
            let got = t.texels.iter().skip(c).step_by(3).sum::<f32>() / n;
            assert!((got / want - 1.0).abs() < 0.02, "{m} channel {c}: mean {got} vs {want}");
        }
    }
    for s in found.iter().filter(|s| !["floor", "wall"].contains(&s.material.as_str())) {
        assert!(s.chosen.is_none(), "{s:?}");
    }
    // The textured scene shows the photo's texture where the homogeneous one is flat (contrast inside each
    // crop within 25 % of the photo's), and its image at 1/8 size (means, which the tint keeps) is no worse
    // than 5 % of the photo's mean beyond the homogeneous one's. Registered on their pixels, the textures are in
    // phase with the photo's: at the working size, pixel by pixel, closer to it than the mean colours (a
    // texture out of phase is farther from the photo than its mean colour).
    let after = render(&start, 64);
    let (w, h) = (256usize, 192usize);
    let crop_contrast = |img: &[f32], r: [usize; 4]| {
        let data = (r[1]..r[1] + r[3])
            .flat_map(|y| (r[0]..r[0] + r[2]).flat_map(move |x| (0..3).map(move |c| img[3 * (y * w + x) + c])))
            .collect();
        contrast(&Image { width: r[2], height: r[3], channels: 3, data })
    };
    for s in found.iter().filter(|s| s.chosen.is_some()) {
        let r = s.crop.unwrap();
        let (photo, flat, textured) =
            (crop_contrast(&frame.radiance, r), crop_contrast(&before, r), crop_contrast(&after, r));
        eprintln!("{}: crop contrast photo {photo:.3}, homogeneous {flat:.3}, textured {textured:.3}", s.material);
        assert!((textured / photo - 1.0).abs() < 0.25, "{}: {textured} vs {photo}", s.material);
    }
    let (e0, e1) = (
        relative_rmse_downsampled(&before, &frame.radiance, w, h, 8),
        relative_rmse_downsampled(&after, &frame.radiance, w, h, 8),
    );
    eprintln!("RMSE at 1/8 size: homogeneous {e0:.4}, textured {e1:.4}");
    assert!(e1 < e0 + 0.05, "textured {e1} vs homogeneous {e0}");
    let (f0, f1) = (
        relative_rmse_downsampled(&before, &frame.radiance, w, h, 1),
        relative_rmse_downsampled(&after, &frame.radiance, w, h, 1),
    );
    eprintln!("RMSE at the working size: homogeneous {f0:.4}, textured {f1:.4}");
    assert!(f1 < f0, "textured {f1} vs homogeneous {f0}");
    for s in found.iter().filter(|s| s.chosen.is_some()) {
        assert!(s.registration.is_some(), "{}: not registered ({})", s.material, s.decision);
    }
}

/// A brick wall whose courses are 3 pixels high at the working size (its mortar averaged away there) is
/// recognised from the photo at twice that size (`texture_surfaces`' detail photo, as room.rhai passes it at
/// `texture_size`): the crops are cut from the detail photo and seen through uv grids cast at its pixels, so
/// the scale found is the wall's own (it would be off by the factor 2 if the grid were cast at working pixels).
/// (Measured: from the working photo alone brick_wall at 0.81 times the wall's scale, from the photo at 2x at
/// 0.96; under the descriptor-log ranking tried and not kept, 1.33 and 1.00.) Then registered on the wall's
/// pixels (`texture_registration`): courses upright, scale within 3 %, in phase with the photo's.
/// The known-geometry room whose walls wear `brick_wall` at 1 repeat per metre, upright: the photo at 256 x
/// 192 (each pixel the mean of 2 x 2 of the detail photo's, rendered at twice the size), the wall's segment
/// from the object ids, and the start the homogeneous pass leaves (the wall's mean albedo as a constant).
struct BrickWall {
    start: Scene,
    photo: Vec<f32>,
    detail: Image,
    segments: [Segment; 1],
    wall: usize,
    mean: Vec3,
}

fn brick_wall(library: &[LibraryTexture]) -> BrickWall {
    let (mut truth, _) = truth_room();
    let tex = library.iter().find(|t| t.name == "brick_wall").unwrap();
    wear(&mut truth, "wall", tex, 1.0, 0.0);
    let (w, h) = (256usize, 192usize);
    let detail = {
        let mut s = truth.clone();
        (s.camera.width, s.camera.height) = (2 * w as u32, 2 * h as u32);
        let data = render(&s, 32);
        Image { width: 2 * w, height: 2 * h, channels: 3, data }
    };
    // The working photo: each pixel the mean of its 2x2 detail pixels (the working size's area average).
    let photo: Vec<f32> = (0..w * h * 3)
        .map(|i| {
            let (p, c) = (i / 3, i % 3);
            let (x, y) = (p % w, p / w);
            let at = |dx: usize, dy: usize| detail.data[((2 * y + dy) * 2 * w + 2 * x + dx) * 3 + c];
            (at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1)) / 4.0
        })
        .collect();
    (truth.camera.width, truth.camera.height) = (w as u32, h as u32);
    let ids = {
        let mut s = truth.clone();
        s.settings.spp = 4;
        render_cpu(&SceneData::build(&s).unwrap(), &s.settings, &|_, _| {}).object_id
    };
    let mut start = truth.clone();
    let n = (tex.size * tex.size) as f32;
    let mean = Vec3::from_array(std::array::from_fn(|c| tex.albedo.iter().skip(c).step_by(3).sum::<f32>() / n));
    let mat = start.materials.iter_mut().find(|x| x.name == "wall").unwrap();
    (mat.albedo, mat.uv_transform) = (Color::Constant(mean), UvTransform::default());
    start.textures.clear();
    let wall = start.materials.iter().position(|m| m.name == "wall").unwrap();
    let mask = ids
        .iter()
        .map(|&o| f32::from(u8::from(start.objects.get(o as usize).is_some_and(|x| x.parts[0].material == wall))))
        .collect();
    let segments = [Segment { material: wall, mask }];
    BrickWall { start, photo, detail, segments, wall, mean }
}

#[test]
fn a_brick_wall_is_recognised_from_the_photo_at_twice_the_working_size() {
    let library = library_textures(128).unwrap();
    let (name, scale) = ("brick_wall", 1.0f32);
    let BrickWall { mut start, photo, detail, segments, wall, mean } = brick_wall(&library);
    let (w, h) = (256usize, 192usize);
    let mut opts = SurfaceTextureOptions { spp: 32, ..Default::default() };
    opts.graph_fit.iters = 0;
    let found =
        texture_surfaces(&mut CpuBackend, &mut start, &photo, Some(&detail), &segments, &library, &opts).unwrap();
    let s = &found[0];
    eprintln!("{}", serde_json::to_string_pretty(s).unwrap());
    let [x, y, cw, ch] = s.crop.unwrap();
    assert_eq!(s.detail_crop, Some([2 * x, 2 * y, 2 * cw, 2 * ch]), "the detail crop is the working crop at 2x");
    assert!(2 * cw <= opts.max_crop && 2 * ch <= opts.max_crop, "{s:?}");
    let chosen = s.chosen.as_ref().unwrap_or_else(|| panic!("nothing chosen: {}", s.decision));
    assert_eq!(chosen.name, name, "{}", s.decision);
    let ratio = chosen.scale / scale;
    assert!((0.8..=1.25).contains(&ratio), "scale {} vs {scale}", chosen.scale);
    // The search's own rotation is not asserted: its descriptor barely tells a turned brick bond from an upright
    // one (it picks 45 degrees here, as on real room08's wall). The registration on every wall pixel puts the
    // courses back: upright (or upside down: the bond is the same), the wall's scale within 3 %, and each wall's
    // bricks where the photo has them (walls have their own uv origins): pixel by pixel at the working size the
    // textured render is closer to the photo than the homogeneous one (out of phase it would be farther).
    eprintln!("search's rotation {} (the truth's 0)", chosen.rotation_deg);
    let reg = s.registration.as_ref().unwrap_or_else(|| panic!("not registered: {}", s.decision));
    let turn = reg.rotation_deg.rem_euclid(180.0);
    assert!(!(1e-3..=180.0 - 1e-3).contains(&turn), "registered rotation {}", reg.rotation_deg);
    assert!((reg.scale / scale - 1.0).abs() < 0.03, "registered scale {} vs {scale}", reg.scale);
    let mut flat = start.clone();
    let m = &mut flat.materials[wall];
    (m.albedo, m.procedural) = (Color::Constant(mean), None);
    let rmse = |img: &[f32]| relative_rmse_downsampled(img, &photo, w, h, 1);
    let (e_flat, e_textured) = (rmse(&render(&flat, 32)), rmse(&render(&start, 32)));
    eprintln!("RMSE at the working size: homogeneous {e_flat:.4}, registered texture {e_textured:.4}");
    assert!(e_textured < 0.8 * e_flat, "registered {e_textured} vs homogeneous {e_flat}");
}

/// The descriptor ranks, the registration decides: the photo's walls are red bricks, but the library the
/// search sees has its bricks grey (their luminance), so its colour term ranks a rug, cork, a geometric
/// wallpaper and granite first and the bricks fifth, as real room11's brick walls ranked fifth. Every one of the top matches that
/// reproduces the crop's contrast is applied and registered on the wall's pixels, and the bricks, closest to
/// the photo's albedo pixel by pixel, are kept (tinted back to the wall's colour, upright, at the wall's scale);
/// every other candidate tried came out farther.
#[test]
fn the_registration_chooses_among_the_top_matches() {
    let library = library_textures(128).unwrap();
    let BrickWall { mut start, photo, detail, segments, .. } = brick_wall(&library);
    let mut recoloured = library.clone();
    let bricks = recoloured.iter_mut().find(|t| t.name == "brick_wall").unwrap();
    bricks.albedo = bricks.albedo.chunks(3).flat_map(|c| [0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; 3]).collect();
    let mut opts = SurfaceTextureOptions { spp: 32, top_k: 5, ..Default::default() };
    opts.graph_fit.iters = 0;
    let found =
        texture_surfaces(&mut CpuBackend, &mut start, &photo, Some(&detail), &segments, &recoloured, &opts).unwrap();
    let s = &found[0];
    eprintln!("{}", serde_json::to_string_pretty(s).unwrap());
    let rank = s.matches.iter().position(|m| m.name == "brick_wall");
    assert!(rank.is_some_and(|r| r > 0), "the setup needs bricks among the top 5 but not first: {:?}", s.matches);
    let chosen = s.chosen.as_ref().unwrap_or_else(|| panic!("nothing chosen: {}", s.decision));
    assert_eq!(chosen.name, "brick_wall", "{}", s.decision);
    let reg = s.registration.as_ref().unwrap();
    assert!(reg.applied && reg.error_ratio < 0.9, "{reg:?}");
    assert!(
        (reg.scale - 1.0).abs() < 0.03 && !(1e-3..=180.0 - 1e-3).contains(&reg.rotation_deg.rem_euclid(180.0)),
        "{reg:?}"
    );
    assert!(!s.tried.is_empty(), "no other candidate tried: {}", s.decision);
    for t in &s.tried {
        assert!(
            t.error_ratio.is_none_or(|e| e >= reg.error_ratio),
            "{t:?} came out closer than the kept bricks: {reg:?}"
        );
    }
}
