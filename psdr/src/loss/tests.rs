//! Every op's backward pass against central finite differences of its forward pass, plus invariants.
//!
//! Method: for an op y = f(x₁, x₂, ...) the checked quantity is the linear functional L = Σ y·R for a fixed
//! random R (so every output element is checked); for each input, along a random direction v,
//! (L(x + h v) − L(x − h v)) / 2h must match ⟨∇ₓL, v⟩. Forward passes run in f32 with f64 sums; with h = 1e-2
//! the FD truncation error is O(h²)·|f'''| ≈ 1e-4 relative and f32 rounding of L (≈ 1e-7·|L| / h) stays below
//! 1e-4 for |L| ~ 10, so the tolerance is 2e-3 relative to max(|FD|, |AD|, 1e-3). Inputs are kept away from
//! kinks (|a − b| > 0.05 for L1-type ops, positive values for sqrt, distinct values for min/max).

#![allow(clippy::cloned_ref_to_slice_refs)] // inputs are listed as slices of images, one clone each

use super::*;
use crate::error::Result;

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 40) as f32) / (1u64 << 24) as f32
    }
    fn image(&mut self, w: usize, h: usize, c: usize, lo: f32, hi: f32) -> Image {
        Image::new(w, h, c, (0..w * h * c).map(|_| lo + (hi - lo) * self.next()).collect()).unwrap()
    }
}

/// Checks `op` over the given inputs (all differentiated). Returns the number of checks.
fn check(name: &str, inputs: &[Image], op: impl Fn(&[Tensor]) -> Result<Tensor>) {
    check_with(name, inputs, 1e-2, 2e-3, op)
}

/// `check` along a direction with `nonzero` non-zero entries (0: all), step h, relative tolerance `tol`.
fn check_with(name: &str, inputs: &[Image], h: f32, tol: f64, op: impl Fn(&[Tensor]) -> Result<Tensor>) {
    check_dir(name, inputs, h, tol, 0, op)
}

fn check_dir(name: &str, inputs: &[Image], h: f32, tol: f64, nonzero: usize, op: impl Fn(&[Tensor]) -> Result<Tensor>) {
    let mut rng = Rng(name.len() as u64 * 7919 + 13);
    let tape = Tape::new();
    let xs: Vec<Tensor> = inputs.iter().map(|i| tape.input(i.clone())).collect();
    let y = op(&xs).unwrap();
    let r = rng.image(y.value().width, y.value().height, y.value().channels, -1.0, 1.0);
    let functional =
        |y: &Tensor| -> f64 { y.value().data.iter().zip(&r.data).map(|(a, b)| *a as f64 * *b as f64).sum() };
    let loss = sum(&mul(&y, &Tensor::constant(r.clone())).unwrap()).unwrap();
    let grads = tape.backward(&loss).unwrap();
    for (k, x) in inputs.iter().enumerate() {
        let g = grads.of(&xs[k]).unwrap_or_else(|| panic!("{name}: no gradient for input {k}"));
        assert_eq!(g.data.len(), x.data.len(), "{name}: gradient {k} has the wrong size");
        let mut v: Vec<f32> = (0..x.data.len()).map(|_| rng.next() * 2.0 - 1.0).collect();
        if nonzero > 0 {
            let keep: Vec<usize> = (0..nonzero).map(|_| (rng.next() * x.data.len() as f32) as usize).collect();
            v.iter_mut().enumerate().filter(|(i, _)| !keep.contains(i)).for_each(|(_, e)| *e = 0.0);
        }
        let ad: f64 = g.data.iter().zip(&v).map(|(a, b)| *a as f64 * *b as f64).sum();
        let shifted = |s: f32| -> f64 {
            let consts: Vec<Tensor> = inputs
                .iter()
                .enumerate()
                .map(|(j, im)| {
                    let mut im = im.clone();
                    if j == k {
                        im.data.iter_mut().zip(&v).for_each(|(a, b)| *a += s * h * b);
                    }
                    Tensor::constant(im)
                })
                .collect();
            functional(&op(&consts).unwrap())
        };
        let fd = (shifted(1.0) - shifted(-1.0)) / (2.0 * h as f64);
        let scale = fd.abs().max(ad.abs()).max(1e-3);
        assert!((fd - ad).abs() <= tol * scale, "{name} input {k}: FD {fd:.6e} vs AD {ad:.6e}");
    }
}

