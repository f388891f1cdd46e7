//! Where the fitted scene and the segmentation agree (`stages::geometry_agreement`, the photometric fits'
//! `agreement`), on the known-geometry room (a cabinet and a table named after their instances):
//! - the truth as the fit agrees everywhere;
//! - with the table moved by half its width, the pixels that disagree are exactly those where the moved
//!   scene's object-id render (another path than the function's own ray casts) shows another surface or
//!   object than the photo's segmentation says: the table's old and new outlines, nothing else;
//! - a pixel the segmentation labels a window agrees where the scene shows a room surface there (a window may
//!   be drawn as the wall or as a light) and disagrees where it puts furniture before it; a pixel whose ray
//!   hits a light agrees;
//! - masks of another size are an error naming both sizes.

use glam::Vec3;
use psdr::scene::Scene;
use psdr::stages::geometry_agreement;
use psdr::vision::Instances;
use psdr_tests::known_geometry::{id_frame, instances_of, truth_room};

/// What a pixel shows, in the segmentation's terms: room surfaces by class, furniture by instance id, lights
/// nothing.
fn shown(scene: &Scene, object: u32, ids: &[(u16, &str)]) -> Option<String> {
    let name = &scene.objects.get(object as usize)?.name;
    if name.starts_with("light") {
        return None;
    }
    let id = ids.iter().find(|(_, n)| n == name)?.0;
    Some(match name.split('_').next()? {
        c @ ("floor" | "ceiling" | "wall") => c.to_string(),
        _ => id.to_string(),
    })
}

fn said(inst: &Instances, p: usize) -> Option<String> {
    let i = inst.instances.iter().find(|i| i.id == inst.ids[p])?;
    match i.class.as_str() {
        "window" => None,
        c @ ("floor" | "ceiling" | "wall") => Some(c.to_string()),
        _ => Some(i.id.to_string()),
    }
}

#[test]
fn the_fits_leave_out_exactly_where_the_scene_shows_another_surface_than_the_photo() {
    let (truth, ids) = truth_room();
    let tf = id_frame(&truth);
    let inst = instances_of(&truth, &tf, &ids);
    let (w, h) = (truth.camera.width as usize, truth.camera.height as usize);

    let same = geometry_agreement(&truth, &inst).unwrap();
    assert_eq!(same.len(), w * h);
    assert!(
        same.iter().all(|&v| v == 1.0),
        "the truth disagrees on {} pixels",
        same.iter().filter(|&&v| v == 0.0).count()
    );

    // The table moved by half its width along its own x axis.
    let mut moved = truth.clone();
    let k = moved.object_index("table_8").unwrap();
    let along = moved.objects[k].pose.rotation * Vec3::X;
    moved.objects[k].pose.translation += 0.6 * along;
    let mf = id_frame(&moved);
    let agree = geometry_agreement(&moved, &inst).unwrap();
    let expected: Vec<f32> = (0..w * h)
        .map(|p| {
            let (r, s) = (shown(&moved, mf.object_id[p], &ids), said(&inst, p));
            f32::from(u8::from(r.is_none() || s.is_none() || r == s))
        })
        .collect();
    let differ = (0..w * h).filter(|&p| agree[p] != expected[p]).count();
    let off = agree.iter().filter(|&&v| v == 0.0).count();
    eprintln!("table moved by half its width: {off} pixels disagree, {differ} differ from the id render");
    // The function casts a ray through each pixel's centre; the id render's one sample may land elsewhere in
    // the pixel, so a few pixels along outlines can differ.
    assert!(differ * 50 <= off, "{differ} of {off}");
    assert!(off > 200, "the moved table must disagree somewhere: {off}");
    let table = |p: usize| inst.ids[p] == 8 || mf.object_id[p] == k as u32;
    let elsewhere = (0..w * h).filter(|&p| agree[p] == 0.0 && !table(p)).count();
    assert_eq!(elsewhere, 0, "disagreement outside the table's old and new outlines");

    // The table's instance labelled a window: its pixels agree where the scene shows a room surface there, and
    // disagree where it puts furniture (the moved table) before it.
    let mut window = inst.clone();
    window.instances.iter_mut().filter(|i| i.id == 8).for_each(|i| i.class = "window".into());
    let agree = geometry_agreement(&moved, &window).unwrap();
    let (mut behind, mut open) = (0, 0);
    for p in (0..w * h).filter(|&p| inst.ids[p] == 8) {
        let furniture = shown(&moved, mf.object_id[p], &ids).is_some_and(|s| s.parse::<u16>().is_ok());
        let room = shown(&moved, mf.object_id[p], &ids).is_some_and(|s| s.parse::<u16>().is_err());
        behind += usize::from(furniture && agree[p] == 0.0);
        open += usize::from(room && agree[p] == 1.0);
        // Behind furniture it disagrees; on a room surface it agrees.
        if furniture || room {
            assert_eq!(agree[p], f32::from(u8::from(room)), "pixel {p}");
        }
    }
    assert!(behind > 50 && open > 50, "window pixels behind furniture {behind}, on the room {open}");

    // Lights: the photo's pixels under a ceiling light agree with it whatever the segmentation says there.
    let mut lit = truth.clone();
    let l = lit.object_index("light_a").unwrap();
    lit.objects[l].pose.translation.y = 1.0; // hung low, in view
    let lf = id_frame(&lit);
    let agree = geometry_agreement(&lit, &inst).unwrap();
    let in_view = (0..w * h).filter(|&p| lf.object_id[p] == l as u32).collect::<Vec<_>>();
    assert!(in_view.len() > 50, "the lowered light is in view on {} pixels", in_view.len());
    assert!(in_view.iter().all(|&p| agree[p] == 1.0));

    let small = Instances { width: w / 2, height: h / 2, ids: vec![0; w * h / 4], instances: vec![] };
    let e = geometry_agreement(&truth, &small).unwrap_err().to_string();
    assert!(e.contains(&format!("{}x{}", w / 2, h / 2)) && e.contains(&format!("{w}x{h}")), "{e}");
}
