//! Crop strategies over masks: where a loss compares texture statistics, it needs rectangles that lie inside
//! one material's region. Scripts choose among these (or their own rectangles from a file).

pub use crate::base::{largest_rect, squarest_rect, Rect};
use crate::base::{mask_inside as inside, Image};
use crate::error::{Error, Result};
use serde::Deserialize;
use std::path::Path;

/// Up to `k` rectangles of `w`×`h` lying wholly inside the mask, drawn uniformly among the valid positions
/// with a seeded generator (the same seed gives the same crops). Fewer than k when fewer positions exist;
/// distinct positions when possible.
pub fn random_crops(mask: &Image, k: usize, w: usize, h: usize, seed: u64) -> Result<Vec<Rect>> {
    let ins = inside(mask)?;
    if w == 0 || h == 0 || w > mask.width || h > mask.height {
        return Err(Error::Invalid(format!(
            "random_crops: a {w}x{h} crop does not fit a {}x{} mask",
            mask.width, mask.height
        )));
    }
    // Summed-area table of inside pixels: a crop is valid when it holds w·h of them.
    let (mw, mh) = (mask.width, mask.height);
    let mut sat = vec![0u32; (mw + 1) * (mh + 1)];
    for y in 0..mh {
        for x in 0..mw {
            sat[(y + 1) * (mw + 1) + x + 1] =
                ins[y * mw + x] as u32 + sat[y * (mw + 1) + x + 1] + sat[(y + 1) * (mw + 1) + x]
                    - sat[y * (mw + 1) + x];
        }
    }
    let count = |x: usize, y: usize| {
        sat[(y + h) * (mw + 1) + x + w] + sat[y * (mw + 1) + x]
            - sat[y * (mw + 1) + x + w]
            - sat[(y + h) * (mw + 1) + x]
    };
    let valid: Vec<(usize, usize)> = (0..=mh - h)
        .flat_map(|y| (0..=mw - w).map(move |x| (x, y)))
        .filter(|&(x, y)| count(x, y) as usize == w * h)
        .collect();
    let mut state = seed ^ 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        // splitmix64
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    // A partial Fisher-Yates shuffle: k distinct positions.
    let mut pool = valid;
    let mut out = vec![];
    for i in 0..k.min(pool.len()) {
        let j = i + (next() % (pool.len() - i) as u64) as usize;
        pool.swap(i, j);
        out.push(Rect { x: pool[i].0, y: pool[i].1, w, h });
    }
    Ok(out)
}

/// User rectangles from a JSON file: `[{"x":..,"y":..,"w":..,"h":..}, ...]` or `{"crops": [...]}`.
pub fn load_rects(path: &Path) -> Result<Vec<Rect>> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum File {
        List(Vec<Rect>),
        Object { crops: Vec<Rect> },
    }
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let f: File = serde_json::from_str(&text).map_err(|e| {
        Error::io(path, format!("expected [{{\"x\",\"y\",\"w\",\"h\"}}, ...] or {{\"crops\": [...]}}: {e}"))
    })?;
    let rects = match f {
        File::List(v) | File::Object { crops: v } => v,
    };
    if let Some(i) = rects.iter().position(|r| r.w == 0 || r.h == 0) {
        return Err(Error::io(path, format!("crop {i} is empty")));
    }
    Ok(rects)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mask(w: usize, h: usize, f: impl Fn(usize, usize) -> bool) -> Image {
        let data = (0..w * h).map(|i| f(i % w, i / w) as u32 as f32).collect();
        Image::new(w, h, 1, data).unwrap()
    }

    #[test]
    fn random_crops_lie_inside_and_repeat_with_the_seed() {
        let m = mask(40, 30, |x, y| (x as i32 - 20).pow(2) + (y as i32 - 15).pow(2) < 144);
        let a = random_crops(&m, 5, 6, 4, 7).unwrap();
        assert_eq!(a.len(), 5);
        for r in &a {
            assert!((r.y..r.y + r.h).all(|y| (r.x..r.x + r.w).all(|x| m.data[y * 40 + x] > 0.5)), "{r:?}");
        }
        assert_eq!(a, random_crops(&m, 5, 6, 4, 7).unwrap());
        assert_ne!(a, random_crops(&m, 5, 6, 4, 8).unwrap());
        assert!(random_crops(&m, 3, 30, 30, 0).unwrap().is_empty(), "no 30x30 crop fits a radius-12 disc");
        assert!(random_crops(&m, 3, 50, 4, 0).is_err());
    }
}