#[test]
fn pointwise_ops_and_broadcasting_match_finite_differences() {
    let mut g = Rng(1);
    let (a, b) = (g.image(5, 4, 3, 0.5, 2.0), g.image(5, 4, 3, 0.5, 2.0));
    let (m, s) = (g.image(5, 4, 1, 0.5, 2.0), Image::scalar(1.7));
    check("add", &[a.clone(), b.clone()], |x| add(&x[0], &x[1]));
    check("sub", &[a.clone(), m.clone()], |x| sub(&x[0], &x[1]));
    check("mul", &[m.clone(), b.clone()], |x| mul(&x[0], &x[1]));
    check("mul scalar", &[a.clone(), s.clone()], |x| mul(&x[0], &x[1]));
    check("div", &[a.clone(), b.clone()], |x| div(&x[0], &x[1]));
    check("div scalar num", &[s.clone(), m.clone()], |x| div(&x[0], &x[1]));
    check("neg", &[a.clone()], |x| neg(&x[0]));
    check("scale", &[a.clone()], |x| scale(&x[0], -2.5));
    check("sqr", &[a.clone()], |x| sqr(&x[0]));
    check("sqrt", &[a.clone()], |x| sqrt(&x[0]));
    let signed = g.image(5, 4, 3, 0.1, 1.0);
    let signed = signed.like(signed.data.iter().enumerate().map(|(i, v)| if i % 2 == 0 { *v } else { -*v }).collect());
    check("abs", &[signed], |x| abs(&x[0]));
}

#[test]
fn reductions_and_distances_match_finite_differences() {
    let mut g = Rng(2);
    let a = g.image(6, 5, 3, 0.0, 1.0);
    let b = a.like(a.data.iter().enumerate().map(|(i, v)| v + if i % 3 == 0 { 0.3 } else { -0.2 }).collect());
    let w = g.image(6, 5, 1, 0.1, 1.0);
    check("sum", &[a.clone()], |x| sum(&x[0]));
    check("mean", &[a.clone()], |x| mean(&x[0]));
    check("l1", &[a.clone(), b.clone()], |x| l1(&x[0], &x[1]));
    check("l2", &[a.clone(), b.clone()], |x| l2(&x[0], &x[1]));
    check("l2 broadcast", &[a.clone(), Image::scalar(0.4)], |x| l2(&x[0], &x[1]));
    check("charbonnier", &[a.clone(), b.clone()], |x| charbonnier(&x[0], &x[1], 0.1));
    check("weighted_mean", &[a.clone(), w.clone()], |x| weighted_mean(&x[0], &x[1]));
    check("masked_mean", &[a.clone(), w.clone()], |x| masked_mean(&x[0], &x[1]));
    check("mean_color", &[a.clone(), w.clone()], |x| mean_color(&x[0], &x[1]));
    check("soft_iou", &[w.clone(), g.image(6, 5, 1, 0.0, 1.0)], |x| soft_iou(&x[0], &x[1]));
}

#[test]
fn resampling_matches_finite_differences() {
    let mut g = Rng(3);
    let a = g.image(7, 5, 3, 0.0, 1.0);
    check("downsample 2", &[a.clone()], |x| downsample(&x[0], 2));
    check("downsample 3", &[a.clone()], |x| downsample(&x[0], 3));
    check("blur", &[a.clone()], |x| blur(&x[0], 1.3));
    check("blur wide", &[g.image(9, 6, 1, 0.0, 1.0)], |x| blur(&x[0], 4.0));
    check("crop border", &[a.clone()], |x| crop(&x[0], 3, 2, 4, 3));
    check("pyramid", &[g.image(12, 10, 1, 0.0, 1.0)], |x| {
        let p = gaussian_pyramid(&x[0], 3)?;
        add(&sum(&p[1])?, &scale(&sum(&p[2])?, 3.0)?)
    });
}

#[test]
fn normalization_matches_finite_differences() {
    let mut g = Rng(4);
    // Distinct values: min and max are unique.
    let a = g.image(6, 4, 2, 0.0, 5.0);
    check("normalize", &[a.clone()], |x| normalize(&x[0]));
    let mask = Tensor::constant(g.image(6, 4, 1, 0.0, 1.0));
    check("normalize_in", &[a], |x| normalize_in(&x[0], &mask));
}

