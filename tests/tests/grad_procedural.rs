//! Procedural materials in the scene: a floor whose albedo is the library's `oak_planks` graph, tinted. Its
//! graph parameters and tint are scene parameters (`material/floor/graph.gap`, `material/floor/tint`), their
//! analytic gradients (the whole albedo texture's gradient chained through the graph's backward) agree with
//! central finite differences, and the material survives a scene file's round trip.
//!
//! The loss is a fixed random weighting of the radiance image (a linear functional: it sees where in the
//! image the texture changes, which the image mean would not, and is unbiased at the primal's seed).
//! Statistical bound: AD and FD each average R = 12 seeds; their difference must stay within 4·sqrt(s_a² + s_f²)
//! (a t distribution with 11 degrees of freedom fails a correct implementation with probability < 0.3 % per
//! comparison; the seeds are fixed, so runs reproduce). Each FD must also be 4 standard errors from zero.

mod grad_common;

use grad_common::check_components;
use grad_common::scenes::planks;
use psdr::grad::{AdOptions, ImageLoss, Output, ParamPath};
use psdr::scene::{load_scene, save_scene, Color, Scene};
use psdr_tests::SplitMix64;

const REPLICAS: u32 = 12;

fn weights(s: &Scene) -> ImageLoss {
    let mut rng = SplitMix64(5);
    let n = (s.camera.width * s.camera.height * 3) as usize;
    ImageLoss::Weighted { output: Output::Radiance, weights: (0..n).map(|_| rng.next_f32() * 2.0 - 0.5).collect() }
}

fn check(s: &Scene, path: &str, step: f32, components: &[usize]) {
    let opts = AdOptions { replicas: REPLICAS, edge_samples: 0, secondary_edge_samples: 0 };
    let (_, fd) = check_components(s, path, &weights(s), step, opts, components);
    for (k, c) in components.iter().enumerate() {
        assert!(fd.mean[k].abs() > 4.0 * fd.std_err[k], "{path}[{c}]: FD is pure noise; the check proves nothing");
    }
}

#[test]
fn tint_matches_finite_differences() {
    check(&planks(), "material/floor/tint", 0.02, &[0, 1, 2]);
}

/// A colour of the graph (the light wood), the board gap and the per-board variation: parameters that move
/// different texels in different ways (the gap only the seams; its FD step is 0.001: at 0.004 the seams'
/// smooth steps curve enough that FD reads 3 % low, 5 sigma).
#[test]
fn graph_parameters_match_finite_differences() {
    let s = planks();
    check(&s, "material/floor/graph.light", 0.02, &[0, 2]);
    check(&s, "material/floor/graph.gap", 0.001, &[0]);
    check(&s, "material/floor/graph.variation", 0.05, &[0]);
}

/// Setting a graph parameter bakes the texture anew; the file keeps graph, parameters, size and tint, and
/// reading it back gives the same texels.
#[test]
fn procedural_materials_round_trip_through_scene_files() {
    let mut s = planks();
    let m = s.material_index("floor").unwrap();
    let Color::Texture(t) = s.materials[m].albedo else { panic!("a procedural albedo is a texture") };
    let before = s.textures[t].texels.clone();
    let gap: ParamPath = "material/floor/graph.gap".parse().unwrap();
    gap.set(&mut s, &[0.06]).unwrap();
    let after = s.textures[t].texels.clone();
    let changed = before.iter().zip(&after).filter(|(a, b)| a != b).count();
    assert!(changed > before.len() / 20, "a wider gap changes the seams' texels ({changed} changed)");
    assert_eq!(s.textures.len(), 1, "re-baking reuses the material's texture");

    let dir = psdr_tests::temp_dir("procedural-round-trip");
    save_scene(&s, &dir.join("scene.json")).unwrap();
    let back = load_scene(&dir.join("scene.json")).unwrap();
    let bm = &back.materials[back.material_index("floor").unwrap()];
    assert_eq!(bm.procedural, s.materials[m].procedural);
    let Color::Texture(bt) = bm.albedo else { panic!("still a texture") };
    assert_eq!(back.textures[bt].texels, after);
    assert_eq!(gap.get(&back).unwrap(), vec![0.06]);

    // Integer parameters are not differentiable, unknown ones are named, plain materials have no graph.
    let err = |p: &str| p.parse::<ParamPath>().unwrap().get(&s).unwrap_err().to_string();
    assert!(err("material/floor/graph.seed").contains("integer"));
    assert!(err("material/floor/graph.nope").contains("no parameter 'nope'"));
    assert!(err("material/white/tint").contains("not procedural"));
}
