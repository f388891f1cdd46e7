//! The interior term in reverse mode against independent truth: a closed form for a linear parameter, and
//! central finite differences for the others.
//!
//! Statistical bound: AD and FD each average R = 16 independent seeds; with their standard errors s_a, s_f the
//! difference is compared with 4·sqrt(s_a² + s_f²). For a t-distribution with 15 degrees of freedom that fails a
//! correct implementation with probability < 0.2 % per comparison; all seeds are fixed, so the test is
//! deterministic, and a gradient off by 10 % or more exceeds the bound in every case below.

use psdr::grad::{
    analytic_gradient, central_difference, radiance_vjp, AdOptions, FdOptions, GradLayout, ImageLoss, Output, ParamPath,
};
use psdr::render::{render_cpu, SceneData};
use psdr::scene::Scene;

mod grad_common;
use grad_common::scenes::textured_floor_with;

const REPLICAS: u32 = 16;

fn room(width: u32, height: u32, spp: u32) -> Scene {
    psdr_tests::example_room(width, height, spp)
}

fn check_against_fd(scene: &Scene, path: &str, step: f32, components: &[usize]) {
    let p: ParamPath = path.parse().unwrap();
    let loss = ImageLoss::Mean(Output::Radiance);
    let ad = analytic_gradient(
        scene,
        std::slice::from_ref(&p),
        &loss,
        &AdOptions { replicas: REPLICAS, edge_samples: 0, secondary_edge_samples: 0 },
        psdr_tests::fd_backend().as_mut(),
    )
    .unwrap();
    let opts = FdOptions { step, replicas: REPLICAS, components: components.to_vec() };
    let fd = central_difference(scene, &p, &loss, &opts, psdr_tests::fd_backend().as_mut()).unwrap();
    for (k, &c) in components.iter().enumerate() {
        let bound = 4.0 * (ad.std_err[c].powi(2) + fd.std_err[k].powi(2)).sqrt();
        let diff = (ad.mean[c] - fd.mean[k]).abs();
        eprintln!(
            "{path}[{c}]: AD {:.5e} ± {:.1e}, FD {:.5e} ± {:.1e}, |diff| {diff:.2e} (bound {bound:.2e})",
            ad.mean[c], ad.std_err[c], fd.mean[k], fd.std_err[k]
        );
        assert!(diff <= bound, "{path}[{c}]: AD {} vs FD {} exceeds 4 sigma ({bound})", ad.mean[c], fd.mean[k]);
        assert!(fd.mean[k].abs() > 4.0 * fd.std_err[k], "{path}[{c}]: FD is pure noise; the check proves nothing");
    }
}

/// Every path's contribution is linear in the single light's radiance, so with the primal's own seed the
/// adjoint must reproduce d(mean)/d(Le_c) = Σ I_c / (3 N Le_c) up to f32 rounding (relative 1e-4). Also with
/// the light's radiance shaped by direction (a sky gradient, per channel): still linear in Le, the shape
/// carried into the gradient of every emission and next-event term (without it the red channel misses by 25 %).
#[test]
fn light_radiance_gradient_is_exact_for_the_same_paths() {
    for g in [glam::Vec3::ZERO, glam::Vec3::new(0.6, -0.3, 0.9)] {
        let mut s = room(40, 30, 4);
        let p: ParamPath = "light/ceiling_light/radiance".parse().unwrap();
        s.objects.iter_mut().filter_map(|o| o.emitter.as_mut()).for_each(|e| e.sky_gradient = g);
        let le = p.get(&s).unwrap();
        let data = SceneData::build(&s).unwrap();
        let frame = render_cpu(&data, &s.settings, &|_, _| {});
        let n = frame.radiance.len() as f32;
        let layout = GradLayout::new(&s, std::slice::from_ref(&p)).unwrap();
        let grad = radiance_vjp(&data, &s.settings, &layout, &vec![1.0 / n; frame.radiance.len()]).unwrap();
        for c in 0..3 {
            let sum: f64 = frame.radiance.iter().skip(c).step_by(3).map(|&x| x as f64).sum();
            let exact = sum / (n as f64 * le[c] as f64);
            assert!((grad[c] - exact).abs() < 1e-4 * exact, "g {g}, channel {c}: AD {} vs exact {exact}", grad[c]);
        }
    }
}

#[test]
fn albedo_constant_matches_finite_differences() {
    check_against_fd(&room(40, 30, 8), "material/accent_wall/albedo", 0.02, &[0, 1, 2]);
}

