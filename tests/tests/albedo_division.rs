//! The albedo division in a light room, where light bounces many times: each round must bring every albedo
//! nearer the truth, and a few rounds must reach it. The photo is the truth rendered with 16-vertex paths
//! (converged), and so are the division's renders (scripts/room.rhai's path_depth).
//!
//! With the plain ratio (albedo x photo mean / render mean) the albedos overshoot: the render grows faster
//! than the albedos, light bouncing off them again. In this room (walls 0.8, ceiling 0.85) the worst albedo
//! went 60 -> 68 -> 102 -> 71 -> 107 % off over 1..5 rounds; the Newton steps take it to 2 %.

use glam::Vec3;
use psdr::backend::CpuBackend;
use psdr::scene::{Color, Material, RenderSettings, Scene};
use psdr::stages::{divide_albedos, Division, Segment};
use psdr_tests::known_geometry::truth_room;

/// The truth room with light surfaces, and per material the pixels that show it.
fn light_room() -> (Scene, Vec<f32>, Vec<Segment>) {
    let (mut truth, _) = truth_room();
    let light = [
        ("floor", Vec3::new(0.6, 0.45, 0.3)),
        ("wall", Vec3::new(0.8, 0.78, 0.72)),
        ("ceiling", Vec3::splat(0.85)),
        ("cabinet_7", Vec3::new(0.3, 0.45, 0.7)),
        ("table_8", Vec3::new(0.8, 0.4, 0.25)),
    ];
    for (name, a) in light {
        let m = truth.materials.iter_mut().find(|m| m.name == name).unwrap();
        *m = Material::diffuse(name, a);
    }
    truth.settings = RenderSettings { spp: 512, max_depth: 16, rr_depth: 3, seed: 7 };
    let frame = psdr_tests::render(&truth);
    assert!(frame.radiance.iter().all(|v| v.is_finite()));
    let segments: Vec<Segment> = light
        .iter()
        .map(|(name, _)| {
            let material = truth.materials.iter().position(|m| m.name == *name).unwrap();
            let shows =
                |o: u32| truth.objects.get(o as usize).is_some_and(|x| x.parts.iter().all(|p| p.material == material));
            Segment { material, mask: frame.object_id.iter().map(|&o| if shows(o) { 1.0 } else { 0.0 }).collect() }
        })
        .collect();
    for s in &segments {
        assert!(s.mask.iter().sum::<f32>() > 50.0, "{} must show", truth.materials[s.material].name);
    }
    (truth, frame.radiance, segments)
}

fn worst_error(scene: &Scene, truth: &Scene, segments: &[Segment]) -> f32 {
    let albedo = |s: &Scene, m: usize| match s.materials[m].albedo {
        Color::Constant(a) => a,
        _ => unreachable!("homogeneous materials"),
    };
    segments
        .iter()
        .map(|s| {
            ((albedo(scene, s.material) - albedo(truth, s.material)) / albedo(truth, s.material)).abs().max_element()
        })
        .fold(0.0, f32::max)
}

#[test]
fn the_division_converges_where_light_bounces_many_times() {
    let (truth, photo, segments) = light_room();
    let mut start = truth.clone();
    for s in &segments {
        start.materials[s.material].albedo = Color::Constant(Vec3::splat(0.5));
    }
    start.settings = RenderSettings { spp: 16, max_depth: 16, rr_depth: 3, seed: 1 };
    let mut errors = vec![worst_error(&start, &truth, &segments)];
    let divided = |rounds: usize| {
        let mut scene = start.clone();
        divide_albedos(
            &mut CpuBackend,
            &mut scene,
            &photo,
            &segments,
            &Division { rounds, spp: 64, ..Default::default() },
        )
        .unwrap();
        scene
    };
    errors.extend((1..5).map(|rounds| worst_error(&divided(rounds), &truth, &segments)));
    let scene = divided(5);
    errors.push(worst_error(&scene, &truth, &segments));
    println!("worst albedo error per round: {errors:?}");
    for s in &segments {
        let m = &scene.materials[s.material];
        let px = s.mask.iter().sum::<f32>();
        println!("{} ({px} px): {:?} (truth {:?})", m.name, m.albedo, truth.materials[s.material].albedo);
    }
    // Each number of rounds nearer (0.01: the renders' noise over a segment of a few hundred pixels at 64
    // spp), and five within 4 % of every albedo.
    for k in 1..errors.len() {
        assert!(errors[k] <= errors[k - 1] + 0.01, "{k} rounds ended farther from the truth: {errors:?}");
    }
    assert!(*errors.last().unwrap() < 0.04, "{errors:?}");
}