/// The descriptor is piecewise smooth (ReLU) and its entries are f32: a dense perturbation crosses the kinks of
/// many features (10 % off at h = 1e-2), and a random functional over its 408 entries is dominated by their
/// rounding (~1e-6 absolute per entry at h = 1e-3). So it is checked entry by entry and texel by texel at
/// h = 1e-3: |FD − AD| ≤ 1 % of the larger plus 2e-6 (the rounding floor).
#[test]
fn texture_descriptor_matches_finite_differences() {
    for (seed, channels) in [(5u64, 1usize), (6, 3)] {
        let img = Rng(seed).image(26, 24, channels, 0.0, 1.0);
        let tape = Tape::new();
        let x = tape.input(img.clone());
        let d = texture_descriptor(&x).unwrap();
        let n = d.value().channels;
        let mut checked = 0;
        for entry in [0usize, 7, 136, 200, 300, 407] {
            let mut r = vec![0.0f32; n];
            r[entry] = 1.0;
            let l = sum(&mul(&d, &Tensor::constant(Image::new(1, 1, n, r).unwrap())).unwrap()).unwrap();
            let gx = tape.backward(&l).unwrap();
            let gx = gx.of(&x).unwrap();
            for texel in [37usize, 100, 301, 555 % img.data.len()] {
                let f = |s: f32| {
                    let mut im = img.clone();
                    im.data[texel] += s;
                    texture_descriptor(&Tensor::constant(im)).unwrap().value().data[entry] as f64
                };
                let h = 1e-3;
                let fd = (f(h) - f(-h)) / (2.0 * h as f64);
                let ad = gx.data[texel] as f64;
                assert!(
                    (fd - ad).abs() <= 1e-2 * fd.abs().max(ad.abs()) + 2e-6,
                    "entry {entry} texel {texel}: FD {fd:.5e} AD {ad:.5e}"
                );
                checked += (ad != 0.0) as usize;
            }
        }
        assert!(checked >= 12, "most pairs must have a non-zero gradient to mean anything ({checked})");
    }
    // texture_loss is built from checked ops; its chain through two descriptors, on one texel:
    let b = Tensor::constant(Rng(9).image(30, 28, 3, 0.0, 1.0));
    check_dir("texture_loss", &[Rng(8).image(25, 24, 3, 0.0, 1.0)], 1e-3, 2e-2, 1, |x| texture_loss(&x[0], &b));
}

#[test]
fn invariants_hold() {
    let mut g = Rng(6);
    let c = Tensor::constant(Image::new(9, 7, 2, vec![0.37; 126]).unwrap());
    for v in &blur(&c, 2.5).unwrap().value().data {
        assert!((v - 0.37).abs() < 1e-6, "blur of a constant is constant: {v}");
    }
    let img = Tensor::constant(g.image(40, 30, 1, 0.0, 1.0));
    let (m0, m1) = (mean(&img).unwrap().item().unwrap(), mean(&blur(&img, 1.0).unwrap()).unwrap().item().unwrap());
    assert!((m0 - m1).abs() < 0.01, "blur keeps the mean (up to border renormalisation): {m0} vs {m1}");
    for v in &downsample(&c, 3).unwrap().value().data {
        assert!((v - 0.37).abs() < 1e-6);
    }
    // Fractional masks: IoU(m, m) = Σm² / Σ(2m − m²) < 1 unless m is binary.
    let m = Tensor::constant(g.image(8, 8, 1, 0.1, 0.9));
    let d = m.value().data.iter().map(|&v| v as f64);
    let want = d.clone().map(|v| v * v).sum::<f64>() / d.map(|v| 2.0 * v - v * v).sum::<f64>();
    assert!((soft_iou(&m, &m).unwrap().item().unwrap() as f64 - want).abs() < 1e-6);
    let ones = Tensor::constant(Image::new(8, 8, 1, vec![1.0; 64]).unwrap());
    assert_eq!(soft_iou(&ones, &ones).unwrap().item().unwrap(), 1.0);
    let zeros = Tensor::constant(Image::zeros(8, 8, 1));
    assert_eq!(soft_iou(&zeros, &zeros).unwrap().item().unwrap(), 1.0, "two empty masks agree");
}

/// A periodic texture gives nearly the same descriptor at two crop sizes, a different texture a clearly
/// different one: measured relative distances ~1e-3 vs > 0.05 (margins stated in the asserts).
#[test]
fn texture_descriptor_compares_crops_of_different_sizes() {
    let mut g = Rng(7);
    let tile = g.image(16, 16, 3, 0.0, 1.0);
    let tiled = |w: usize, h: usize, t: &Image| {
        let mut d = Vec::with_capacity(w * h * 3);
        for y in 0..h {
            for x in 0..w {
                for c in 0..3 {
                    d.push(t.get(x % 16, y % 16, c));
                }
            }
        }
        Tensor::constant(Image::new(w, h, 3, d).unwrap())
    };
    let other = g.image(16, 16, 3, 0.0, 1.0);
    let (a, b, o) = (tiled(64, 64, &tile), tiled(96, 96, &tile), tiled(64, 64, &other));
    let same = texture_loss(&a, &b).unwrap().item().unwrap();
    let diff = texture_loss(&o, &b).unwrap().item().unwrap();
    assert_eq!(texture_descriptor(&a).unwrap().value().channels, texture_descriptor(&b).unwrap().value().channels);
    assert!(same < 0.01, "same texture, two sizes: {same}");
    assert!(diff > 5.0 * same && diff > 0.01, "different textures: {diff} vs same {same}");
}

