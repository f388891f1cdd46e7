//! Optimisation sanity for the material library: psdr's Adam (the project's one optimiser, `psdr::optim`),
//! started from random parameters, recovers a library material's own output at its default parameters.
//! (Lives in the tests crate because psdr depends on psdr-materials, not the other way round.)
//! Stated accuracy: mean absolute texel error below 0.01 for linear albedo and
//! roughness and below 0.02 for normal components.

use psdr::optim::{AdamConfig, AdamState};
use psdr_materials::{library, Evaluator, Params, RenderGrads, RenderMaps};

/// xorshift64* (reproducible starting points, not quality).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
}

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
    // Adam in range-normalised units u = p / (hi - lo).
    let mut adam = AdamState::new(p.floats.len());
    let cfg = AdamConfig { eps: 1e-12, ..AdamConfig::default() };
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
        let g: Vec<f64> = grad.iter().zip(&ranges).map(|(g, (lo, hi))| g * (hi - lo)).collect();
        let mut u: Vec<f64> = p.floats.iter().zip(&ranges).map(|(v, (lo, hi))| v / (hi - lo)).collect();
        adam.step(&cfg, lr, &mut u, &g);
        for (k, (lo, hi)) in ranges.iter().enumerate() {
            p.floats[k] = (u[k] * (hi - lo)).clamp(*lo, *hi);
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
