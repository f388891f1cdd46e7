//! A light the photo shows (a window, a ceiling panel) is a rectangle on a known plane, and the photo records
//! its outline to a fraction of a pixel: a pixel the rectangle covers by a fraction c reads
//! min(1, c L + (1 - c) B) of its white, L the light's brightness and B the surface's around it. Taken from
//! the range of the pixels inside it, the outline was 1-2 pixels off (an 8-bit photo's white makes a pixel a
//! tenth covered read as fully lit), and at 1/8 size the blocks along a window's edge then held half of a
//! room's image error (real room01: 63 %, room10: 46 %). `refine_outline` fits the rectangle's four edges and
//! L to the photo's pixels around it, each pixel's exact covered area from the projected rectangle clipped to
//! the pixel's square.

use super::window_lights::{is_room_surface, near_window};
use super::{is_edge_ceiling_light, is_visible_light};
use crate::render::scene_data::camera_gpu;
use crate::scene::{Camera, Scene};
use crate::vision::{is_low_dynamic_range, Instances};
use glam::{Vec2, Vec3};

/// A rectangle on a plane: its points are `origin + a u + b v` for u in `u`, v in `v` (`a`, `b` unit and
/// orthogonal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PlaneRect {
    pub origin: Vec3,
    pub a: Vec3,
    pub b: Vec3,
    pub u: [f32; 2],
    pub v: [f32; 2],
}

impl PlaneRect {
    fn corners(&self) -> [Vec3; 4] {
        let p = |u: f32, v: f32| self.origin + self.a * u + self.b * v;
        [p(self.u[0], self.v[0]), p(self.u[1], self.v[0]), p(self.u[1], self.v[1]), p(self.u[0], self.v[1])]
    }

    /// The centre of the rectangle in world space, and its extent along `a` and `b`.
    pub fn centre_and_size(&self) -> (Vec3, f32, f32) {
        let (u, v) = ((self.u[0] + self.u[1]) / 2.0, (self.v[0] + self.v[1]) / 2.0);
        (self.origin + self.a * u + self.b * v, self.u[1] - self.u[0], self.v[1] - self.v[0])
    }
}

/// World point to continuous pixel position (pixel corners at integers); None behind the camera.
fn project(cam: &Camera, x: Vec3) -> Option<Vec2> {
    crate::grad::project(&camera_gpu(cam), x).map(Vec2::from)
}

/// Area of a polygon (shoelace, either winding).
fn area(poly: &[Vec2]) -> f32 {
    let n = poly.len();
    (0..n).map(|i| poly[i].perp_dot(poly[(i + 1) % n])).sum::<f32>().abs() * 0.5
}

/// The part of `poly` where `inside` holds, for a half-plane given by `inside` and the crossing of an edge
/// with its boundary (Sutherland-Hodgman, one boundary).
fn clip(poly: &[Vec2], inside: impl Fn(Vec2) -> bool, cross: impl Fn(Vec2, Vec2) -> Vec2) -> Vec<Vec2> {
    let mut out = Vec::with_capacity(poly.len() + 2);
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        match (inside(p), inside(q)) {
            (true, true) => out.push(q),
            (true, false) => out.push(cross(p, q)),
            (false, true) => {
                out.push(cross(p, q));
                out.push(q);
            }
            (false, false) => {}
        }
    }
    out
}

/// The fraction of pixel (x, y)'s square that the convex polygon `quad` covers.
fn covered(quad: &[Vec2], x: f32, y: f32) -> f32 {
    let at_x = |c: f32| move |p: Vec2, q: Vec2| p + (q - p) * ((c - p.x) / (q.x - p.x));
    let at_y = |c: f32| move |p: Vec2, q: Vec2| p + (q - p) * ((c - p.y) / (q.y - p.y));
    let mut poly = clip(quad, |p| p.x >= x, at_x(x));
    poly = clip(&poly, |p| p.x <= x + 1.0, at_x(x + 1.0));
    poly = clip(&poly, |p| p.y >= y, at_y(y));
    poly = clip(&poly, |p| p.y <= y + 1.0, at_y(y + 1.0));
    if poly.len() < 3 {
        0.0
    } else {
        area(&poly)
    }
}

