//! Whether two scenes (or two meshes) are the same up to what a file round trip may change: the order vertices are
//! numbered in (a reader numbers them by first use) and float rounding of normals (renormalised on load). A
//! stage's scene must come back from its file this way (`RunContext::end_stage`), and `psdr db check` asks it
//! of every model of a database.

use super::{Color, MeshPart, Scalar, Scene};
use glam::{Vec2, Vec3};

/// Ok when `b` has `a`'s triangles in the same order, corner by corner, with the same positions (within `tol`
/// of the part's size), uvs and normals (within 1e-5); else what differs first.
pub fn same_triangles(a: &MeshPart, b: &MeshPart, tol: f32) -> Result<(), String> {
    if a.indices.len() != b.indices.len() {
        return Err(format!("{} triangles became {}", a.indices.len(), b.indices.len()));
    }
    if (a.uvs.is_some(), a.normals.is_some()) != (b.uvs.is_some(), b.normals.is_some()) {
        let has = |p: &MeshPart| format!("uvs {}, normals {}", p.uvs.is_some(), p.normals.is_some());
        return Err(format!("attributes changed: {} became {}", has(a), has(b)));
    }
    let extent = a.positions.iter().fold(0.0f32, |m, p| m.max(p.abs().max_element())).max(1e-6);
    let near3 = |x: Vec3, y: Vec3, t: f32| (x - y).abs().max_element() <= t;
    let near2 = |x: Vec2, y: Vec2, t: f32| (x - y).abs().max_element() <= t * x.abs().max_element().max(1.0);
    for (k, (ta, tb)) in a.indices.iter().zip(&b.indices).enumerate() {
        for c in 0..3 {
            let (i, j) = (ta[c] as usize, tb[c] as usize);
            let (pa, pb) = (a.positions[i], b.positions[j]);
            if !near3(pa, pb, tol * extent) {
                return Err(format!("triangle {k} corner {c}: position {pa} became {pb}"));
            }
            if let (Some(ua), Some(ub)) = (&a.uvs, &b.uvs) {
                if !near2(ua[i], ub[j], 1e-6) {
                    return Err(format!("triangle {k} corner {c}: uv {} became {}", ua[i], ub[j]));
                }
            }
            if let (Some(na), Some(nb)) = (&a.normals, &b.normals) {
                if !near3(na[i], nb[j], 1e-5) {
                    return Err(format!("triangle {k} corner {c}: normal {} became {}", na[i], nb[j]));
                }
            }
        }
    }
    Ok(())
}

/// Ok when every part of `a` with triangles is in `b` in the same order, with the same triangles, and the same
/// material name when `material_names` are given (`a`'s and `b`'s); `a`'s parts without triangles are not
/// written.
pub fn same_parts(
    a: &[MeshPart],
    b: &[MeshPart],
    tol: f32,
    material_names: Option<(&[String], &[String])>,
) -> Result<(), String> {
    let kept: Vec<&MeshPart> = a.iter().filter(|p| !p.indices.is_empty()).collect();
    if kept.len() != b.len() {
        let names = |ps: &mut dyn Iterator<Item = &MeshPart>| ps.map(|p| p.name.clone()).collect::<Vec<_>>();
        return Err(format!(
            "{} parts {:?} became {} {:?}",
            kept.len(),
            names(&mut kept.iter().copied()),
            b.len(),
            names(&mut b.iter())
        ));
    }
    for (k, (pa, pb)) in kept.iter().zip(b).enumerate() {
        same_triangles(pa, pb, tol).map_err(|e| format!("part {k} ('{}'): {e}", pa.name))?;
        if let Some((ma, mb)) = material_names {
            let (na, nb) = (&ma[pa.material], &mb[pb.material]);
            if na != nb {
                return Err(format!("part {k} ('{}'): material '{na}' became '{nb}'", pa.name));
            }
        }
    }
    Ok(())
}

