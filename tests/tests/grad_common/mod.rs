//! Shared by the gradient tests: scene files in temp dirs, and AD-against-FD checks with a stated bound.
//!
//! Statistical bound: AD and FD each average R independent seeds; their difference must stay within
//! 4·sqrt(s_a² + s_f²) of their standard errors (for a t distribution with R−1 ≥ 9 degrees of freedom a correct
//! implementation fails one comparison with probability < 0.3 %; the seeds are fixed, so runs reproduce).
#![allow(dead_code)]

pub mod scenes;

use psdr::grad::ParamPath;
use psdr::grad::{analytic_gradient, central_difference, AdEstimate, AdOptions, FdEstimate, FdOptions, ImageLoss};
use psdr::scene::{load_scene, Scene};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU32, Ordering};

/// Writes `json` to a fresh temp dir and loads it.
pub fn scene_from_json(name: &str, json: &str) -> Scene {
    static NEXT: AtomicU32 = AtomicU32::new(0);
    let k = NEXT.fetch_add(1, Ordering::Relaxed);
    let dir: PathBuf = std::env::temp_dir().join(format!("psdr_grad_{}_{k}_{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("scene.json");
    std::fs::write(&p, json).unwrap();
    let s = load_scene(&p).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    s
}

pub fn ad(scene: &Scene, path: &str, loss: &ImageLoss, opts: AdOptions) -> AdEstimate {
    let p: ParamPath = path.parse().unwrap();
    analytic_gradient(scene, &[p], loss, &opts, psdr_tests::fd_backend().as_mut()).unwrap()
}

pub fn fd(scene: &Scene, path: &str, loss: &ImageLoss, step: f32, replicas: u32) -> FdEstimate {
    let p: ParamPath = path.parse().unwrap();
    let opts = FdOptions { step, replicas, components: vec![] };
    central_difference(scene, &p, loss, &opts, psdr_tests::fd_backend().as_mut()).unwrap()
}

/// Asserts AD within 4 combined standard errors of FD for every component; returns both.
pub fn check(scene: &Scene, path: &str, loss: &ImageLoss, step: f32, opts: AdOptions) -> (AdEstimate, FdEstimate) {
    check_components(scene, path, loss, step, opts, &[])
}

/// `check` for the listed components only (all when empty); the FD estimate holds just those, in that order.
pub fn check_components(
    scene: &Scene,
    path: &str,
    loss: &ImageLoss,
    step: f32,
    opts: AdOptions,
    components: &[usize],
) -> (AdEstimate, FdEstimate) {
    let a = ad(scene, path, loss, opts);
    let p: ParamPath = path.parse().unwrap();
    let fd_opts = FdOptions { step, replicas: opts.replicas, components: components.to_vec() };
    let f = central_difference(scene, &p, loss, &fd_opts, psdr_tests::fd_backend().as_mut()).unwrap();
    for (k, &c) in f.components.iter().enumerate() {
        let bound = 4.0 * (a.std_err[c].powi(2) + f.std_err[k].powi(2)).sqrt();
        let diff = (a.mean[c] - f.mean[k]).abs();
        eprintln!(
            "{path}[{c}] {:?}: AD {:+.4e} ± {:.1e}, FD {:+.4e} ± {:.1e} (|diff| {diff:.1e}, bound {bound:.1e})",
            loss.output(),
            a.mean[c],
            a.std_err[c],
            f.mean[k],
            f.std_err[k]
        );
        assert!(a.mean[c].is_finite(), "{path}[{c}]: AD is not finite");
        assert!(diff <= bound, "{path}[{c}]: AD {} vs FD {} (bound {bound})", a.mean[c], f.mean[k]);
    }
    (a, f)
}
