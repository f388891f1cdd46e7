//! Every library material: finite over random parameters, end-to-end gradient
//! against finite differences, seamless tiling, thread-count determinism.

mod common;
use common::{check_fd, random_params, Rng};
use psdr_materials::{library, Evaluator, Graph, MapKind, ParamKind, Params, RenderGrads};

fn load(name: &str) -> Graph {
    library::load(name).unwrap().unwrap()
}

/// Any parameters in range, ints included.
fn any_params(g: &Graph, rng: &mut Rng) -> Params {
    let mut p = g.default_params();
    for info in &g.params {
        for k in 0..info.len {
            let v = rng.range(info.min[k], info.max[k]);
            match info.kind {
                ParamKind::Int => p.ints[info.offset] = v.round() as i64,
                _ => p.floats[info.offset + k] = v,
            }
        }
    }
    p
}

#[test]
fn library_has_at_least_40_materials_with_descriptions() {
    let names = library::names();
    assert!(names.len() >= 40, "only {} materials", names.len());
    for n in names {
        let g = load(n);
        assert_eq!(g.name, n, "graph name must match its file name");
        assert!(!g.description.is_empty(), "{n}: no description");
        assert!(g.num_floats() > 0, "{n}: nothing to optimise");
    }
}

#[test]
fn every_material_is_finite_over_random_parameters() {
    let mut rng = Rng(42);
    for name in library::names() {
        let g = load(name);
        let mut ev = Evaluator::new(g.clone(), 32);
        for draw in 0..3 {
            let p = any_params(&g, &mut rng);
            let m = ev.forward(&p);
            let all = m.albedo_linear.iter().chain(&m.roughness).chain(&m.normal).chain(m.height.iter().flatten());
            assert!(all.clone().all(|x| x.is_finite()), "{name} draw {draw}: non-finite texel with {p:?}");
            for t in m.normal.chunks(3) {
                let len = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
                assert!((len - 1.0).abs() < 1e-4 && t[2] > 0.0, "{name}: normal {t:?} not unit / outward");
            }
        }
    }
}

fn srgb_decode(c: f64) -> f64 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

struct Weights {
    albedo: Vec<f32>,
    rough: Vec<f32>,
    normal: Vec<f32>,
    height: Vec<f32>,
}

/// The loss the renderer would see, recomputed here from the graph's own f64 images
/// with an independent sRGB decode and clamp.
fn render_loss(ev: &mut Evaluator, p: &Params, w: &Weights) -> f64 {
    ev.evaluate(p);
    let base = ev.output_image(MapKind::BaseColor).unwrap();
    let n2 = base.size * base.size;
    let mut l = 0.0;
    for i in 0..n2 {
        for c in 0..3 {
            let s = base.data[i * base.channels + if base.channels == 1 { 0 } else { c }];
            l += w.albedo[i * 3 + c] as f64 * srgb_decode(s);
        }
    }
    let r = ev.output_image(MapKind::Roughness).unwrap();
    l += r.data.iter().zip(&w.rough).map(|(a, b)| a.clamp(0.0, 1.0) * *b as f64).sum::<f64>();
    if let Some(nm) = ev.output_image(MapKind::Normal) {
        l += nm.data.iter().zip(&w.normal).map(|(a, b)| a * *b as f64).sum::<f64>();
    }
    if let Some(h) = ev.output_image(MapKind::Height) {
        l += h.data.iter().zip(&w.height).map(|(a, b)| a * *b as f64).sum::<f64>();
    }
    l
}

#[test]
fn every_material_gradient_matches_finite_differences() {
    const N: usize = 24;
    let mut failures = vec![];
    for (t, name) in library::names().into_iter().enumerate() {
        let g = load(name);
        let mut ev = Evaluator::new(g.clone(), N);
        let mut rng = Rng(7 + t as u64);
        let p = random_params(&ev, &mut rng);
        let mut wv = |len: usize| (0..len).map(|_| rng.range(-1.0, 1.0) as f32).collect::<Vec<_>>();
        let w = Weights { albedo: wv(N * N * 3), rough: wv(N * N), normal: wv(N * N * 3), height: wv(N * N) };
        ev.forward(&p);
        let has_h = ev.maps().height.is_some();
        let grads = RenderGrads {
            albedo_linear: Some(&w.albedo),
            roughness: Some(&w.rough),
            normal: Some(&w.normal),
            height: has_h.then_some(&w.height[..]),
        };
        let mut grad = vec![0.0; g.num_floats()];
        ev.backward(&grads, &mut grad);
        assert!(grad.iter().any(|&x| x != 0.0), "{name}: all-zero gradient");
        if let Err(e) = check_fd(&mut ev, &p, &grad, 1e-4, 1e-5, |ev, p| render_loss(ev, p, &w)) {
            failures.push(format!("{name}: {e}"));
        }
    }
    assert!(failures.is_empty(), "FD mismatches:\n{}", failures.join("\n"));
}

