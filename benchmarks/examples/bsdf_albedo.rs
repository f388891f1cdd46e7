//! Directional albedo of our BSDF (diffuse and specular parts) for a few incidence angles, to compare with
//! Mitsuba's roughplastic: `cargo run --release -p psdr-benchmarks --example bsdf_albedo -- ALBEDO ROUGHNESS SPECULAR`.
use glam::Vec3;
use psdr::render::bsdf::*;
use psdr::render::sampler::sample_1d;

fn main() {
    let a: Vec<f32> = std::env::args().skip(1).map(|s| s.parse().unwrap()).collect();
    let p = BsdfParams { albedo: Vec3::splat(a[0]), roughness: a[1], specular: a[2] };
    let k = psdr::export::mitsuba::roughplastic_albedo_scale(ggx_alpha(p.roughness), specular_to_eta(p.specular));
    println!("roughplastic albedo scale {k:.5}");
    for cos_i in [1.0f32, 0.8, 0.6, 0.4, 0.2, 0.1] {
        let wi = Vec3::new((1.0 - cos_i * cos_i).sqrt(), 0.0, cos_i);
        let n = 1u32 << 20;
        let mut s = 0.0f64;
        for i in 0..n {
            if let Some(b) = bsdf_sample(&p, wi, sample_1d(1, i, 0, 0), sample_1d(1, i, 0, 1), sample_1d(1, i, 0, 2)) {
                s += b.weight.x as f64;
            }
        }
        println!("cos_i {cos_i:.2} albedo {:.5}", s / n as f64);
    }
}
