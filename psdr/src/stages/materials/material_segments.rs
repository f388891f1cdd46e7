//! Which photo pixels show which material (PSDR-Room: a material part's crop lies in "the intersection of the
//! part's rendered mask and the object's segmentation mask"): a pixel belongs to material m when the fitted
//! scene's primary ray there hits a triangle of material m, and the segmentation agrees that the pixel shows
//! the object it hits: the floor, ceiling and walls (objects `floor`, `ceiling`, `wall_*`) by class, furniture
//! (objects named `CLASS_ID`) by instance id. Lights, windows and objects named otherwise give no pixels; so do
//! a part's edges where the fitted pose and the photo disagree. Materials showing on fewer than `min_pixels`
//! pixels are left out (a crop of three pixels fits noise).

use crate::error::{Error, Result};
use crate::render::bvh::trace_closest;
use crate::render::camera::camera_ray;
use crate::render::SceneData;
use crate::scene::Scene;
use crate::vision::Instances;
use glam::Vec3;
use rayon::prelude::*;

/// What the segmentation must say at a pixel for the object hit there to count.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Expect<'a> {
    Class(&'a str),
    Instance(u16),
    Nothing,
}

pub(super) fn expectation(name: &str) -> Expect<'_> {
    match name {
        "floor" => Expect::Class("floor"),
        "ceiling" => Expect::Class("ceiling"),
        n if n.starts_with("wall_") => Expect::Class("wall"),
        n if n.starts_with("light_") || n.contains("window") => Expect::Nothing,
        n => n.rsplit('_').next().and_then(|id| id.parse().ok()).map_or(Expect::Nothing, Expect::Instance),
    }
}

/// Per photo pixel, what the fitted scene's primary ray hits there: the object's index and the material's, or
/// None where it leaves the scene.
pub(super) fn primary_hits(scene: &Scene) -> Result<Vec<Option<(u32, u32)>>> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let d = SceneData::build(scene)?;
    let origin = Vec3::from(d.camera.origin);
    Ok((0..w * h)
        .into_par_iter()
        .map(|p| {
            let dir = camera_ray(&d.camera, (p % w) as f32 + 0.5, (p / w) as f32 + 0.5);
            let hit = trace_closest(&d.nodes, &d.triangles, origin, dir, f32::INFINITY)?;
            let tri = &d.triangles[hit.triangle as usize];
            Some((tri.object, tri.material))
        })
        .collect())
}

pub(super) fn check_size(scene: &Scene, inst: &Instances, what: &str) -> Result<()> {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    if (inst.width, inst.height) != (w, h) {
        return Err(Error::Invalid(format!(
            "{what}: the masks are {}x{}, the scene's camera renders {w}x{h}",
            inst.width, inst.height
        )));
    }
    Ok(())
}

/// Per material (scene order) with at least `min_pixels` pixels: its name and its mask (1 inside).
pub fn material_segments(scene: &Scene, inst: &Instances, min_pixels: usize) -> Result<Vec<(String, Vec<f32>)>> {
    check_size(scene, inst, "material segments")?;
    let expect: Vec<Expect> = scene.objects.iter().map(|o| expectation(&o.name)).collect();
    let class_of = |id: u16| inst.instances.iter().find(|i| i.id == id).map(|i| i.class.as_str());
    // The material each pixel shows, where the segmentation agrees.
    let shown: Vec<Option<u32>> = primary_hits(scene)?
        .iter()
        .zip(&inst.ids)
        .map(|(hit, &id)| {
            let (object, material) = (*hit)?;
            let agrees = match expect.get(object as usize)? {
                Expect::Class(c) => class_of(id) == Some(*c),
                Expect::Instance(i) => id == *i,
                Expect::Nothing => false,
            };
            agrees.then_some(material)
        })
        .collect();
    let mut out = vec![];
    for (m, mat) in scene.materials.iter().enumerate() {
        let mask: Vec<f32> = shown.iter().map(|s| f32::from(u8::from(*s == Some(m as u32)))).collect();
        if mask.iter().sum::<f32>() as usize >= min_pixels.max(1) {
            out.push((mat.name.clone(), mask));
        }
    }
    Ok(out)
}