/// Mean absolute difference between rows a and b (or columns when `cols`).
fn line_diff(d: &[f64], n: usize, ch: usize, a: usize, b: usize, cols: bool) -> f64 {
    let mut s = 0.0;
    for k in 0..n {
        for c in 0..ch {
            let (ia, ib) = if cols { (k * n + a, k * n + b) } else { (a * n + k, b * n + k) };
            s += (d[ia * ch + c] - d[ib * ch + c]).abs();
        }
    }
    s / (n * ch) as f64
}

/// Seam difference (last row/column against the first) and the largest interior
/// neighbour difference, over both axes.
fn seam_vs_interior(d: &[f64], n: usize, ch: usize) -> (f64, f64) {
    let mut seam: f64 = 0.0;
    let mut interior: f64 = 0.0;
    for cols in [false, true] {
        seam = seam.max(line_diff(d, n, ch, n - 1, 0, cols));
        for a in 0..n - 1 {
            interior = interior.max(line_diff(d, n, ch, a, a + 1, cols));
        }
    }
    (seam, interior)
}

fn check_tiles(ev: &mut Evaluator, p: &Params) -> Result<(), String> {
    ev.evaluate(p);
    for map in [MapKind::BaseColor, MapKind::Roughness, MapKind::Height, MapKind::Normal] {
        if let Some(img) = ev.output_image(map) {
            let (seam, interior) = seam_vs_interior(&img.data, img.size, img.channels);
            // For noise the seam is one more draw from the interior distribution,
            // so it may exceed the interior maximum slightly: allow 25%.
            if seam > 1.25 * interior + 1e-9 {
                return Err(format!(
                    "{map:?}: seam {seam:.4} > 1.25 x largest interior neighbour difference {interior:.4}"
                ));
            }
        }
    }
    Ok(())
}

#[test]
fn every_material_tiles_seamlessly() {
    let mut rng = Rng(5);
    for name in library::names() {
        let g = load(name);
        let mut ev = Evaluator::new(g.clone(), 64);
        check_tiles(&mut ev, &g.default_params()).unwrap_or_else(|e| panic!("{name} (defaults): {e}"));
        let p = random_params(&ev, &mut rng);
        check_tiles(&mut ev, &p).unwrap_or_else(|e| panic!("{name} (random): {e}"));
    }
}

/// The seam check must catch a pattern that does not tile (noise scaled by 1.37 and shifted).
#[test]
fn seam_check_detects_a_non_tiling_graph() {
    let json = r#"{"name": "bad", "nodes": [
        {"id": "s", "type": "fbm", "params": {"scale_x": 2, "scale_y": 2, "octaves": 3}},
        {"id": "t", "type": "transform", "inputs": {"input": "s"}, "params": {"scale": 1.37, "offset_x": 0.1}},
        {"id": "r", "type": "uniform"}],
        "outputs": {"base_color": "t", "roughness": "r"}}"#;
    let g = Graph::from_json(json, "bad.json").unwrap();
    let mut ev = Evaluator::new(g.clone(), 64);
    assert!(check_tiles(&mut ev, &g.default_params()).is_err());
}

#[test]
fn output_is_bit_identical_on_any_thread_count() {
    for name in ["oak_planks", "marble_white", "stone_wall", "patterned_rug"] {
        let g = load(name);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let mut ev = Evaluator::new(g.clone(), 48);
                let p = g.default_params();
                let m = ev.forward(&p).clone();
                let w: Vec<f32> = (0..48 * 48 * 3).map(|i| ((i * 7919) % 13) as f32 - 6.0).collect();
                let mut grad = vec![0.0; g.num_floats()];
                ev.backward(
                    &RenderGrads { albedo_linear: Some(&w), normal: Some(&w), ..Default::default() },
                    &mut grad,
                );
                (m.albedo_linear, m.normal, grad)
            })
        };
        let (a1, n1, g1) = run(1);
        for t in [2, 3] {
            let (a, n, g) = run(t);
            assert!(a1 == a && n1 == n, "{name}: maps differ between 1 and {t} threads");
            assert!(
                g1.iter().zip(&g).all(|(x, y)| x.to_bits() == y.to_bits()),
                "{name}: gradients differ between 1 and {t} threads"
            );
        }
    }
}