/// Per pixel of `pixels` (indices into a `width`-wide image), the fraction of it that `rect` covers as `cam`
/// sees it; None when a corner is behind the camera.
fn coverage(cam: &Camera, rect: &PlaneRect, pixels: &[usize], width: usize) -> Option<Vec<f32>> {
    let quad: Vec<Vec2> = rect.corners().iter().map(|c| project(cam, *c)).collect::<Option<_>>()?;
    let (lo, hi) =
        quad.iter().fold((Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    Some(
        pixels
            .iter()
            .map(|&p| {
                let (x, y) = ((p % width) as f32, (p / width) as f32);
                if x + 1.0 <= lo.x || x >= hi.x || y + 1.0 <= lo.y || y >= hi.y {
                    0.0
                } else {
                    covered(&quad, x, y)
                }
            })
            .collect(),
    )
}

/// What the outline fit found: the rectangle, and the mean squared error over the pixels used at the start and
/// at the end (each with its best brightness; the stages take the rectangle, the tests read the errors).
#[derive(Clone, Debug)]
#[cfg_attr(not(test), allow(dead_code))]
pub(super) struct Outline {
    pub rect: PlaneRect,
    pub error_before: f32,
    pub error_after: f32,
}

/// Fits `start`'s four edges and the light's brightness to `photo` (linear RGB at the camera's size) on the
/// pixels around its projection that `usable` allows (not covered by furniture), by a pattern search from a
/// pixel's footprint down to 1/64 of it, each edge within `margin` pixels of the start (an edge the frame cuts
/// stays); `low_dynamic_range` clips the model at 1, as the photo is; `brightness` fixes L (a fitted light's
/// radiance, so that its render clips the pixels the photo's does), else L is the best for each outline. None
/// when the rectangle is not wholly in front of the camera or too few pixels are usable.
pub(super) fn refine_outline(
    cam: &Camera,
    photo: &[f32],
    usable: &dyn Fn(usize) -> bool,
    start: PlaneRect,
    margin: f32,
    low_dynamic_range: bool,
    brightness: Option<f32>,
) -> Option<Outline> {
    let (w, h) = (cam.width as usize, cam.height as usize);
    if photo.len() != w * h * 3 {
        return None;
    }
    // A pixel's footprint on the plane along each axis at the rectangle's centre, the search's first step.
    let (centre, _, _) = start.centre_and_size();
    let footprint = |axis: Vec3| -> Option<f32> {
        let eps = 1e-3 * (centre - cam.origin).length();
        let moved = (project(cam, centre + axis * eps)? - project(cam, centre)?).length();
        (moved > 0.0).then(|| eps / moved)
    };
    let (fu, fv) = (footprint(start.a)?, footprint(start.b)?);
    // The pixels any rectangle within reach covers, and a pixel beyond.
    let reach = PlaneRect {
        u: [start.u[0] - (margin + 1.0) * fu, start.u[1] + (margin + 1.0) * fu],
        v: [start.v[0] - (margin + 1.0) * fv, start.v[1] + (margin + 1.0) * fv],
        ..start
    };
    let quad: Vec<Vec2> = reach.corners().iter().map(|c| project(cam, *c)).collect::<Option<_>>()?;
    let (lo, hi) =
        quad.iter().fold((Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let (x0, y0) = ((lo.x - 1.0).floor().max(0.0) as usize, (lo.y - 1.0).floor().max(0.0) as usize);
    let (x1, y1) = ((hi.x + 1.0).ceil().min(w as f32) as usize, (hi.y + 1.0).ceil().min(h as f32) as usize);
    let pixels: Vec<usize> = (y0..y1).flat_map(|y| (x0..x1).map(move |x| y * w + x)).filter(|&p| usable(p)).collect();
    if pixels.len() < 16 {
        return None;
    }
    // Each pixel's brightest channel: the one that clips first, as the light's white does.
    let value: Vec<f32> = pixels.iter().map(|&p| photo[3 * p..3 * p + 3].iter().copied().fold(0.0, f32::max)).collect();
    // The background: the median of the pixels the start leaves uncovered.
    let c0 = coverage(cam, &start, &pixels, w)?;
    let mut outside: Vec<f32> = value.iter().zip(&c0).filter(|(_, c)| **c == 0.0).map(|(v, _)| *v).collect();
    if outside.len() < 8 {
        return None;
    }
    outside.sort_by(f32::total_cmp);
    let background = outside[outside.len() / 2];
    // The brightnesses tried for each outline (log-spaced from just above the background to far past the
    // brightest pixel): the best is taken for each, so the search over edges never stalls on a brightness.
    let top = value.iter().copied().fold(background, f32::max).max(1.0);
    let (lmin, lmax) = ((background * 1.01).max(0.02), 256.0 * top);
    let levels: Vec<f32> = (0..64).map(|i| lmin * (lmax / lmin).powf(i as f32 / 63.0)).collect();
    let error = |rect: &PlaneRect| -> (f32, f32) {
        let Some(c) = coverage(cam, rect, &pixels, w) else { return (f32::INFINITY, 0.0) };
        let at = |brightness: f32| -> f32 {
            let sum: f32 = c
                .iter()
                .zip(&value)
                .map(|(c, v)| {
                    let model = c * brightness + (1.0 - c) * background;
                    let model = if low_dynamic_range { model.min(1.0) } else { model };
                    (model - v).powi(2)
                })
                .sum();
            sum / pixels.len() as f32
        };
        if let Some(l) = brightness {
            return (at(l), l);
        }
        let errors: Vec<f32> = levels.iter().map(|l| at(*l)).collect();
        let k = (0..levels.len()).min_by(|a, b| errors[*a].total_cmp(&errors[*b])).unwrap_or(0);
        // Then between its neighbours by golden section (in log brightness), so that the error is continuous
        // in the edges and the search over them sees its slope.
        let (mut a, mut b) = (levels[k.saturating_sub(1)].ln(), levels[(k + 1).min(levels.len() - 1)].ln());
        let g = 0.618_034f32;
        for _ in 0..20 {
            let (x, y) = (b - g * (b - a), a + g * (b - a));
            if at(x.exp()) < at(y.exp()) {
                b = y;
            } else {
                a = x;
            }
        }
        let l = ((a + b) / 2.0).exp();
        let e = at(l);
        if e < errors[k] {
            (e, l)
        } else {
            (errors[k], levels[k])
        }
    };
    // An edge the frame cuts (its midpoint not a pixel inside the image) stays: no pixel says where it is.
    let inside =
        |p: Option<Vec2>| p.is_some_and(|p| p.x > 1.0 && p.y > 1.0 && p.x < w as f32 - 1.0 && p.y < h as f32 - 1.0);
    let (um, vm) = ((start.u[0] + start.u[1]) / 2.0, (start.v[0] + start.v[1]) / 2.0);
    let seen = |k: usize| {
        let at = |u: f32, v: f32| project(cam, start.origin + start.a * u + start.b * v);
        match k {
            0 => inside(at(start.u[0], vm)),
            1 => inside(at(start.u[1], vm)),
            2 => inside(at(um, start.v[0])),
            _ => inside(at(um, start.v[1])),
        }
    };
    let free: Vec<bool> = (0..4).map(seen).collect();
    // The moves tried, in units of a footprint on (u0, u1, v0, v1): each edge alone, and each pair of opposite
    // edges together, out of step (wider or narrower) and in step (shifted), as the brightness trades against
    // the width: a narrower light a little brighter clips the same pixels.
    let mut steps: Vec<[f32; 4]> = vec![];
    for k in 0..4 {
        let mut s = [0.0; 4];
        s[k] = 1.0;
        steps.push(s);
    }
    for (a, b) in [(0, 1), (2, 3)] {
        for other in [-1.0, 1.0] {
            let mut s = [0.0; 4];
            (s[a], s[b]) = (1.0, other);
            steps.push(s);
        }
    }
    steps.retain(|s| (0..4).all(|k| free[k] || s[k] == 0.0));
    let mut rect = start;
    let (error_before, _) = error(&rect);
    let mut best = error_before;
    let mut scale = 1.0f32;
    while scale > 1.0 / 64.0 {
        let mut moved = false;
        for step in &steps {
            for sign in [-1.0f32, 1.0] {
                let mut r = rect;
                for j in 0..2 {
                    r.u[j] += sign * scale * fu * step[j];
                    r.v[j] += sign * scale * fv * step[2 + j];
                }
                // Within `margin` pixels of the start on every edge, and no narrower than a pixel.
                let off = (0..2)
                    .any(|j| (r.u[j] - start.u[j]).abs() > margin * fu || (r.v[j] - start.v[j]).abs() > margin * fv);
                if off || r.u[1] - r.u[0] < fu || r.v[1] - r.v[0] < fv {
                    continue;
                }
                let (e, _) = error(&r);
                if e < best {
                    (best, rect, moved) = (e, r, true);
                    break;
                }
            }
        }
        if !moved {
            scale *= 0.5;
        }
    }
    Some(Outline { rect, error_before, error_after: best })
}

/// One light's outline refitted at its fitted radiance (`fit_light_outlines`): how far its edges moved
/// (pixels, the largest) and the error over its pixels before and after.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LightOutline {
    pub name: String,
    pub moved_px: f32,
    pub error_before: f32,
    pub error_after: f32,
}

/// Refits the outline of each light the photo shows (`is_visible_light`, and `is_edge_ceiling_light` on its
/// sides in view), each edge within `margin` pixels, to `photo` (linear RGB at the camera's size) with its brightness fixed at its radiance's
/// brightest channel, the one that clips first: the light's initial outline took the brightness the photo's
/// edge pixels suggest, but a grid-aligned edge is known only to the pixel it crosses, and the render clips
/// that pixel or not by the radiance the fits gave it (real room09: a window 8 % dimmer than the truth's still
/// clipped a ring of 198 pixels the photo does not). `inst` (at the camera's size), where given, leaves out
/// furniture and other instances' pixels, and for a window all but its mask's and 2 pixels round it. Lights
/// whose rectangle is not in front of the camera, or (8-bit photo) dimmer than its white, stay.
pub fn fit_light_outlines(
    scene: &mut Scene,
    photo: &[f32],
    inst: Option<&Instances>,
    margin: f32,
) -> Vec<LightOutline> {
    let cam = scene.camera.clone();
    let ldr = is_low_dynamic_range(photo);
    let mut out = vec![];
    for o in scene.objects.iter_mut() {
        if !(is_visible_light(&o.name) || is_edge_ceiling_light(&o.name)) {
            continue;
        }
        let (Some(e), Some(part)) = (o.emitter.as_ref(), o.parts.first()) else { continue };
        let (lo, hi) = part
            .positions
            .iter()
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| (a.min(*p), b.max(*p)));
        // A flat rectangle in its own x-y plane (as psdr makes lights), not necessarily centred.
        let (w0, h0) = (hi.x - lo.x, hi.y - lo.y);
        if !(w0 > 0.0 && h0 > 0.0) || (hi.z - lo.z).abs() > 1e-4 * w0.max(h0) {
            continue;
        }
        let (sx, sy) = (o.pose.scale.x, o.pose.scale.y);
        let start = PlaneRect {
            origin: o.pose.translation + o.pose.rotation * Vec3::Z * (lo.z * o.pose.scale.z),
            a: o.pose.rotation * Vec3::X,
            b: o.pose.rotation * Vec3::Y,
            u: [lo.x * sx, hi.x * sx],
            v: [lo.y * sy, hi.y * sy],
        };
        let own = o.name.strip_prefix("light_window_").and_then(|id| id.parse::<u16>().ok());
        let usable = |p: usize| match (inst, own) {
            (Some(i), Some(id)) => near_window(i, id, p),
            (Some(i), None) => i.ids[p] == 0 || is_room_surface(i, i.ids[p]),
            (None, _) => true,
        };
        // A light the fits left dimmer than the photo's white cannot clip its edge pixels as the photo does:
        // its outline says nothing (real room04's window, lit 0.2, was pulled 2 pixels out).
        let brightness = e.radiance.max_element();
        if ldr && brightness < 1.0 {
            continue;
        }
        let Some(fit) = refine_outline(&cam, photo, &usable, start, margin, ldr, Some(brightness)) else { continue };
        let r = fit.rect;
        let footprint = |axis: Vec3, d: f32| {
            let at = |x: Vec3| project(&cam, x);
            match (at(o.pose.translation), at(o.pose.translation + axis * 0.01)) {
                (Some(p), Some(q)) => d.abs() * (q - p).length() / 0.01,
                _ => 0.0,
            }
        };
        let moved_px = (0..2)
            .map(|j| footprint(r.a, r.u[j] - start.u[j]).max(footprint(r.b, r.v[j] - start.v[j])))
            .fold(0.0, f32::max);
        // The new scale along x and y, and the translation that puts the mesh's corner (lo) at the fit's.
        let (nx, ny) = ((r.u[1] - r.u[0]) / w0, (r.v[1] - r.v[0]) / h0);
        o.pose.translation += r.a * (r.u[0] - lo.x * nx) + r.b * (r.v[0] - lo.y * ny);
        (o.pose.scale.x, o.pose.scale.y) = (nx, ny);
        out.push(LightOutline {
            name: o.name.clone(),
            moved_px,
            error_before: fit.error_before,
            error_after: fit.error_after,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pixel_covered_by_a_quad_is_its_overlap_area() {
        let quad = [Vec2::new(0.5, 0.25), Vec2::new(3.0, 0.25), Vec2::new(3.0, 3.0), Vec2::new(0.5, 3.0)];
        assert!((covered(&quad, 0.0, 0.0) - 0.5 * 0.75).abs() < 1e-6);
        assert!((covered(&quad, 1.0, 1.0) - 1.0).abs() < 1e-6);
        assert_eq!(covered(&quad, 4.0, 1.0), 0.0);
        // The diamond |x - 2| + |y - 2| <= 1 covers the half of pixel (1, 1) where x + y >= 3.
        let diamond = [Vec2::new(2.0, 1.0), Vec2::new(3.0, 2.0), Vec2::new(2.0, 3.0), Vec2::new(1.0, 2.0)];
        assert!((covered(&diamond, 1.0, 1.0) - 0.5).abs() < 1e-6);
    }

    /// A window light 1.5 pixels too small and off-centre in its mesh (not as psdr makes them, as a scene
    /// file may) is refitted by `fit_light_outlines` at its own radiance to the photo's: its world corners end
    /// within half a pixel of the true ones (the camera is rolled, so the photo pins them), its mesh untouched.
    #[test]
    fn a_window_light_is_refitted_at_its_radiance() {
        use crate::scene::{rectangle_mesh, Emitter, Object, Pose};
        use glam::Quat;
        let (w, h) = (160usize, 120usize);
        let cam = Camera::look_at(
            Vec3::new(0.3, 1.4, 3.0),
            Vec3::new(-0.4, 1.2, 0.0),
            Vec3::new(0.15, 1.0, 0.0),
            60.0,
            w as u32,
            h as u32,
        );
        let truth = PlaneRect { origin: Vec3::ZERO, a: Vec3::X, b: Vec3::Y, u: [-0.83, -0.11], v: [0.97, 1.71] };
        let all: Vec<usize> = (0..w * h).collect();
        let c = coverage(&cam, &truth, &all, w).unwrap();
        let (light, wall) = (6.0f32, 0.3f32);
        let photo: Vec<f32> = c.iter().flat_map(|c| [(c * light + (1.0 - c) * wall).min(1.0); 3]).collect();
        let footprint = 3.0 * 2.0 * (30.0f32).to_radians().tan() / h as f32;
        // The mesh spans x in [0, 0.6], y in [-0.2, 0.5]; its pose puts it 1.5 pixels inside the truth.
        let mut part = rectangle_mesh(0.6, 0.7);
        part.positions.iter_mut().for_each(|p| *p += Vec3::new(0.3, 0.15, 0.0));
        let k = 1.5 * footprint;
        let scale = Vec3::new((0.72 - 2.0 * k) / 0.6, (0.74 - 2.0 * k) / 0.7, 1.0);
        let at = Vec3::new(-0.83 + k, 0.97 + k, 0.0) - Vec3::new(0.0, -0.2 * scale.y, 0.0);
        let mut scene = Scene::empty(cam);
        scene.objects.push(Object {
            name: "light_window_3".into(),
            parts: vec![part],
            pose: Pose { translation: at, rotation: Quat::IDENTITY, scale },
            emitter: Some(Emitter::uniform(Vec3::new(5.0, light, 4.0), false)),
        });
        let fitted = fit_light_outlines(&mut scene, &photo, None, 2.0);
        assert_eq!(fitted.len(), 1, "{fitted:?}");
        let o = &scene.objects[0];
        let m = o.pose.matrix();
        let corners: Vec<Vec3> = o.parts[0].positions.iter().map(|p| m.transform_point3(*p)).collect();
        let (lo, hi) =
            corners.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| (a.min(*p), b.max(*p)));
        for (got, want) in [lo.x, hi.x, lo.y, hi.y].iter().zip([-0.83, -0.11, 0.97, 1.71]) {
            assert!((got - want).abs() < 0.5 * footprint, "edge {got} for {want}: {fitted:?}");
        }
        assert!(fitted[0].moved_px > 1.0 && fitted[0].error_after < 0.01 * fitted[0].error_before, "{fitted:?}");
    }

    /// The photo of a bright rectangle on a wall, drawn with each pixel's exact covered area and clipped at 1,
    /// gives its outline back from a start two pixels off on every edge: to a tenth of a pixel where its edges
    /// cross the pixel grid at an angle (a camera rolled 8 degrees), and where they run along it (no roll), to
    /// within the pixel its edge crosses, the photo's pixels reproduced all the same: there the photo says only
    /// that a pixel is covered enough to clip.
    #[test]
    fn a_clipped_window_outline_is_found_from_its_pixels() {
        let (w, h) = (160usize, 120usize);
        let truth = PlaneRect { origin: Vec3::ZERO, a: Vec3::X, b: Vec3::Y, u: [-0.83, -0.11], v: [0.97, 1.71] };
        let footprint = 3.0 * 2.0 * (30.0f32).to_radians().tan() / h as f32;
        let start = PlaneRect {
            u: [truth.u[0] + 2.0 * footprint, truth.u[1] - 2.0 * footprint],
            v: [truth.v[0] - 2.0 * footprint, truth.v[1] + 2.0 * footprint],
            ..truth
        };
        for (roll, tolerance) in [(0.15, 0.1), (0.0, 1.0)] {
            let up = Vec3::new(roll, 1.0, 0.0);
            let cam =
                Camera::look_at(Vec3::new(0.3, 1.4, 3.0), Vec3::new(-0.4, 1.2, 0.0), up, 60.0, w as u32, h as u32);
            let all: Vec<usize> = (0..w * h).collect();
            let c = coverage(&cam, &truth, &all, w).unwrap();
            let (light, wall) = (9.0f32, 0.35f32);
            let photo: Vec<f32> =
                c.iter().flat_map(|c| [0.9, 1.0, 0.8].map(|k| (k * (c * light + (1.0 - c) * wall)).min(1.0))).collect();
            let fit = refine_outline(&cam, &photo, &|_| true, start, 4.0, true, None).unwrap();
            eprintln!("roll {roll}: {fit:?}");
            for (got, want) in fit.rect.u.iter().chain(&fit.rect.v).zip(truth.u.iter().chain(&truth.v)) {
                let off = (got - want).abs() / footprint;
                assert!(off < tolerance, "roll {roll}: edge {got} for {want}, {off} pixels off");
            }
            assert!(fit.error_after < 1e-3 * fit.error_before, "{} -> {}", fit.error_before, fit.error_after);
        }
    }
}
