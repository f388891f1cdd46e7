//! The BSDF (psdr::render::bsdf) against its own definition: the sampling density integrates to the probability
//! that sampling produces a direction, samples are distributed as that density (chi-square), the sampling
//! weights f cos / pdf average to the integral of f cos, that integral never exceeds 1 (energy), Lambert alone
//! integrates to its albedo exactly, and f is symmetric.
//!
//! Quadrature: the hemisphere is integrated in polar coordinates about the mirror direction of wi with the polar
//! angle theta = pi t^2 (t uniform, midpoint rule), which puts most nodes in the specular peak; 1000 x 1000 nodes.
//! Its error is dominated by the cells cut by the horizon, where the integrand jumps to zero: measured 1.4e-6 on
//! the exact Lambert case and below 5e-5 for GGX down to alpha = MIN_ALPHA (1e-3, whose peak still spans ~25 t
//! nodes); QUAD_TOL = 2e-4 is the tolerance of every quadrature comparison. (This test found the GGX D losing
//! its digits to f32 cancellation near the peak: ∫pdf was 1.0094 at alpha = 1e-3 before the render fix.)

use glam::Vec3;
use psdr::render::bsdf::{bsdf_eval, bsdf_pdf, bsdf_sample, BsdfParams};
use psdr_tests::{chi2_pooled, chi2_upper_quantile, SplitMix64};
use std::f64::consts::PI;

const NQ: usize = 1000;
/// Tolerance of every quadrature comparison (see the module comment).
const QUAD_TOL: f64 = 2e-4;

