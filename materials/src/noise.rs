//! Hash-based, periodic noise primitives (no global RNG state, tile by construction).

/// 64-bit avalanche hash of an integer lattice point and a seed.
#[inline(always)]
pub fn hash(x: i64, y: i64, seed: u64) -> u64 {
    let mut h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ seed.wrapping_mul(0x1656_67B1_9E37_79F9).wrapping_add(0x27D4_EB2F_1656_67C5);
    h ^= h >> 33;
    h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
    h ^= h >> 33;
    h = h.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
    h ^= h >> 33;
    h
}

/// Uniform value in [0, 1) for lattice point (x, y), stream `k`.
#[inline(always)]
pub fn hash01(x: i64, y: i64, seed: u64, k: u64) -> f64 {
    (hash(x, y, seed ^ k.wrapping_mul(0x9E37_79B9)) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

#[inline(always)]
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

const GRAD: [(f64, f64); 8] = [
    (1.0, 0.0),
    (-1.0, 0.0),
    (0.0, 1.0),
    (0.0, -1.0),
    (std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2),
    (-std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2),
    (std::f64::consts::FRAC_1_SQRT_2, -std::f64::consts::FRAC_1_SQRT_2),
    (-std::f64::consts::FRAC_1_SQRT_2, -std::f64::consts::FRAC_1_SQRT_2),
];

/// Gradient (Perlin) noise in about [-1, 1] at lattice coordinates (x, y),
/// periodic with `px` x `py` lattice cells.
pub fn perlin(x: f64, y: f64, px: i64, py: i64, seed: u64) -> f64 {
    let x0 = x.floor();
    let y0 = y.floor();
    let fx = x - x0;
    let fy = y - y0;
    let (ix, iy) = (x0 as i64, y0 as i64);
    let g = |dx: i64, dy: i64| -> f64 {
        let h = hash((ix + dx).rem_euclid(px), (iy + dy).rem_euclid(py), seed);
        let (gx, gy) = GRAD[(h & 7) as usize];
        gx * (fx - dx as f64) + gy * (fy - dy as f64)
    };
    let (u, v) = (fade(fx), fade(fy));
    let a = g(0, 0) + (g(1, 0) - g(0, 0)) * u;
    let b = g(0, 1) + (g(1, 1) - g(0, 1)) * u;
    (a + (b - a) * v) * std::f64::consts::SQRT_2
}

/// Octaves of periodic Perlin noise at (u, v) in tile units [0,1): octave k has
/// period `(px, py) * 2^k` and a seed of its own. Fills `out[..octaves]`.
pub fn octaves(u: f64, v: f64, px: i64, py: i64, seed: u64, out: &mut [f64]) {
    for (k, o) in out.iter_mut().enumerate() {
        let f = 1i64 << k;
        let (qx, qy) = (px * f, py * f);
        *o = perlin(u * qx as f64, v * qy as f64, qx, qy, seed.wrapping_add(k as u64 * 7919));
    }
}

/// Non-periodic value-ish smooth noise for plank-local coordinates (grain).
pub fn perlin_free(x: f64, y: f64, seed: u64) -> f64 {
    perlin(x, y, i64::MAX / 4, i64::MAX / 4, seed)
}
