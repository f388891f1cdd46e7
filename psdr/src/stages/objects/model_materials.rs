//! A retrieved model's own colouring of its parts (`scene::ModelLook`): the colour its MTL file gives each
//! material group (Kd), times the mean of its albedo picture (map_Kd) where it has one, and that picture's path.
//! The fits start every part grey and fit the ones the photo shows; `stages::object_pictures` then gives the
//! unseen ones this colour (the model's author coloured them; grey was a guess) and decides whether each seen
//! part's picture goes back on.

use crate::scene::{load_obj, ModelLook, Texture, TextureEncoding};
use crate::stages::materials::ALBEDO_RANGE;
use glam::Vec3;
use std::collections::HashMap;
use std::path::Path;

/// Per material group name (the parts' names), the model's own colour and picture. A model without an MTL file,
/// or one that does not read, gives none: its parts start grey.
pub fn model_looks(model: &Path) -> HashMap<String, ModelLook> {
    let Ok(mesh) = load_obj(model) else { return HashMap::new() };
    let dir = model.parent().unwrap_or(Path::new(""));
    let mut out = HashMap::new();
    for mtl in mesh.part_mtl.into_iter().flatten() {
        let picture = mtl.diffuse_texture.as_ref().map(|t| dir.join(t)).and_then(|p| {
            let tex = Texture::load(&p, TextureEncoding::Srgb, 3).ok()?;
            Some((p, picture_mean(&tex)))
        });
        // An MTL without Kd reads as white under its picture (the renderer's convention for map_Kd), else grey.
        let kd = mtl.diffuse.unwrap_or(if picture.is_some() { Vec3::ONE } else { Vec3::splat(0.5) });
        let albedo = picture.as_ref().map_or(kd, |(_, mean)| kd * *mean);
        let albedo = albedo.clamp(Vec3::splat(ALBEDO_RANGE.0), Vec3::splat(ALBEDO_RANGE.1));
        out.insert(mtl.name.clone(), ModelLook { albedo, picture: picture.map(|(p, _)| p) });
    }
    out
}

/// A picture's mean linear colour.
pub(crate) fn picture_mean(tex: &Texture) -> Vec3 {
    let n = (tex.width * tex.height).max(1) as f32;
    let sum = tex.texels.chunks(3).fold(Vec3::ZERO, |s, c| s + Vec3::new(c[0], c[1], c[2]));
    sum / n
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model with three groups: one coloured by Kd alone, one by a picture under a Kd, one whose picture is
    /// missing. The first looks its Kd, the second Kd times the picture's linear mean, with the picture's path,
    /// the third its Kd and no picture.
    #[test]
    fn a_models_look_is_its_mtl_colours_and_pictures() {
        let dir = std::env::temp_dir().join(format!("psdr-model-materials-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // A 2x1 picture: sRGB 255 and 0 in red, 188 (0.5 linear) in green and blue.
        let mut img = image::RgbImage::new(2, 1);
        img.put_pixel(0, 0, image::Rgb([255, 188, 188]));
        img.put_pixel(1, 0, image::Rgb([0, 188, 188]));
        img.save(dir.join("cloth.png")).unwrap();
        std::fs::write(
            dir.join("m.mtl"),
            "newmtl paint\nKd 0.2 0.4 0.6\nnewmtl cloth\nKd 0.8 0.8 0.8\nmap_Kd cloth.png\nnewmtl gone\nKd 0.3 0.3 0.3\nmap_Kd missing.png\n",
        )
        .unwrap();
        let tri = |m: &str, o: usize| format!("usemtl {m}\nf {} {} {}\n", o + 1, o + 2, o + 3);
        let obj = format!(
            "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv 3 0 0\nv 2 1 0\nv 4 0 0\nv 5 0 0\nv 4 1 0\n{}{}{}",
            tri("paint", 0),
            tri("cloth", 3),
            tri("gone", 6)
        );
        std::fs::write(dir.join("m.obj"), obj).unwrap();
        let priors = model_looks(&dir.join("m.obj"));
        let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 2e-3;
        assert!(close(priors["paint"].albedo, Vec3::new(0.2, 0.4, 0.6)) && priors["paint"].picture.is_none());
        let green = crate::scene::srgb_to_linear(188.0 / 255.0);
        assert!(close(priors["cloth"].albedo, 0.8 * Vec3::new(0.5, green, green)), "{:?}", priors["cloth"]);
        assert_eq!(priors["cloth"].picture.as_deref(), Some(dir.join("cloth.png").as_path()));
        assert!(close(priors["gone"].albedo, Vec3::splat(0.3)) && priors["gone"].picture.is_none());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