fn dir(theta_deg: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

/// Integral over the sphere of g(wo) (g is zero below the surface) about the mirror direction of wi.
fn quadrature(wi: Vec3, g: impl Fn(Vec3) -> f64) -> f64 {
    let r = Vec3::new(-wi.x, -wi.y, wi.z).normalize();
    let t1 = if r.z.abs() < 0.999 { r.cross(Vec3::Z).normalize() } else { Vec3::X };
    let t2 = r.cross(t1);
    let mut sum = 0.0f64;
    for i in 0..NQ {
        let t = (i as f64 + 0.5) / NQ as f64;
        let theta = PI * t * t;
        let w = theta.sin() * 2.0 * PI * t / NQ as f64 * (2.0 * PI / NQ as f64);
        let (st, ct) = (theta.sin() as f32, theta.cos() as f32);
        let mut ring = 0.0f64;
        for j in 0..NQ {
            let phi = 2.0 * PI * (j as f64 + 0.5) / NQ as f64;
            let wo = t1 * (st * phi.cos() as f32) + t2 * (st * phi.sin() as f32) + r * ct;
            ring += g(wo);
        }
        sum += ring * w;
    }
    sum
}

fn params(roughness: f32, specular: f32, albedo: f32) -> BsdfParams {
    BsdfParams { albedo: Vec3::splat(albedo), roughness, specular }
}

/// (fraction of samples that produce a direction, mean weight, standard error of the mean weight) over n draws.
fn sample_stats(p: &BsdfParams, wi: Vec3, n: usize, seed: u64) -> (f64, f64, f64) {
    let mut rng = SplitMix64(seed);
    let (mut ok, mut s, mut s2) = (0usize, 0.0f64, 0.0f64);
    for _ in 0..n {
        let (a, b, c) = (rng.next_f32(), rng.next_f32(), rng.next_f32());
        if let Some(bs) = bsdf_sample(p, wi, a, b, c) {
            ok += 1;
            let w = bs.weight.x as f64;
            s += w;
            s2 += w * w;
        }
    }
    let nf = n as f64;
    let mean = s / nf;
    (ok as f64 / nf, mean, ((s2 / nf - mean * mean).max(0.0) / nf).sqrt())
}

const ROUGHNESS: [f32; 4] = [0.0, 0.05, 0.3, 1.0];
const SPECULAR: [f32; 2] = [0.5, 1.0];
const ANGLES: [f32; 3] = [0.0, 60.0, 85.0];

/// ∫ pdf dω over the upper hemisphere equals the probability that bsdf_sample returns a direction (reflections
/// that the GGX lobe sends below the horizon are dropped, so this is 1 only where none are). The success
/// fraction is estimated from N = 100k draws: bound QUAD_TOL + 5 sqrt(P(1-P)/N), and the quadrature must not
/// exceed 1 + QUAD_TOL.
#[test]
fn pdf_integrates_to_the_probability_of_producing_a_direction() {
    let n = 100_000;
    let mut worst: f64 = 0.0;
    for &r in &ROUGHNESS {
        for &s in &SPECULAR {
            for &a in &ANGLES {
                let p = params(r, s, 0.6);
                let wi = dir(a);
                let integral = quadrature(wi, |wo| bsdf_pdf(&p, wi, wo) as f64);
                let (ok, _, _) = sample_stats(&p, wi, n, 7);
                let bound = QUAD_TOL + 5.0 * (ok * (1.0 - ok) / n as f64).sqrt();
                let err = (integral - ok).abs();
                worst = worst.max(err / bound);
                eprintln!(
                    "r {r} s {s} theta {a}: ∫pdf {integral:.5} P(sample) {ok:.5} |err| {err:.1e} bound {bound:.1e}"
                );
                assert!(integral <= 1.0 + QUAD_TOL, "r {r} s {s} theta {a}: ∫pdf = {integral} > 1");
                assert!(err <= bound, "r {r} s {s} theta {a}: ∫pdf = {integral} but P(sample) = {ok}");
            }
        }
    }
    eprintln!("worst |err| / bound = {worst:.3}");
}

/// Specular 0 is Lambert alone: ∫ pdf = 1 and ∫ f cos = albedo, exactly up to the quadrature.
#[test]
fn lambert_integrates_exactly() {
    for a in [0.0f32, 45.0, 89.0] {
        let p = params(1.0, 0.0, 0.7);
        let wi = dir(a);
        let ipdf = quadrature(wi, |wo| bsdf_pdf(&p, wi, wo) as f64);
        let ialb = quadrature(wi, |wo| bsdf_eval(&p, wi, wo).x as f64);
        eprintln!("theta {a}: ∫pdf - 1 = {:.1e}, ∫f cos - 0.7 = {:.1e}", ipdf - 1.0, ialb - 0.7);
        assert!((ipdf - 1.0).abs() < 1e-4, "∫pdf = {ipdf}");
        assert!((ialb - 0.7).abs() < 1e-4, "∫f cos = {ialb}");
    }
}

/// Chi-square test of bsdf_sample against bsdf_pdf: 24 x 48 bins in (theta, phi) of wo (the horizon is a bin
/// edge, so each bin's expected count, from a 10 x 10 midpoint rule of the pdf, is a smooth integral), plus one
/// bin for "no direction" whose expectation is N (1 - ∫pdf). Bins expecting fewer than 5 are pooled. N = 100k
/// per case; the statistic must stay below the chi-square quantile of p = 1e-5 (z = 4.265, Wilson-Hilferty) for
/// its degrees of freedom. Roughness >= 0.3: sharper lobes fall inside one bin and test nothing more.
#[test]
fn sampling_matches_the_pdf_chi_square() {
    const NT: usize = 24;
    const NP: usize = 48;
    const SUB: usize = 10;
    let n = 100_000usize;
    let dt = PI / 2.0 / NT as f64;
    let dp = 2.0 * PI / NP as f64;
    for &r in &[0.3f32, 0.6, 1.0] {
        for &s in &SPECULAR {
            for &a in &ANGLES {
                let p = params(r, s, 0.5);
                let wi = dir(a);
                let mut expected = vec![0.0f64; NT * NP + 1];
                for it in 0..NT {
                    for ip in 0..NP {
                        let mut acc = 0.0;
                        for st in 0..SUB {
                            let th = (it as f64 + (st as f64 + 0.5) / SUB as f64) * dt;
                            for sp in 0..SUB {
                                let ph = (ip as f64 + (sp as f64 + 0.5) / SUB as f64) * dp;
                                let wo = Vec3::new(
                                    (th.sin() * ph.cos()) as f32,
                                    (th.sin() * ph.sin()) as f32,
                                    th.cos() as f32,
                                );
                                acc += bsdf_pdf(&p, wi, wo) as f64 * th.sin();
                            }
                        }
                        expected[it * NP + ip] = acc * dt * dp / (SUB * SUB) as f64 * n as f64;
                    }
                }
                let total: f64 = expected.iter().sum();
                expected[NT * NP] = (n as f64 - total).max(0.0);
                let mut observed = vec![0.0f64; NT * NP + 1];
                let mut rng = SplitMix64(1234);
                for _ in 0..n {
                    let (u0, u1, u2) = (rng.next_f32(), rng.next_f32(), rng.next_f32());
                    match bsdf_sample(&p, wi, u0, u1, u2) {
                        None => observed[NT * NP] += 1.0,
                        Some(bs) => {
                            let th = (bs.wo.z as f64).clamp(-1.0, 1.0).acos();
                            let ph = (bs.wo.y as f64).atan2(bs.wo.x as f64).rem_euclid(2.0 * PI);
                            let it = ((th / dt) as usize).min(NT - 1);
                            let ip = ((ph / dp) as usize).min(NP - 1);
                            observed[it * NP + ip] += 1.0;
                        }
                    }
                }
                let (stat, dof) = chi2_pooled(&observed, &expected, 5.0);
                let limit = chi2_upper_quantile(dof as f64, 4.265);
                eprintln!("r {r} s {s} theta {a}: chi2 {stat:.1} dof {dof} limit {limit:.1}");
                assert!(stat < limit, "r {r} s {s} theta {a}: chi2 {stat} with {dof} dof exceeds {limit} (p < 1e-5)");
            }
        }
    }
}

/// Energy: with a white diffuse albedo, ∫ f cos dω <= 1 (quadrature, tolerance QUAD_TOL), and the sampling
/// weights f cos / pdf (N = 200k) average to that integral within 5 standard errors + QUAD_TOL (which also proves
/// the weights and the pdf belong together); the weight mean itself stays <= 1 + 5 standard errors.
#[test]
fn energy_is_conserved_and_weights_average_to_the_albedo_integral() {
    let n = 200_000;
    for &r in &ROUGHNESS {
        for &s in &SPECULAR {
            for &a in &ANGLES {
                let p = params(r, s, 1.0);
                let wi = dir(a);
                let integral = quadrature(wi, |wo| bsdf_eval(&p, wi, wo).x as f64);
                let (_, mean, se) = sample_stats(&p, wi, n, 99);
                eprintln!("r {r} s {s} theta {a}: ∫f cos {integral:.5}, weight mean {mean:.5} ± {se:.1e}");
                assert!(integral <= 1.0 + QUAD_TOL, "r {r} s {s} theta {a}: ∫f cos = {integral} > 1");
                assert!(mean <= 1.0 + 5.0 * se, "r {r} s {s} theta {a}: weight mean {mean} > 1 + 5 se");
                let bound = 5.0 * se + QUAD_TOL;
                assert!(
                    (mean - integral).abs() <= bound,
                    "r {r} s {s} theta {a}: weights average {mean} but ∫f cos = {integral} (bound {bound})"
                );
            }
        }
    }
}

/// Reciprocity: f(wi, wo) = f(wo, wi), where bsdf_eval returns f * cos(theta_o); relative 1e-4 (f32 rounding of
/// the two evaluation orders) over 20k random direction pairs and random parameters.
#[test]
fn bsdf_is_reciprocal() {
    let mut rng = SplitMix64(5);
    let hemi = |rng: &mut SplitMix64| {
        let z = rng.next_f32().max(1e-3);
        let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
        let s = (1.0 - z * z).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), z)
    };
    let mut worst = 0.0f32;
    for _ in 0..20_000 {
        let p = BsdfParams {
            albedo: Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
            roughness: rng.next_f32(),
            specular: rng.next_f32(),
        };
        let (wi, wo) = (hemi(&mut rng), hemi(&mut rng));
        let f1 = bsdf_eval(&p, wi, wo) / wo.z;
        let f2 = bsdf_eval(&p, wo, wi) / wi.z;
        let rel = (f1 - f2).abs().max_element() / f1.abs().max(f2.abs()).max_element().max(1e-6);
        worst = worst.max(rel);
        assert!(rel < 1e-4, "f(wi, wo) = {f1} but f(wo, wi) = {f2} for {p:?}, wi {wi}, wo {wo}");
    }
    eprintln!("worst relative asymmetry {worst:.1e}");
}
