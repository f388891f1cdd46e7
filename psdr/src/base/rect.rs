//! Axis-aligned rectangles inside masks: where a texture statistic is compared, it needs a rectangle that lies
//! inside one region.

use crate::base::Image;
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// A pixel rectangle: x, y of the top-left corner, width, height.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rect {
    pub x: usize,
    pub y: usize,
    pub w: usize,
    pub h: usize,
}

/// Pixels of a 1-channel mask that count as inside (anti-aliased masks: more than half covered).
pub fn mask_inside(mask: &Image) -> Result<Vec<bool>> {
    if mask.channels != 1 {
        return Err(Error::Invalid(format!("crop strategies take a 1-channel mask, not {} channels", mask.channels)));
    }
    Ok(mask.data.iter().map(|&v| v > 0.5).collect())
}

/// The largest-area axis-aligned rectangle of inside pixels (maximal rectangle in a histogram, row by row,
/// O(W·H)); None for an empty mask. Ties: the first found scanning from the top.
pub fn largest_rect(mask: &Image) -> Result<Option<Rect>> {
    best_rect(mask, |r| (r.w * r.h, 0))
}

/// The rectangle of inside pixels with the largest square inside it (ties: the larger area): what a texture
/// descriptor wants, where the largest-area rectangle can be a strip one row high.
pub fn squarest_rect(mask: &Image) -> Result<Option<Rect>> {
    best_rect(mask, |r| (r.w.min(r.h), r.w * r.h))
}

/// The maximal rectangle of inside pixels with the highest `key`.
fn best_rect(mask: &Image, key: impl Fn(&Rect) -> (usize, usize)) -> Result<Option<Rect>> {
    let ins = mask_inside(mask)?;
    let (w, h) = (mask.width, mask.height);
    let mut heights = vec![0usize; w];
    let mut best: Option<Rect> = None;
    let area = |r: &Option<Rect>| r.as_ref().map_or((0, 0), &key);
    for y in 0..h {
        for x in 0..w {
            heights[x] = if ins[y * w + x] { heights[x] + 1 } else { 0 };
        }
        // Stack of (start column, height) with increasing heights.
        let mut stack: Vec<(usize, usize)> = vec![];
        for (x, &hx) in heights.iter().chain(std::iter::once(&0)).enumerate() {
            let mut start = x;
            while let Some(&(s, sh)) = stack.last() {
                if sh < hx {
                    break;
                }
                stack.pop();
                let cand = Some(Rect { x: s, y: y + 1 - sh, w: x - s, h: sh });
                if sh > 0 && area(&cand) > area(&best) {
                    best = cand;
                }
                start = s;
            }
            stack.push((start, hx));
        }
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mask(w: usize, h: usize, f: impl Fn(usize, usize) -> bool) -> Image {
        let data = (0..w * h).map(|i| f(i % w, i / w) as u32 as f32).collect();
        Image::new(w, h, 1, data).unwrap()
    }

    /// Against brute force over every rectangle on random blobby masks.
    #[test]
    fn largest_rect_matches_brute_force() {
        let mut s = 12345u64;
        for _ in 0..30 {
            let (w, h) = (9, 7);
            let bits: Vec<bool> = (0..w * h)
                .map(|_| {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    !(s >> 33).is_multiple_of(4)
                })
                .collect();
            let m = mask(w, h, |x, y| bits[y * w + x]);
            let mut best = 0;
            for y0 in 0..h {
                for x0 in 0..w {
                    for y1 in y0..h {
                        for x1 in x0..w {
                            if (y0..=y1).all(|y| (x0..=x1).all(|x| bits[y * w + x])) {
                                best = best.max((x1 - x0 + 1) * (y1 - y0 + 1));
                            }
                        }
                    }
                }
            }
            let r = largest_rect(&m).unwrap();
            assert_eq!(r.map_or(0, |r| r.w * r.h), best);
            if let Some(r) = r {
                assert!((r.y..r.y + r.h).all(|y| (r.x..r.x + r.w).all(|x| bits[y * w + x])), "{r:?} leaves the mask");
            }
        }
        assert_eq!(largest_rect(&mask(4, 4, |_, _| false)).unwrap(), None);
    }
}
