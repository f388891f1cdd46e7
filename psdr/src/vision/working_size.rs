//! The photo's observations at the size the stages fit at. A 4000x3000 phone photo has 150 times the pixels of
//! a 320x240 one and nothing a box, a pose or an albedo needs that the smaller one lacks; every render of every
//! stage costs in proportion. `resized` makes the working observations: sides multiples of 8 (so the 1/8-size
//! light and material fits and the mask pyramids divide them exactly), the photo cropped at most a few working
//! pixels about its centre to that aspect (the vertical field of view follows a vertical crop), colours
//! area-averaged, instance ids by majority over each working pixel's footprint, and depth the median of the
//! footprint's pixels of the winning instance (so a pixel on an object's outline takes the object's depth or the
//! wall's, never a mix). The final scene is then rendered at the photo's own size (`Observations` of the photo
//! give its camera).

use super::depth::Depth;
use super::masks::Instances;
use super::observations::Observations;
use crate::base::Image;
use crate::error::{Error, Result};

/// Working sides are multiples of this.
pub const WORKING_MULTIPLE: usize = 8;

/// The working size for a `w` x `h` photo at about `long_side` pixels on its long side (never larger than the
/// photo), and the centred crop of the photo (x0, y0, width, height, in photo pixels) that has its aspect.
pub fn working_size(w: usize, h: usize, long_side: usize) -> (usize, usize, [f64; 4]) {
    let m = WORKING_MULTIPLE;
    let long = long_side.min(w.max(h)).max(m);
    let s = long as f64 / w.max(h) as f64;
    let round = |v: f64| (((v / m as f64).round() as usize).max(1)) * m;
    let (ww, wh) = (round(w as f64 * s), round(h as f64 * s));
    let (w, h) = (w as f64, h as f64);
    let aspect = ww as f64 / wh as f64;
    let (cw, ch) = if aspect > w / h { (w, w / aspect) } else { (h * aspect, h) };
    (ww, wh, [(w - cw) / 2.0, (h - ch) / 2.0, cw, ch])
}

/// For working pixel (x, y): the range of photo pixels whose centres fall in its footprint (at least the
/// nearest one), and the footprint in photo coordinates.
struct Footprint {
    crop: [f64; 4],
    sx: f64,
    sy: f64,
}

impl Footprint {
    fn new(crop: [f64; 4], ww: usize, wh: usize) -> Footprint {
        Footprint { crop, sx: crop[2] / ww as f64, sy: crop[3] / wh as f64 }
    }
    fn span(a: f64, b: f64, n: usize) -> std::ops::Range<usize> {
        // Pixel i's centre is at i + 0.5; those with a <= i + 0.5 < b, else the one nearest (a + b) / 2.
        let lo = (a - 0.5).ceil().max(0.0) as usize;
        let hi = ((b - 0.5).ceil().max(0.0) as usize).min(n);
        if lo < hi {
            lo..hi
        } else {
            let c = (((a + b) / 2.0).floor().max(0.0) as usize).min(n - 1);
            c..c + 1
        }
    }
    fn pixels(&self, x: usize, y: usize, w: usize, h: usize) -> (std::ops::Range<usize>, std::ops::Range<usize>) {
        let (x0, y0) = (self.crop[0] + x as f64 * self.sx, self.crop[1] + y as f64 * self.sy);
        (Self::span(x0, x0 + self.sx, w), Self::span(y0, y0 + self.sy, h))
    }
    /// Exact area weights of photo column (or row) i under the footprint [a, b).
    fn overlap(a: f64, b: f64, i: usize) -> f64 {
        ((i + 1) as f64).min(b) - (i as f64).max(a)
    }
}

