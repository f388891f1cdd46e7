//! One backward pass for a whole loss: the adjoints of radiance, depth and several masks given together give
//! the sum of the gradients each gives alone (same seeds: the same edge samples and paths), to float
//! rounding, and a loss that reads nothing gives zero.

use psdr::backend::CpuBackend;
use psdr::grad::{outputs_vjp, BoundarySamples, OutputAdjoints, ParamPath};
use psdr::render::SceneData;
use psdr::scene::load_scene;
use std::path::Path;

#[test]
fn adjoints_of_several_outputs_sum_like_separate_passes() {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/fit/truth.json"));
    let mut scene = load_scene(path).unwrap();
    scene.camera.width = 48;
    scene.camera.height = 36;
    scene.settings.spp = 2;
    let data = SceneData::build(&scene).unwrap();
    let n = 48 * 36;
    let mut state = 7u64;
    let mut rand = |k: usize| -> Vec<f32> {
        (0..k)
            .map(|_| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((state >> 40) as f32 / (1u64 << 24) as f32) - 0.5
            })
            .collect()
    };
    let (cabinet, floor) = (scene.object_index("cabinet").unwrap(), scene.object_index("floor").unwrap());
    let all = OutputAdjoints {
        radiance: Some(rand(n * 3)),
        depth: Some(rand(n)),
        masks: vec![(cabinet, rand(n)), (floor, rand(n))],
    };
    let params: Vec<ParamPath> = ["material/walls/albedo", "object/cabinet/translation", "object/cabinet/yaw"]
        .iter()
        .map(|p| p.parse().unwrap())
        .collect();
    let b = BoundarySamples { primary: 4096, secondary: 1 };
    let together = outputs_vjp(&scene, &data, &scene.settings, &params, &all, b, &mut CpuBackend).unwrap();
    let parts = [
        OutputAdjoints { radiance: all.radiance.clone(), ..Default::default() },
        OutputAdjoints { depth: all.depth.clone(), ..Default::default() },
        OutputAdjoints { masks: vec![all.masks[0].clone()], ..Default::default() },
        OutputAdjoints { masks: vec![all.masks[1].clone()], ..Default::default() },
    ];
    let mut sum = vec![0.0f64; together.len()];
    let mut nonzero = [false; 4];
    for (k, p) in parts.iter().enumerate() {
        let g = outputs_vjp(&scene, &data, &scene.settings, &params, p, b, &mut CpuBackend).unwrap();
        nonzero[k] = g.iter().any(|&v| v != 0.0);
        sum.iter_mut().zip(g).for_each(|(s, v)| *s += v);
    }
    assert!(nonzero.iter().all(|&z| z), "every output must contribute for the test to mean anything: {nonzero:?}");
    let scale = sum.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (i, (a, b)) in together.iter().zip(&sum).enumerate() {
        assert!((a - b).abs() <= 1e-5 * scale, "entry {i}: together {a} vs separately {b}");
    }
    let none =
        outputs_vjp(&scene, &data, &scene.settings, &params, &OutputAdjoints::default(), b, &mut CpuBackend).unwrap();
    assert!(none.iter().all(|&v| v == 0.0));
}