/// A division with a tolerance ends after the round whose ratios are within it: started at the truth's albedos
/// the first round's ratios are the renders' noise (a pixel-weighted mean |ln| of 0.003-0.008 at 32 spp on
/// were; started at grey 0.5 (ratios of 0.3-0.5 in log) it goes on until its ratios are that small, more
/// rounds than the five above in this light room (a render here grows 3-5 times as fast as its albedos, so a
/// ratio of 0.02 is an albedo a fraction of a percent off), and ends nearer the truth than those five (4 %).
#[test]
fn a_division_ends_once_its_ratios_are_within_the_tolerance() {
    let (truth, photo, segments) = light_room();
    let division = Division { rounds: 12, spp: 64, tolerance: 0.02, ..Default::default() };
    let mut at_truth = truth.clone();
    at_truth.settings = RenderSettings { spp: 16, max_depth: 16, rr_depth: 3, seed: 1 };
    let rounds = divide_albedos(&mut CpuBackend, &mut at_truth, &photo, &segments, &division).unwrap();
    let error = worst_error(&at_truth, &truth, &segments);
    println!("from the truth: {rounds} round(s), worst albedo {error}");
    assert_eq!(rounds, 1, "a division started at its answer rendered {rounds} rounds");
    assert!(error < 0.04, "{error}");

    let mut grey = at_truth.clone();
    for s in &segments {
        grey.materials[s.material].albedo = Color::Constant(Vec3::splat(0.5));
    }
    let rounds = divide_albedos(&mut CpuBackend, &mut grey, &photo, &segments, &division).unwrap();
    let error = worst_error(&grey, &truth, &segments);
    println!("from grey: {rounds} rounds, worst albedo {error}");
    assert!((2..12).contains(&rounds), "{rounds} rounds from grey");
    assert!(error < 0.04, "{error}");
}

/// The light scale scored from renders kept by bounce count (`bounce_spp`): the light room's lamps dimmed to
/// 0.7 and its albedos divided under them (so they come out too bright and reproduce each segment's mean
/// colour), the search must find the factor 1 / 0.7 that puts both back, from one set of bounce renders, and
/// leave the albedos near the truth's. Interreflections are what tell the factor apart (the walls at 0.8 and
/// the ceiling at 0.85 bounce most of this room's light), so this is the search's own signal, not a check
/// on a direct-light scene where every factor fits. Measured: 1.43 and the albedos within 1.1 % in three
/// passes (one pass 1.38 and 2.4 %: the model is exact only where it was rendered); the render-per-factor
/// search (`bounce_spp: 0`) 1.44 and 1.1 %, three times as long.
#[test]
fn the_light_scale_from_renders_kept_by_bounce() {
    use psdr::stages::{search_light_scale, LightScaleOptions};
    let (truth, photo, segments) = light_room();
    let mut dimmed = truth.clone();
    for o in &mut dimmed.objects {
        if let Some(e) = &mut o.emitter {
            e.radiance *= 0.7;
        }
    }
    dimmed.settings = RenderSettings { spp: 16, max_depth: 16, rr_depth: 3, seed: 1 };
    let division = Division { rounds: 6, spp: 64, tolerance: 0.01, ..Default::default() };
    divide_albedos(&mut CpuBackend, &mut dimmed, &photo, &segments, &division).unwrap();
    let before = worst_error(&dimmed, &truth, &segments);
    let opts = LightScaleOptions {
        range: (0.707, 1.414),
        steps: 3,
        extend: 4,
        spp: 64,
        rounds: 3,
        tolerance: 0.01,
        downsample: 2,
        bounce_spp: 64,
        ..Default::default()
    };
    let mut scene = dimmed.clone();
    let found = search_light_scale(&mut CpuBackend, &mut scene, &photo, &segments, &opts).unwrap();
    let after = worst_error(&scene, &truth, &segments);
    println!("chosen {:?} (common {}), worst albedo {before} -> {after}", found.chosen, found.common);
    for s in &segments {
        println!(
            "{}: {:?} (truth {:?})",
            scene.materials[s.material].name, scene.materials[s.material].albedo, truth.materials[s.material].albedo
        );
    }
    for c in 0..3 {
        assert!((found.chosen[c] * 0.7 - 1.0).abs() < 0.08, "channel {c}: {:?} for {}", found.chosen, 1.0 / 0.7);
    }
    assert!(after < 0.06 && after < before, "worst albedo {before} -> {after}");
}
