//! Optimisation sanity: Adam, started from random parameters, recovers a library
//! material's own output at its default parameters.
//! Stated accuracy: mean absolute texel error below 0.01 for linear albedo and
//! roughness and below 0.02 for normal components.

mod common;
use common::Rng;
use psdr_materials::{library, Evaluator, Params, RenderGrads, RenderMaps};

fn mean_abs(a: &[f32], b: &[f32]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs() as f64).sum::<f64>() / a.len() as f64
}

/// Starts each parameter uniformly within `window` x its range around the truth
/// (clipped to the range; 1.0 = anywhere in range) and runs `iters` Adam steps at `n` x `n`.
fn recover(name: &str, seed: u64, iters: usize, n: usize, window: f64) -> (f64, f64, f64) {
    let g = library::load(name).unwrap().unwrap();
    let ranges = g.float_ranges();
    let mut ev = Evaluator::new(g.clone(), n);
    let target: RenderMaps = ev.forward(&g.default_params()).clone();
    let mut rng = Rng(seed);
    let mut p: Params = g.default_params();
    for (v, (lo, hi)) in p.floats.iter_mut().zip(&ranges) {
        let w = window * (hi - lo);
        let (a, b) = ((*v - w).max(*lo), (*v + w).min(*hi));
        *v = a + (b - a) * rng.next();
    }
    let (mut m, mut s) = (vec![0.0; p.floats.len()], vec![0.0; p.floats.len()]);
    let (b1, b2) = (0.9f64, 0.999f64);
    let mut ga = vec![0.0f32; n * n * 3];
    let mut gr = vec![0.0f32; n * n];
    let mut gn = vec![0.0f32; n * n * 3];
    for it in 1..=iters {
        // Step size decays from 0.05 to 0.0025 of each range (exponential schedule).
        let lr = 0.05 * 0.05f64.powf(it as f64 / iters as f64);
        let maps = ev.forward(&p);
        // L = mean squared error per map; dL/dx = 2 (x - x*) / len.
        for (d, (x, t)) in ga.iter_mut().zip(maps.albedo_linear.iter().zip(&target.albedo_linear)) {
            *d = 2.0 * (x - t) / (n * n) as f32;
        }
        for (d, (x, t)) in gr.iter_mut().zip(maps.roughness.iter().zip(&target.roughness)) {
            *d = 2.0 * (x - t) / (n * n) as f32;
        }
        for (d, (x, t)) in gn.iter_mut().zip(maps.normal.iter().zip(&target.normal)) {
            *d = 2.0 * (x - t) / (n * n) as f32;
        }
        let mut grad = vec![0.0; p.floats.len()];
        let grads = RenderGrads { albedo_linear: Some(&ga), roughness: Some(&gr), normal: Some(&gn), height: None };
        ev.backward(&grads, &mut grad);
        for k in 0..grad.len() {
            let (lo, hi) = ranges[k];
            let g = grad[k] * (hi - lo); // optimise in range-normalised units
            m[k] = b1 * m[k] + (1.0 - b1) * g;
            s[k] = b2 * s[k] + (1.0 - b2) * g * g;
            let mh = m[k] / (1.0 - b1.powi(it as i32));
            let sh = s[k] / (1.0 - b2.powi(it as i32));
            p.floats[k] = (p.floats[k] - lr * (hi - lo) * mh / (sh.sqrt() + 1e-12)).clamp(lo, hi);
        }
    }
    if std::env::var("RECOVERY_DEBUG").is_ok() {
        let d = g.default_params();
        for (k, name) in g.float_names().iter().enumerate() {
            eprintln!("{name}: got {:.4} want {:.4}", p.floats[k], d.floats[k]);
        }
    }
    let maps = ev.forward(&p);
    (
        mean_abs(&maps.albedo_linear, &target.albedo_linear),
        mean_abs(&maps.roughness, &target.roughness),
        mean_abs(&maps.normal, &target.normal),
    )
}

#[test]
fn adam_recovers_concrete_from_anywhere_in_range() {
    let (a, r, n) = recover("concrete", 3, 500, 32, 1.0);
    assert!(a < 0.01 && r < 0.01 && n < 0.02, "albedo {a:.4}, roughness {r:.4}, normal {n:.4}");
}

/// Ring phase makes wood non-convex in distortion far from the truth: start within +-20%.
#[test]
fn adam_recovers_wood_grain_from_a_20_percent_neighbourhood() {
    let (a, r, n) = recover("wood_grain", 3, 500, 32, 0.2);
    assert!(a < 0.01 && r < 0.01 && n < 0.02, "albedo {a:.4}, roughness {r:.4}, normal {n:.4}");
}

#[test]
fn adam_recovers_wallpaper_stripes_from_anywhere_in_range() {
    let (a, r, n) = recover("wallpaper_stripes", 4, 500, 32, 1.0);
    assert!(a < 0.01 && r < 0.01 && n < 0.02, "albedo {a:.4}, roughness {r:.4}, normal {n:.4}");
}

/// Tile geometry is not convex from anywhere (a very wide mortar is a local minimum
/// where grout and tile colours agree), so start within +-30% of each range.
#[test]
fn adam_recovers_square_tiles_from_a_30_percent_neighbourhood() {
    for seed in [1, 2, 3] {
        let (a, r, n) = recover("square_tiles", seed, 500, 64, 0.3);
        assert!(a < 0.01 && r < 0.01 && n < 0.02, "seed {seed}: albedo {a:.4}, roughness {r:.4}, normal {n:.4}");
    }
}
