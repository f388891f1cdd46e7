//! Back-projecting a depth map to camera-space points (x right, y up, z forward: the depth AOV's z) and their
//! normals, for the pixels of a mask shrunk away from its border (boundary pixels mix two surfaces).

use glam::Vec3;

/// A pinhole camera's intrinsics as the renderer uses them (square pixels, vertical fov).
#[derive(Clone, Copy, Debug)]
pub struct Intrinsics {
    pub width: usize,
    pub height: usize,
    pub tan_half_fov_y: f32,
}

impl Intrinsics {
    pub fn new(width: usize, height: usize, fov_y_deg: f32) -> Intrinsics {
        Intrinsics { width, height, tan_half_fov_y: (fov_y_deg.to_radians() * 0.5).tan() }
    }

    /// The camera-space point at pixel (x, y)'s centre with depth z.
    pub fn point(&self, x: usize, y: usize, z: f32) -> Vec3 {
        self.ray(x as f32 + 0.5, y as f32 + 0.5) * z
    }

    /// The ray through continuous pixel position (px, py) (pixel corners at integers), scaled to z = 1.
    pub fn ray(&self, px: f32, py: f32) -> Vec3 {
        let aspect = self.width as f32 / self.height as f32;
        let ndc_x = 2.0 * px / self.width as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * py / self.height as f32;
        Vec3::new(ndc_x * self.tan_half_fov_y * aspect, ndc_y * self.tan_half_fov_y, 1.0)
    }
}

/// The mask shrunk by `r` pixels (a pixel stays when its whole (2r+1)² neighbourhood is inside).
pub fn erode(mask: &[bool], w: usize, h: usize, r: usize) -> Vec<bool> {
    let mut out = mask.to_vec();
    if r == 0 {
        return out;
    }
    for y in 0..h {
        for x in 0..w {
            if !mask[y * w + x] {
                continue;
            }
            let inside = (y.saturating_sub(r)..=(y + r).min(h - 1))
                .all(|yy| (x.saturating_sub(r)..=(x + r).min(w - 1)).all(|xx| mask[yy * w + xx]))
                && y >= r
                && x >= r
                && y + r < h
                && x + r < w;
            out[y * w + x] = inside;
        }
    }
    out
}

/// A back-projected pixel with its normal (from neighbouring points, facing the camera).
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub p: Vec3,
    pub n: Vec3,
}

/// Points and normals of the pixels where `mask` holds and the depth (and its 4 neighbours') is valid.
pub fn surface_points(depth: &[f32], mask: &[bool], k: &Intrinsics) -> Vec<SurfacePoint> {
    let (w, h) = (k.width, k.height);
    let at = |x: usize, y: usize| -> Option<Vec3> {
        let z = depth[y * w + x];
        (z > 0.0).then(|| k.point(x, y, z))
    };
    let mut out = vec![];
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            if !mask[y * w + x] {
                continue;
            }
            let (Some(p), Some(l), Some(r), Some(u), Some(d)) =
                (at(x, y), at(x - 1, y), at(x + 1, y), at(x, y - 1), at(x, y + 1))
            else {
                continue;
            };
            let n = (r - l).cross(u - d).normalize_or_zero();
            if n == Vec3::ZERO {
                continue;
            }
            out.push(SurfacePoint { p, n: if n.dot(p) > 0.0 { -n } else { n } });
        }
    }
    out
}