/// Area average of `img` over each working pixel's footprint.
fn area_average(img: &Image, f: &Footprint, ww: usize, wh: usize) -> Result<Image> {
    let (w, h, c) = (img.width, img.height, img.channels);
    let mut out = vec![0.0f32; ww * wh * c];
    for y in 0..wh {
        let (a, b) = (f.crop[1] + y as f64 * f.sy, f.crop[1] + (y + 1) as f64 * f.sy);
        let rows = (a.floor() as usize)..((b.ceil() as usize).min(h));
        for x in 0..ww {
            let (l, r) = (f.crop[0] + x as f64 * f.sx, f.crop[0] + (x + 1) as f64 * f.sx);
            let cols = (l.floor() as usize)..((r.ceil() as usize).min(w));
            let mut sum = vec![0.0f64; c];
            let mut total = 0.0f64;
            for j in rows.clone() {
                let wy = Footprint::overlap(a, b, j);
                for i in cols.clone() {
                    let wt = wy * Footprint::overlap(l, r, i);
                    if wt <= 0.0 {
                        continue;
                    }
                    total += wt;
                    let px = &img.data[(j * w + i) * c..][..c];
                    for (s, &v) in sum.iter_mut().zip(px) {
                        *s += wt * v as f64;
                    }
                }
            }
            for k in 0..c {
                out[(y * ww + x) * c + k] = (sum[k] / total.max(1e-30)) as f32;
            }
        }
    }
    Image::new(ww, wh, c, out)
}

/// Instance ids by majority over each footprint (ties to the smaller id), and the depth as the median of the
/// footprint's valid depths at the winning id's pixels (any pixel's when none of those has one).
fn ids_and_depth(
    ids: Option<&Instances>,
    depth: Option<&Image>,
    f: &Footprint,
    (w, h): (usize, usize),
    (ww, wh): (usize, usize),
) -> (Vec<u16>, Vec<f32>) {
    let mut out_ids = vec![0u16; ww * wh];
    let mut out_depth = vec![0.0f32; ww * wh];
    let mut counts: Vec<(u16, usize)> = vec![];
    let mut values: Vec<f32> = vec![];
    for y in 0..wh {
        for x in 0..ww {
            let (cols, rows) = f.pixels(x, y, w, h);
            let winner = ids.map(|m| {
                counts.clear();
                for j in rows.clone() {
                    for i in cols.clone() {
                        let id = m.ids[j * w + i];
                        match counts.iter_mut().find(|c| c.0 == id) {
                            Some(c) => c.1 += 1,
                            None => counts.push((id, 1)),
                        }
                    }
                }
                counts.iter().max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0))).map_or(0, |c| c.0)
            });
            out_ids[y * ww + x] = winner.unwrap_or(0);
            if let Some(d) = depth {
                let mut median_of = |only: Option<u16>| {
                    values.clear();
                    for j in rows.clone() {
                        for i in cols.clone() {
                            let v = d.data[j * w + i];
                            let same = match (only, ids) {
                                (Some(id), Some(m)) => m.ids[j * w + i] == id,
                                _ => true,
                            };
                            if same && v.is_finite() && v > 0.0 {
                                values.push(v);
                            }
                        }
                    }
                    values.sort_by(f32::total_cmp);
                    values.get(values.len() / 2).copied()
                };
                out_depth[y * ww + x] = median_of(winner).or_else(|| median_of(None)).unwrap_or(0.0);
            }
        }
    }
    (out_ids, out_depth)
}

/// The photo as the stages see it at `w` x `h` (a working size of it, or its own size): area-averaged over the
/// working size's centred crop, as `Observations::resized` makes it; None when no working size of this photo
/// is `w` x `h`.
pub fn photo_at(photo: &Image, w: usize, h: usize) -> Option<Image> {
    if (photo.width, photo.height) == (w, h) {
        return Some(photo.clone());
    }
    let (ww, wh, crop) = working_size(photo.width, photo.height, w.max(h));
    if (ww, wh) != (w, h) {
        return None;
    }
    area_average(photo, &Footprint::new(crop, ww, wh), ww, wh).ok()
}