/// Ok when `b` is `a` read back from its file: the same camera, objects (names, poses, emitters, parts with
/// their materials) and materials (constants, texture sizes, uv transforms, procedural graphs).
pub fn same_scene(a: &Scene, b: &Scene) -> Result<(), String> {
    let close = |x: f32, y: f32| (x - y).abs() <= 1e-5 * x.abs().max(y.abs()).max(1.0);
    let close3 = |x: Vec3, y: Vec3| (0..3).all(|k| close(x[k], y[k]));
    let (ca, cb) = (&a.camera, &b.camera);
    if (ca.width, ca.height) != (cb.width, cb.height)
        || !close(ca.fov_y_deg, cb.fov_y_deg)
        || !close3(ca.origin, cb.origin)
        || !close3(ca.forward, cb.forward)
    {
        return Err("the camera changed".into());
    }
    if a.objects.len() != b.objects.len() || a.materials.len() != b.materials.len() {
        return Err(format!(
            "{} objects and {} materials became {} and {}",
            a.objects.len(),
            a.materials.len(),
            b.objects.len(),
            b.materials.len()
        ));
    }
    let names = |s: &Scene| s.materials.iter().map(|m| m.name.clone()).collect::<Vec<_>>();
    let (na, nb) = (names(a), names(b));
    for (oa, ob) in a.objects.iter().zip(&b.objects) {
        let what = |e: String| format!("object '{}': {e}", oa.name);
        if oa.name != ob.name {
            return Err(what(format!("renamed '{}'", ob.name)));
        }
        let (pa, pb) = (&oa.pose, &ob.pose);
        if !close3(pa.translation, pb.translation)
            || !close3(pa.scale, pb.scale)
            || pa.rotation.dot(pb.rotation).abs() < 1.0 - 1e-6
        {
            return Err(what(format!("pose {pa:?} became {pb:?}")));
        }
        if oa.emitter.map(|e| (e.two_sided, e.radiance.to_array(), e.sky_gradient.to_array()))
            != ob.emitter.map(|e| (e.two_sided, e.radiance.to_array(), e.sky_gradient.to_array()))
        {
            return Err(what("emitter changed".into()));
        }
        same_parts(&oa.parts, &ob.parts, 1e-6, Some((&na, &nb))).map_err(what)?;
    }
    for (ma, mb) in a.materials.iter().zip(&b.materials) {
        let what = |e: &str| Err(format!("material '{}': {e} changed", ma.name));
        if ma.name != mb.name {
            return what("name");
        }
        let texture_size = |s: &Scene, t: usize| (s.textures[t].width, s.textures[t].height);
        let colour_same = match (ma.albedo, mb.albedo) {
            (Color::Constant(x), Color::Constant(y)) => close3(x, y),
            (Color::Texture(x), Color::Texture(y)) => texture_size(a, x) == texture_size(b, y),
            _ => false,
        };
        let scalar_same = |x: Scalar, y: Scalar| match (x, y) {
            (Scalar::Constant(x), Scalar::Constant(y)) => close(x, y),
            (Scalar::Texture(x), Scalar::Texture(y)) => texture_size(a, x) == texture_size(b, y),
            _ => false,
        };
        if !colour_same {
            return what("albedo");
        }
        if !scalar_same(ma.roughness, mb.roughness) || !scalar_same(ma.specular, mb.specular) {
            return what("roughness or specular");
        }
        if ma.normal_map.is_some() != mb.normal_map.is_some() {
            return what("normal map");
        }
        let (ua, ub) = (ma.uv_transform, mb.uv_transform);
        if !close(ua.rotation_deg, ub.rotation_deg) || (ua.scale - ub.scale).abs().max_element() > 1e-5 {
            return what("uv transform");
        }
        // The graph's name may be a path the file writes relative to itself: its parameters say enough.
        let graph = |m: &super::Material| m.procedural.as_ref().map(|p| (p.params.clone(), p.size, p.tint.to_array()));
        if graph(ma) != graph(mb) {
            return what("procedural graph");
        }
    }
    Ok(())
}
