//! Material choice for a crop (weight-free: texture descriptor + mean colour) and the texture-transform search,
//! on crops of library materials seen through a known transform (scale 1.5-3, rotation 0 or 45 degrees) under
//! a known light with 2 % noise, views mip-filtered as a camera averages a fine texture. Stated: the true
//! material in the top 3 in at least 70 % of the cases (measured: 8 of 8, all first); where it is found, its
//! rotation recovered where the texture shows it (the found transform's view differs from the true one's by
//! a texture distance above `SAME_LOOK`; a glaze or a polished concrete looks the same at any rotation, tiles
//! the same turned by 90 degrees) and its scale within a factor 1.25 in every case where the crop shows texture
//! (measured 7 of 7; the eighth, a knit at 3 repeats across 64 pixels, averages to a flat colour, contrast
//! 0.3 %, and was matched at 0.65 of its scale: no transform shows there to be recovered).
//! Before the views were mip-filtered they aliased (several texels per pixel), a 2 % change of scale changed
//! them completely, and the scale was within 1.25 in 5 of 7.

use psdr::loss::{texture_loss, Tensor};
use psdr::stages::{contrast, library_textures, search_materials, transformed_view};

/// Crops with less luminance contrast than this show no texture (the pipeline keeps far flatter-looking
/// surfaces homogeneous: its threshold is 8 % local contrast).
const MIN_VISIBLE_CONTRAST: f32 = 0.01;

/// Two views this close (texture distance) look the same: a rotation between them is not visible.
const SAME_LOOK: f32 = 0.05;
use psdr_tests::SplitMix64;

#[test]
fn library_materials_are_found_with_their_transforms() {
    let t = std::time::Instant::now();
    let library = library_textures(128).unwrap();
    eprintln!("{} library textures in {:.1} s", library.len(), t.elapsed().as_secs_f32());
    // The rotation check can fail: stripes turned by 45 degrees do not look the same.
    let stripes = library.iter().find(|t| t.name == "wallpaper_stripes").unwrap();
    let view = |r: f32| Tensor::constant(transformed_view(stripes, 2.0, r, 64));
    let turned = texture_loss(&view(45.0), &view(0.0)).unwrap().item().unwrap();
    assert!(turned > 4.0 * SAME_LOOK, "stripes turned by 45 degrees look {turned} from upright ones");
    let mut rng = SplitMix64(11);
    let cases: Vec<(usize, f32, f32)> =
        (0..8).map(|k| ((k * 37 + 5) % library.len(), [1.5f32, 3.0][k % 2], [0.0f32, 45.0][(k / 2) % 2])).collect();
    let (mut in_top3, mut scale_ok, mut rotation_ok, mut found) = (0, 0, 0, 0);
    for &(i, scale, rotation) in &cases {
        let light = 0.7f32;
        let mut crop = transformed_view(&library[i], scale, rotation, 64);
        // A crop whose texture averages out over its pixels shows no transform to recover.
        let view_contrast = contrast(&crop);
        let shows_texture = view_contrast >= MIN_VISIBLE_CONTRAST;
        // Seen under a known light with noise; the caller divides the light back out.
        for v in crop.data.iter_mut() {
            let g = 1.0 + 0.02 * (2.0 * rng.next_f32() - 1.0);
            *v = (*v * light * g) / light;
        }
        let t = std::time::Instant::now();
        let top = search_materials(&crop, &library, 3, 1.0).unwrap();
        let names: Vec<&str> = top.iter().map(|m| m.name.as_str()).collect();
        eprintln!(
            "{} at scale {scale} rotation {rotation}: {names:?} ({:.1} s)",
            library[i].name,
            t.elapsed().as_secs_f32()
        );
        if let Some(m) = top.iter().find(|m| m.name == library[i].name) {
            in_top3 += 1;
            if !shows_texture {
                eprintln!("  found; the view's contrast is {view_contrast:.4}: no texture shows, transform not judged");
                continue;
            }
            found += 1;
            let ratio = m.scale / scale;
            scale_ok += usize::from((0.8..=1.25).contains(&ratio));
            // The truth's view against the found rotation's at the true scale: the same look counts as found.
            let want = Tensor::constant(transformed_view(&library[i], scale, rotation, 64));
            let seen = Tensor::constant(transformed_view(&library[i], scale, m.rotation_deg, 64));
            let apart = texture_loss(&seen, &want).unwrap().item().unwrap();
            rotation_ok += usize::from(m.rotation_deg == rotation || apart < SAME_LOOK);
            eprintln!(
                "  found: scale {} (x{ratio:.2}), rotation {} (looks {apart:.3} from the true rotation's)",
                m.scale, m.rotation_deg
            );
        }
    }
    eprintln!(
        "top 3: {in_top3}/{}; scale within 1.25: {scale_ok}/{found}; rotation: {rotation_ok}/{found}",
        cases.len()
    );
    assert!(in_top3 * 10 >= cases.len() * 7, "true material in the top 3 in {in_top3} of {}", cases.len());
    assert_eq!(rotation_ok, found, "rotation recovered in {rotation_ok} of {found}");
    assert_eq!(scale_ok, found, "scale within 1.25 in {scale_ok} of {found}");
    assert!(found >= 6, "only {found} crops show texture");
}

/// Wood stays wood when the albedo division leaves light in the crop (issue "Appearance": no wood crop matched
/// to a non-wood material): wood crops the search sent elsewhere while its colour term was the relative RGB
/// distance (bench_texture_search, 2026-11-26: wood_paneling under a dim warm light, walnut_planks under a bright
/// cool one), and oak planks under both lights, searched as `texture_surfaces` searches a crop (64 pixels, 3x3
/// uv samples per pixel, top 3, colour weight 1). Stated: every top-1 a wood material. (painted_wood under the
/// dim light still goes to canvas, but its crop's contrast, 0.04, is under the pipeline's 0.08: the pipeline
/// keeps such a surface homogeneous and never searches it.)
#[test]
fn wood_crops_under_a_light_left_in_them_stay_wood() {
    use psdr::stages::search_materials_with;
    use psdr_tests::texture_queries::{facing_grid, query, variant, WOOD};
    let library = library_textures(128).unwrap();
    let (camera, grid) = (facing_grid(64, 4), facing_grid(64, 3));
    let mut rng = SplitMix64(7);
    let cases = [
        ("wood_paneling", "dim_warm"),
        ("walnut_planks", "bright_cool"),
        ("oak_planks", "dim_warm"),
        ("oak_planks", "bright_cool"),
    ];
    let mut astray = vec![];
    for (name, light) in cases {
        let tex = library.iter().find(|t| t.name == name).unwrap();
        let crop = query(tex, variant(light).unwrap(), &camera, &mut rng);
        let top = search_materials_with(&crop, &grid, &library, 3, 1.0, None).unwrap();
        let names: Vec<&str> = top.iter().map(|m| m.name.as_str()).collect();
        let scored: Vec<String> =
            top.iter().map(|m| format!("{} {:.3} ({:.5})", m.name, m.distance, m.texture_distance)).collect();
        eprintln!("{name} under {light}: {scored:?}");
        if !WOOD.contains(&names[0]) {
            astray.push(format!("{name} under {light} -> {}", names[0]));
        }
    }
    assert!(astray.is_empty(), "wood crops matched to non-wood materials: {astray:?}");
}