/// `photo` over the same crop as a working photo of `working` (width, height) made by `resized`, at about
/// `long_side` pixels on its long side (never more than the crop's own pixels, never fewer than the working
/// photo's): working pixel (x, y) covers detail pixels (x, y) x k, k = the detail's width over the working
/// width. The texture search cuts its crops from this: a brick's mortar or a plank's seam that the working
/// size averages away is still in it.
pub fn detail_photo(photo: &Image, working: (usize, usize), long_side: usize) -> Result<Image> {
    let (w, h) = (photo.width, photo.height);
    let (ww, wh) = working;
    if ww == 0 || wh == 0 {
        return Err(Error::Invalid("photo detail: the working size is empty".into()));
    }
    let (cw, ch, crop) = working_size(w, h, ww.max(wh));
    if (cw, ch) != (ww, wh) {
        return Err(Error::Invalid(format!(
            "photo detail: {ww}x{wh} is not a working size of the {w}x{h} photo (that is {cw}x{ch})"
        )));
    }
    let long = ww.max(wh) as f64;
    let k = (long_side as f64 / long).min(crop[2].max(crop[3]) / long).max(1.0);
    let (dw, dh) = ((ww as f64 * k).round() as usize, (wh as f64 * k).round() as usize);
    if (dw, dh) == (w, h) && crop == [0.0, 0.0, w as f64, h as f64] {
        return Ok(photo.clone());
    }
    area_average(photo, &Footprint::new(crop, dw, dh), dw, dh)
}

impl Observations {
    /// The photo at up to `long_side` pixels over a working photo's view (`detail_photo`).
    pub fn photo_detail(&self, working: (usize, usize), long_side: usize) -> Result<Image> {
        detail_photo(&self.photo, working, long_side)
    }