#[test]
fn pixelwise_l2_recognises_affine_l2_losses_only() {
    let tape = Tape::new();
    let r = tape.input(Image::new(2, 2, 3, vec![0.5; 12]).unwrap());
    let m = tape.input(Image::new(2, 2, 1, vec![0.5; 4]).unwrap());
    let t = Tensor::constant(Image::new(2, 2, 3, (0..12).map(|i| i as f32 / 12.0).collect()).unwrap());
    let mt = Tensor::constant(Image::zeros(2, 2, 1));
    let l = l2(&r, &t).unwrap();
    let (tt, s) = tape.pixelwise_l2(&l, &r).unwrap();
    assert_eq!(tt, t.value().data);
    assert!((s - 2.0 / 12.0).abs() < 1e-7);
    let l = add(&scale(&l2(&r, &t).unwrap(), 0.5).unwrap(), &l1(&m, &mt).unwrap()).unwrap();
    let (_, s) = tape.pixelwise_l2(&l, &r).unwrap();
    assert!((s - 1.0 / 12.0).abs() < 1e-7, "{s}");
    let l = add(&l2(&r, &t).unwrap(), &l2(&t, &r).unwrap()).unwrap();
    let (_, s) = tape.pixelwise_l2(&l, &r).unwrap();
    assert!((s - 4.0 / 12.0).abs() < 1e-7, "two L2 terms against one target add: {s}");
    // Its claim checked against the tape's own backward pass.
    let g = tape.backward(&l).unwrap();
    let want: Vec<f32> = r.value().data.iter().zip(&t.value().data).map(|(a, b)| s * (a - b)).collect();
    for (a, b) in g.of(&r).unwrap().data.iter().zip(&want) {
        assert!((a - b).abs() < 1e-6);
    }
    assert!(tape.pixelwise_l2(&l2(&downsample(&r, 2).unwrap(), &Tensor::scalar(0.0)).unwrap(), &r).is_none());
    assert!(tape.pixelwise_l2(&l1(&r, &t).unwrap(), &r).is_none());
    let sq = mul(&l2(&r, &t).unwrap(), &l2(&r, &t).unwrap()).unwrap();
    assert!(tape.pixelwise_l2(&sq, &r).is_none());
    let other_t = Tensor::constant(Image::zeros(2, 2, 3));
    assert!(tape.pixelwise_l2(&add(&l2(&r, &t).unwrap(), &l2(&r, &other_t).unwrap()).unwrap(), &r).is_none());
}

#[test]
fn gradients_errors_and_constants() {
    let tape = Tape::new();
    let a = tape.input(Image::new(2, 2, 1, vec![1.0, 2.0, 3.0, 4.0]).unwrap());
    let unused = tape.input(Image::zeros(2, 2, 1));
    let g = tape.backward(&mean(&a).unwrap()).unwrap();
    assert!(g.of(&unused).is_none(), "an input the loss never read has no gradient");
    assert!(tape.backward(&a).is_err(), "backward of a non-scalar");
    let c = Tensor::constant(Image::zeros(3, 3, 3));
    assert!(!add(&c, &c).unwrap().requires_grad(), "constants stay constants");
    let other = Tape::new().input(Image::zeros(2, 2, 1));
    assert!(add(&a, &other).is_err(), "two tapes");
    let m = |e: Result<Tensor>| e.unwrap_err().to_string();
    assert!(m(l1(&a, &c)).contains("l1"));
    assert!(m(downsample(&a, 0)).contains("factor 0"));
    assert!(m(masked_mean(&a, &Tensor::constant(Image::zeros(2, 2, 1)))).contains("masked_mean"));
    assert!(m(mean_color(&a, &Tensor::constant(Image::zeros(2, 2, 1)))).contains("empty"));
    assert!(m(crop(&a, 1, 1, 2, 2)).contains("crop"));
    assert!(m(blur(&a, 0.0)).contains("sigma"));
    assert!(m(normalize(&Tensor::constant(Image::zeros(2, 2, 1)))).contains("constant"));
    assert!(m(texture_descriptor(&a)).contains("too small"));
    assert!(m(div(&a, &Tensor::scalar(0.0))).contains("zero"));
    assert!(m(sqrt(&Tensor::scalar(-1.0))).contains("negative"));
}
