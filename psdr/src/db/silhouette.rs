//! Silhouette descriptors: a model's outline from 8 yaws at two elevations (10 and 30 degrees, where a
//! photo's camera usually sees furniture from), each cropped to its bounds, padded square and sampled on a
//! 16x16 grid of bits. An instance's mask gets the same treatment, and the best IoU over the views ranks a
//! large class's models before the object stage renders any of them: proportions and outline, not size.

use crate::error::{Error, Result};
use crate::render::layout::NONE;
use crate::render::primary_hits::{model_scene_data, primary_hits};
use crate::render::scene_data::camera_gpu;
use crate::scene::{Camera, MeshPart};
use glam::Vec3;

/// Cells per side of a descriptor.
pub const GRID: usize = 16;
/// Yaws per elevation, evenly spaced.
pub const YAWS: usize = 8;
/// Camera elevations above the horizon, degrees.
pub const ELEVATIONS_DEG: [f32; 2] = [10.0, 30.0];
/// Pixels per side of a view's render.
const VIEW_SIZE: u32 = 64;

/// A 16x16 bit outline, row-major, bit `y * 16 + x`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Silhouette(pub [u64; 4]);

impl Silhouette {
    /// The outline of the `true` pixels of a `w` x `h` mask: their bounds padded to a square about their
    /// centre, each cell set where at least half of its 4x4 sample points fall on the mask. None for an
    /// empty mask.
    pub fn from_mask(mask: &[bool], w: usize, h: usize) -> Option<Silhouette> {
        let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
        for (p, _) in mask.iter().enumerate().take(w * h).filter(|(_, &m)| m) {
            let (x, y) = (p % w, p / w);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
        if x0 == usize::MAX {
            return None;
        }
        let side = ((x1 - x0).max(y1 - y0) + 1) as f32;
        let (cx, cy) = ((x0 + x1 + 1) as f32 / 2.0, (y0 + y1 + 1) as f32 / 2.0);
        let at = |u: f32, v: f32| {
            let (x, y) = ((cx + (u - 0.5) * side).floor(), (cy + (v - 0.5) * side).floor());
            x >= 0.0 && y >= 0.0 && (x as usize) < w && (y as usize) < h && mask[y as usize * w + x as usize]
        };
        let mut s = Silhouette::default();
        for gy in 0..GRID {
            for gx in 0..GRID {
                let mut hits = 0;
                for k in 0..16 {
                    let u = (gx as f32 + ((k % 4) as f32 + 0.5) / 4.0) / GRID as f32;
                    let v = (gy as f32 + ((k / 4) as f32 + 0.5) / 4.0) / GRID as f32;
                    hits += at(u, v) as u32;
                }
                if hits >= 8 {
                    let bit = gy * GRID + gx;
                    s.0[bit / 64] |= 1 << (bit % 64);
                }
            }
        }
        Some(s)
    }

    /// Intersection over union of the set cells (1 for two empty outlines).
    pub fn iou(&self, other: &Silhouette) -> f32 {
        let (mut inter, mut union) = (0, 0);
        for k in 0..4 {
            inter += (self.0[k] & other.0[k]).count_ones();
            union += (self.0[k] | other.0[k]).count_ones();
        }
        if union == 0 {
            1.0
        } else {
            inter as f32 / union as f32
        }
    }

    /// 64 hex digits, as catalog.json stores it.
    pub fn to_hex(&self) -> String {
        self.0.iter().map(|w| format!("{w:016x}")).collect()
    }

    pub fn from_hex(s: &str) -> Result<Silhouette> {
        let bad = || Error::Invalid(format!("silhouette '{s}': want 64 hex digits"));
        if s.len() != 64 || !s.is_ascii() {
            return Err(bad());
        }
        let mut out = Silhouette::default();
        for k in 0..4 {
            out.0[k] = u64::from_str_radix(&s[16 * k..16 * k + 16], 16).map_err(|_| bad())?;
        }
        Ok(out)
    }
}

impl serde::Serialize for Silhouette {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_hex())
    }
}

impl<'de> serde::Deserialize<'de> for Silhouette {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        Silhouette::from_hex(&s).map_err(serde::de::Error::custom)
    }
}

/// The views of a model (as `ModelEntry::load_parts` serves it: base at y = 0, footprint centred), elevation
/// by elevation, yaw by yaw; a view that sees nothing gets an empty outline.
pub fn model_silhouettes(parts: &[MeshPart]) -> Result<Vec<Silhouette>> {
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for v in parts.iter().flat_map(|p| &p.positions) {
        (lo, hi) = (lo.min(*v), hi.max(*v));
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(Error::Invalid("silhouette: a model without vertices".into()));
    }
    let (centre, radius) = ((lo + hi) / 2.0, ((hi - lo).length() / 2.0).max(1e-3));
    let fov = 20.0f32;
    let dist = radius / (fov.to_radians() / 2.0).sin();
    let camera = Camera::look_at(centre + Vec3::Z * dist, centre, Vec3::Y, fov, VIEW_SIZE, VIEW_SIZE);
    let data = model_scene_data(parts, camera)?;
    let mut views = vec![];
    for elevation in ELEVATIONS_DEG {
        for k in 0..YAWS {
            let yaw = std::f32::consts::TAU * k as f32 / YAWS as f32;
            let e = elevation.to_radians();
            let dir = Vec3::new(yaw.sin() * e.cos(), e.sin(), yaw.cos() * e.cos());
            let cam = Camera::look_at(centre + dir * dist, centre, Vec3::Y, fov, VIEW_SIZE, VIEW_SIZE);
            let (ids, _) = primary_hits(&data, &camera_gpu(&cam), 1.0);
            let mask: Vec<bool> = ids.iter().map(|&i| i != NONE).collect();
            views.push(Silhouette::from_mask(&mask, VIEW_SIZE as usize, VIEW_SIZE as usize).unwrap_or_default());
        }
    }
    Ok(views)
}

/// How well an instance's outline matches a model's views: the best IoU over them (0 without views).
pub fn best_view_iou(instance: &Silhouette, views: &[Silhouette]) -> f32 {
    views.iter().map(|v| instance.iou(v)).fold(0.0, f32::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_round_trips_and_iou_counts_cells() {
        let mut mask = vec![false; 40 * 30];
        for y in 5..25 {
            for x in 10..20 {
                mask[y * 40 + x] = true;
            }
        }
        let s = Silhouette::from_mask(&mask, 40, 30).unwrap();
        assert_eq!(Silhouette::from_hex(&s.to_hex()).unwrap(), s);
        // A 10x20 bar padded to a 20x20 square fills the middle half of the columns.
        let cells: u32 = s.0.iter().map(|w| w.count_ones()).sum();
        assert_eq!(cells, 128);
        assert_eq!(s.iou(&s), 1.0);
        assert!(Silhouette::from_mask(&[false; 4], 2, 2).is_none());
        assert!(Silhouette::from_hex("xyz").is_err());
    }
}