#[test]
fn roughness_constant_matches_finite_differences() {
    // The walnut table top is glossy (specular 0.5) and large in the image.
    let mut s = room(40, 30, 8);
    s.camera.origin = glam::Vec3::new(0.2, 1.6, 0.4);
    // Step 0.04: roughness changes the sampled lobe directions, so FD noise falls only like 1/step.
    check_against_fd(&s, "material/walnut/roughness", 0.04, &[0]);
}

#[test]
fn light_radiance_matches_finite_differences() {
    check_against_fd(&room(40, 30, 8), "light/ceiling_light/radiance", 0.5, &[1]);
}

/// A floor textured with a 4x4 EXR (large texels) seen from above, with a uv transform.
fn textured_floor(uv_transform: &str) -> Scene {
    textured_floor_with(&format!(r#""albedo": {{ "texture": "checker.exr" }}, "specular": 0 {uv_transform}"#))
}

#[test]
fn single_texel_matches_finite_differences() {
    check_against_fd(&textured_floor(""), "material/floor/albedo.texel[1,2]", 0.05, &[0, 2]);
}

/// A roughness texel of a glossy floor: its highlight under the lamp changes shape.
#[test]
fn single_roughness_texel_matches_finite_differences() {
    let mut s = textured_floor_with(r#""albedo": 0.3, "specular": 0.8, "roughness": { "texture": "rough.exr" }"#);
    s.settings.spp = 64;
    check_against_fd(&s, "material/floor/roughness.texel[2,1]", 0.02, &[0]);
    check_against_fd(&s, "material/floor/roughness.texel[2,2]", 0.02, &[0]);
}

/// A normal-map texel of a glossy floor seen from above (far from grazing, where the terminator of shading
/// normals has no boundary term yet): all three channels.
#[test]
fn single_normal_map_texel_matches_finite_differences() {
    let mut s = textured_floor_with(r#""albedo": 0.4, "specular": 0.8, "roughness": 0.3, "normal_map": "bumps.exr""#);
    s.settings.spp = 64;
    check_against_fd(&s, "material/floor/normal_map.texel[2,2]", 0.02, &[0, 1, 2]);
}

/// The texture is piecewise bilinear, so the FD step stays well inside a texel's worth of uv motion.
#[test]
fn uv_scale_and_rotation_match_finite_differences() {
    let s = textured_floor(r#", "uv_transform": { "scale": [1.3, 0.8], "rotation_deg": 20, "offset": [0.1, 0.05] }"#);
    check_against_fd(&s, "material/floor/uv_scale", 0.002, &[0, 1]);
    check_against_fd(&s, "material/floor/uv_rotation", 0.1, &[0]);
}

#[test]
fn specular_constant_matches_finite_differences() {
    let mut s = room(40, 30, 8);
    s.camera.origin = glam::Vec3::new(0.2, 1.6, 0.4);
    check_against_fd(&s, "material/walnut/specular", 0.02, &[0]);
}

/// A parameter that no path touches has an exactly zero gradient.
#[test]
fn unused_material_has_zero_gradient() {
    let mut s = room(24, 18, 2);
    s.materials.push(psdr::scene::Material::diffuse("unused", glam::Vec3::splat(0.5)));
    let p: ParamPath = "material/unused/albedo".parse().unwrap();
    let ad = analytic_gradient(
        &s,
        &[p],
        &ImageLoss::Mean(Output::Radiance),
        &AdOptions { replicas: 2, edge_samples: 0, secondary_edge_samples: 0 },
        psdr_tests::fd_backend().as_mut(),
    )
    .unwrap();
    assert_eq!(ad.mean, vec![0.0; 3]);
}

/// The uv transform of a normal-mapped glossy floor: the map is read elsewhere and its tangent frame turns.
#[test]
fn normal_mapped_uv_scale_and_rotation_match_finite_differences() {
    let mut s = textured_floor_with(
        r#""albedo": 0.4, "specular": 0.8, "roughness": 0.5, "normal_map": "bumps.exr",
           "uv_transform": { "scale": [1.3, 0.8], "rotation_deg": 20 }"#,
    );
    s.settings.spp = 128;
    check_against_fd(&s, "material/floor/uv_scale", 0.01, &[0, 1]);
    check_against_fd(&s, "material/floor/uv_rotation", 0.5, &[0]);
}