    /// The observations at the working size for `long_side` (see the module); `long_side` 0, or a photo
    /// already at its working size, gives them unchanged.
    pub fn resized(&self, long_side: usize) -> Result<Observations> {
        let (w, h) = (self.photo.width, self.photo.height);
        if long_side == 0 {
            return Ok(self.clone());
        }
        let (ww, wh, crop) = working_size(w, h, long_side);
        if (ww, wh) == (w, h) {
            return Ok(self.clone());
        }
        let f = Footprint::new(crop, ww, wh);
        let photo = area_average(&self.photo, &f, ww, wh)?;
        let (ids, depth) =
            ids_and_depth(self.instances.as_ref(), self.depth.as_ref().map(|d| &d.image), &f, (w, h), (ww, wh));
        let depth = match &self.depth {
            Some(d) => Some(Depth {
                image: Image::new(ww, wh, 1, depth)?,
                units: d.units,
                missing: 0, // counted below
            }),
            None => None,
        };
        let depth = depth.map(|mut d| {
            d.missing = d.image.data.iter().filter(|v| **v <= 0.0).count();
            d
        });
        let instances = self.instances.as_ref().map(|m| {
            let mut inst = m.instances.clone();
            for i in inst.iter_mut() {
                i.pixels = ids.iter().filter(|&&v| v == i.id).count();
            }
            // An instance too small to keep a working pixel is not in the working photo.
            inst.retain(|i| i.pixels > 0);
            Instances { width: ww, height: wh, ids: ids.clone(), instances: inst }
        });
        // A vertical crop narrows the vertical field of view; a horizontal one keeps it.
        let fov_y_deg = self.fov_y_deg.map(|fov| {
            let t = (fov.to_radians() / 2.0).tan() as f64 * crop[3] / h as f64;
            (2.0 * t.atan()).to_degrees() as f32
        });
        let mut sources = self.sources.clone();
        sources.insert(
            "working_size".into(),
            format!(
                "{ww}x{wh} from the photo's {w}x{h} (centred crop {:.1}x{:.1} px, {:.2} photo pixels per working pixel)",
                crop[2],
                crop[3],
                crop[2] / ww as f64
            ),
        );
        if !photo.data.iter().all(|v| v.is_finite()) {
            return Err(Error::Invalid("working size: the resampled photo is not finite".into()));
        }
        Ok(Observations {
            photo_path: self.photo_path.clone(),
            photo,
            depth,
            instances,
            fov_y_deg,
            fov_estimate: self.fov_estimate.clone(),
            depth_calibration: self.depth_calibration.clone(),
            // The box and camera do not depend on the image's size (the crop is centred).
            room_layout: self.room_layout.clone(),
            sources,
            warnings: self.warnings.clone(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_are_multiples_of_eight_with_the_photos_aspect() {
        for (w, h, ww, wh) in
            [(512, 384, 320, 240), (4000, 3000, 320, 240), (800, 600, 320, 240), (1920, 1080, 320, 184)]
        {
            let (a, b, crop) = working_size(w, h, 320);
            assert_eq!((a, b), (ww, wh), "{w}x{h}");
            let photo_aspect = crop[2] / crop[3];
            assert!((photo_aspect - a as f64 / b as f64).abs() < 1e-9, "the crop has the working aspect");
            assert!(crop[2] <= w as f64 && crop[3] <= h as f64);
        }
        // A photo smaller than the working size keeps its size, rounded to multiples of 8.
        assert_eq!(working_size(200, 150, 320).0, 200);
        assert_eq!(working_size(200, 150, 320).1, 152);
    }

    #[test]
    fn the_detail_photo_is_the_working_photos_view_at_k_times_its_pixels() {
        // A 1920x1080 photo (working 320x184: a horizontal crop) of smooth colour and a step: at 640 long the
        // detail is 2x the working size and each working pixel is the mean of its 2x2 detail pixels, so both
        // show the same view of the photo.
        let (w, h) = (1920, 1080);
        let data: Vec<f32> = (0..w * h)
            .flat_map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                [x / w as f32, y / h as f32, if x < 700.0 { 0.2 } else { 0.9 }]
            })
            .collect();
        let photo = Image::new(w, h, 3, data).unwrap();
        let (ww, wh, crop) = working_size(w, h, 320);
        let working = area_average(&photo, &Footprint::new(crop, ww, wh), ww, wh).unwrap();
        let detail = detail_photo(&photo, (ww, wh), 640).unwrap();
        assert_eq!((detail.width, detail.height), (2 * ww, 2 * wh));
        let mut worst = 0.0f32;
        for y in 0..wh {
            for x in 0..ww {
                for c in 0..3 {
                    let d = |i: usize, j: usize| detail.data[((2 * y + j) * detail.width + 2 * x + i) * 3 + c];
                    let mean = (d(0, 0) + d(1, 0) + d(0, 1) + d(1, 1)) / 4.0;
                    worst = worst.max((mean - working.data[(y * ww + x) * 3 + c]).abs());
                }
            }
        }
        assert!(worst < 1e-5, "a working pixel differs from its detail pixels' mean by {worst}");
        // Against the photo itself: channel 0 is x / w at photo pixel x, so a detail pixel's value is the
        // photo column at its footprint's centre (x0 + (X + 0.5) s - 0.5, s photo pixels per detail pixel).
        let s = crop[2] / detail.width as f64;
        for x in [0, 17, detail.width / 2, detail.width - 1] {
            let want = ((crop[0] + (x as f64 + 0.5) * s - 0.5) / w as f64) as f32;
            let got = detail.data[(5 * detail.width + x) * 3];
            assert!((got - want).abs() < 0.6 / w as f32, "detail column {x}: {got} where the photo has {want}");
        }
        // Never more pixels than the photo has; the photo itself where it has the working aspect.
        let small = Image::new(512, 384, 3, vec![0.5; 512 * 384 * 3]).unwrap();
        let same = detail_photo(&small, (320, 240), 640).unwrap();
        assert_eq!((same.width, same.height), (512, 384));
        assert!(detail_photo(&small, (320, 200), 640).is_err(), "320x200 is not this photo's working size");
    }

    #[test]
    fn area_average_keeps_the_mean_and_a_step() {
        // A 6x4 image, left half 1, right half 3: at 3x2 (no crop) each working pixel covers 2x2 photo pixels.
        let data: Vec<f32> = (0..24).map(|i| if i % 6 < 3 { 1.0 } else { 3.0 }).collect();
        let img = Image::new(6, 4, 1, data).unwrap();
        let f = Footprint::new([0.0, 0.0, 6.0, 4.0], 3, 2);
        let out = area_average(&img, &f, 3, 2).unwrap();
        assert_eq!(out.data, vec![1.0, 2.0, 3.0, 1.0, 2.0, 3.0]);
    }
}
