//! Where the fitted scene is not the photo's: per photo pixel, whether the scene's primary ray hits what the
//! segmentation says the photo shows there (`geometry_agreement`), and that mask in the blocks the photometric
//! fits compare (`agreeing_blocks`). A retrieved model is rarely the photo's own object; where it is narrower or
//! lower, the renders show the wall behind it where the photo shows the object, and no light or albedo can
//! explain those pixels: the fits leave them out (their `agreement` option).

use super::material_segments::{check_size, expectation, primary_hits, Expect};
use crate::error::Result;
use crate::scene::Scene;
use crate::vision::Instances;

/// What the segmentation says a pixel shows, in the terms of `Expect` (a room surface by class, any other
/// labelled instance by id, nothing checkable for an unlabelled pixel or an unknown id), and whether it is a
/// window.
fn segmentation_says<'a>(inst: &'a Instances, id: u16) -> (Expect<'a>, bool) {
    match inst.instances.iter().find(|i| i.id == id).map(|i| i.class.as_str()) {
        Some(c @ ("floor" | "ceiling" | "wall")) => (Expect::Class(c), false),
        Some("window") => (Expect::Nothing, true),
        None => (Expect::Nothing, false),
        Some(_) => (Expect::Instance(id), false),
    }
}

/// Per photo pixel, 1 where the fitted scene and the segmentation agree on what the pixel shows, 0 where they
/// disagree: the primary ray hits a room surface of another class than the segmentation's, or another object
/// than the instance the segmentation names (a retrieved model narrower or lower than the photo's, the wall
/// behind it drawn where the photo shows the object). Pixels where either says nothing checkable (a light or
/// window hit, an unlabelled pixel) agree, and so does a window's pixel unless the scene puts furniture before
/// it (a window may be drawn as the wall or as a light). The photometric fits leave the
/// disagreeing pixels out: there the photo shows another surface than the render, and no light or albedo can
/// make up for that (real room02 with its true models held out: a closed cabinet for an open wall unit, 14 %
/// of the pixels, the lights and albedos fitted to them).
pub fn geometry_agreement(scene: &Scene, inst: &Instances) -> Result<Vec<f32>> {
    check_size(scene, inst, "geometry agreement")?;
    let expect: Vec<Expect> = scene.objects.iter().map(|o| expectation(&o.name)).collect();
    let hits = primary_hits(scene)?;
    Ok(hits
        .iter()
        .zip(&inst.ids)
        .map(|(hit, &id)| {
            let rendered = hit.and_then(|(o, _)| expect.get(o as usize).copied()).unwrap_or(Expect::Nothing);
            let agrees = match segmentation_says(inst, id) {
                // A window the photo shows may be drawn as the wall or as a light, not as furniture before it.
                (_, true) => !matches!(rendered, Expect::Instance(_)),
                (said, false) => rendered == Expect::Nothing || said == Expect::Nothing || rendered == said,
            };
            f32::from(u8::from(agrees))
        })
        .collect())
}

/// `mask` (per pixel of a w x h image, 1 where it agrees) in whole k x k blocks: 1 over each block where at
/// least `min_share` of the pixels agree, 0 over the others (the blocks at the right and bottom edges, cut by
/// the image, judged on their own pixels). The fits compare the photo in such blocks; a pixel mask would also
/// take out the outline's misfit of every well-placed object, which the evaluation counts and the fits fitted
/// (real rooms with their own models: 1.3 % of the pixels; left out, the image error rose by up to half a
/// point).
pub fn agreeing_blocks(mask: &[f32], w: usize, h: usize, k: usize, min_share: f32) -> Vec<f32> {
    let k = k.max(1);
    let mut out = vec![1.0; mask.len()];
    if mask.len() != w * h {
        return out;
    }
    for by in (0..h).step_by(k) {
        for bx in (0..w).step_by(k) {
            let pixels = || (by..(by + k).min(h)).flat_map(move |y| (bx..(bx + k).min(w)).map(move |x| y * w + x));
            let n = pixels().count() as f32;
            let agree: f32 = pixels().map(|p| mask[p].clamp(0.0, 1.0)).sum();
            if agree < min_share * n {
                pixels().for_each(|p| out[p] = 0.0);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::agreeing_blocks;

    /// A 10 x 6 mask in 4 x 4 blocks (the right column 2 wide, the bottom row 2 high): a block goes whole to 0
    /// where under 3/4 of its own pixels agree, else whole to 1.
    #[test]
    fn blocks_keep_or_drop_whole_on_their_own_pixels() {
        let (w, h) = (10, 6);
        // Disagreeing: 4 of the first block's 16 pixels (kept at 3/4), 5 of the second's (dropped), 3 of the
        // right column's first block's 8 (dropped: 5/8 agree), 1 of the bottom-left block's 8 (kept: 7/8).
        let off =
            [(0, 0), (1, 0), (2, 0), (3, 0), (4, 0), (5, 0), (6, 0), (7, 0), (4, 1), (8, 0), (9, 0), (8, 1), (0, 5)];
        let mask: Vec<f32> = (0..w * h).map(|p| if off.contains(&(p % w, p / w)) { 0.0 } else { 1.0 }).collect();
        let b = agreeing_blocks(&mask, w, h, 4, 0.75);
        let at = |x: usize, y: usize| b[y * w + x];
        assert_eq!((at(0, 0), at(3, 3), at(0, 5)), (1.0, 1.0, 1.0));
        assert_eq!((at(4, 0), at(7, 3), at(8, 0), at(9, 3)), (0.0, 0.0, 0.0, 0.0));
        assert_eq!((at(4, 4), at(9, 5)), (1.0, 1.0));
        // Without a block, or with a mask of another size, nothing is dropped.
        assert_eq!(agreeing_blocks(&mask, w, h, 1, 1.0), mask);
        assert!(agreeing_blocks(&mask[1..], w, h, 4, 0.75).iter().all(|&v| v == 1.0));
    }
}
