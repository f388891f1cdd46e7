//! Where a photo stops recording the scene: an 8-bit (or 16-bit) photo clips every channel at its white, so a
//! visible lamp, a window or a sunlit patch reads 1.0 however bright it is. Those pixels say only "at least
//! this bright"; a fit that matched them would dim the lights that cause them. The photometric fits leave them
//! out (`unclipped`), and a render is compared with such a photo as the camera would have recorded it
//! (`clip_like_photo`: clamped at its white). A photo with values above 1 (EXR) is high dynamic range and
//! clips nowhere.

/// A linear value at or above this reads as clipped: sRGB 252 of 255 (a clipped region keeps values near 1
/// after the working size's area average, except at its edge, which `unclipped` widens by a pixel).
pub const CLIPPED_LINEAR: f32 = 0.973;

/// Whether `photo` (linear RGB) is low dynamic range: no value above 1, as an integer image decodes.
pub fn is_low_dynamic_range(photo: &[f32]) -> bool {
    photo.iter().all(|v| *v <= 1.0 + 1e-4)
}

/// Per pixel of a `width`-wide linear RGB photo, 1 where it records the scene and 0 where a channel is
/// clipped or next to such a pixel (8-neighbourhood); all ones for a high-dynamic-range photo.
pub fn unclipped(photo: &[f32], width: usize) -> Vec<f32> {
    let n = photo.len() / 3;
    if !is_low_dynamic_range(photo) || width == 0 {
        return vec![1.0; n];
    }
    let height = n / width;
    let clipped: Vec<bool> = photo.chunks(3).map(|c| c.iter().any(|v| *v >= CLIPPED_LINEAR)).collect();
    let mut out = vec![1.0; n];
    for y in 0..height {
        for x in 0..width {
            if !clipped[y * width + x] {
                continue;
            }
            for yy in y.saturating_sub(1)..(y + 2).min(height) {
                for xx in x.saturating_sub(1)..(x + 2).min(width) {
                    out[yy * width + xx] = 0.0;
                }
            }
        }
    }
    out
}

/// `render` as the camera that took `photo` records it: clamped at 1 where the photo is low dynamic range.
pub fn clip_like_photo(render: &[f32], photo: &[f32]) -> Vec<f32> {
    if is_low_dynamic_range(photo) {
        render.iter().map(|v| v.min(1.0)).collect()
    } else {
        render.to_vec()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clipped_pixel_and_its_neighbours_are_left_out() {
        // 4 x 3, one clipped pixel at (0, 1) (its red channel), the rest mid-grey.
        let mut photo = vec![0.4f32; 4 * 3 * 3];
        photo[3 * 4] = 1.0;
        let u = unclipped(&photo, 4);
        let zero: Vec<usize> = (0..12).filter(|&p| u[p] == 0.0).collect();
        assert_eq!(zero, vec![0, 1, 4, 5, 8, 9]);
        // High dynamic range: nothing clips, a render is compared as it is.
        photo[0] = 3.0;
        assert!(unclipped(&photo, 4).iter().all(|v| *v == 1.0));
        assert_eq!(clip_like_photo(&[2.0, 0.5, 0.1], &photo), vec![2.0, 0.5, 0.1]);
        assert_eq!(clip_like_photo(&[2.0, 0.5, 0.1], &[0.2, 0.3, 1.0]), vec![1.0, 0.5, 0.1]);
    }
}
