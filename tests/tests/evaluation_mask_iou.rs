//! The evaluation's per-object mask IoU (`stages::mask_ious`, result.json's `evaluation.mask_iou`): each fitted
//! object named CLASS_ID rendered at the photo's size against instance ID of the photo's masks. On the known
//! geometry room (a cabinet and a table named after their instances): the truth as the fit gives IoU 1 for
//! both; the table moved by half its width along its front gives about 1/3 (two equal rectangles overlapping
//! by half: 1 / (1 + 2); measured 0.37, its top and sides seen in perspective), and exactly what counting the
//! pixels in the test gives; turned by 90 degrees in place, 0.65; a table split into two instances counts both
//! when the object stage merged them, about half without (0.49); a name whose id is no instance is left out.

use glam::{Quat, Vec3};
use psdr::vision::{canonical_class, Instance, Instances};
use psdr_tests::known_geometry::{id_frame, instances_of, truth_room};

fn iou_of(v: &serde_json::Value, name: &str) -> Option<f64> {
    v["objects"].as_array()?.iter().find(|o| o["name"] == name)?["iou"].as_f64()
}

#[test]
fn mask_iou_is_one_for_the_truth_and_drops_for_a_moved_object() {
    let (truth, ids) = truth_room();
    let tf = id_frame(&truth);
    let inst = instances_of(&truth, &tf, &ids);
    let (w, h) = (truth.camera.width as usize, truth.camera.height as usize);
    let table_px = inst.instances.iter().find(|i| i.id == 8).unwrap().pixels;
    assert!(table_px > 300, "the table shows {table_px} pixels");

    // The truth as the fit: every furniture object covers exactly its instance.
    let perfect = psdr::stages::evaluate(&truth, &truth, &[], &tf, &tf, &tf.radiance, Some((&inst, &[])));
    let m = &perfect["mask_iou"];
    assert_eq!(m["objects"].as_array().unwrap().len(), 2, "{m}");
    for name in ["cabinet_7", "table_8"] {
        assert!(iou_of(m, name).unwrap() > 0.999, "{name}: {m}");
    }
    assert!(m["median"].as_f64().unwrap() > 0.999 && m["worst"].as_f64().unwrap() > 0.999, "{m}");

    // The table moved by half its width (1.2 m) along its own x axis.
    let mut moved = truth.clone();
    let k = moved.object_index("table_8").unwrap();
    let along = moved.objects[k].pose.rotation * Vec3::X;
    moved.objects[k].pose.translation += 0.6 * along;
    let mf = id_frame(&moved);
    let v = psdr::stages::mask_ious(&moved, &mf, &inst, &[]).unwrap();
    let iou = iou_of(&v, "table_8").unwrap();
    // Counted here: pixels of the moved table and of instance 8.
    let (mut both, mut either) = (0, 0);
    for p in 0..w * h {
        let (a, b) = (mf.object_id[p] == k as u32, inst.ids[p] == 8);
        both += usize::from(a && b);
        either += usize::from(a || b);
    }
    assert!((iou - both as f64 / either as f64).abs() < 1e-12, "{iou} against {both}/{either}");
    eprintln!("table moved by half its width: IoU {iou:.3}");
    assert!((0.2..0.5).contains(&iou), "half a width off: IoU {iou} (about 1/3 expected)");
    assert!(iou_of(&v, "cabinet_7").unwrap() > 0.999, "{v}");
    // Median of two is the lower: the moved table's.
    assert_eq!(v["median"].as_f64(), Some(iou));
    assert_eq!(v["worst"].as_f64(), Some(iou));

    // Turned by 90 degrees in place: its outline changes, its centre does not.
    let mut turned = truth.clone();
    turned.objects[k].pose.rotation = Quat::from_rotation_y(90f32.to_radians()) * turned.objects[k].pose.rotation;
    let v = psdr::stages::mask_ious(&turned, &id_frame(&turned), &inst, &[]).unwrap();
    let turned_iou = iou_of(&v, "table_8").unwrap();
    eprintln!("table turned by 90 degrees: IoU {turned_iou:.3}");
    assert!(turned_iou < 0.9, "{v}");

    // The table split into two instances (8 on the left of its middle column, 9 on the right).
    let mut split = inst.clone();
    let cols: Vec<usize> = (0..w * h).filter(|&p| inst.ids[p] == 8).map(|p| p % w).collect();
    let mid = (cols.iter().min().unwrap() + cols.iter().max().unwrap()) / 2;
    for p in 0..w * h {
        if split.ids[p] == 8 && p % w > mid {
            split.ids[p] = 9;
        }
    }
    let right = split.ids.iter().filter(|&&v| v == 9).count();
    let kind = canonical_class("table").1;
    split.instances.push(Instance { id: 9, label: None, class: "table".into(), kind, pixels: right });
    let merged = vec![("table_8".to_string(), vec![9u16])];
    let v = psdr::stages::mask_ious(&truth, &tf, &split, &merged).unwrap();
    assert!(iou_of(&v, "table_8").unwrap() > 0.999, "merged pieces count: {v}");
    let v = psdr::stages::mask_ious(&truth, &tf, &split, &[]).unwrap();
    let half = iou_of(&v, "table_8").unwrap();
    eprintln!("one piece of a split table: IoU {half:.3}");
    assert!((0.2..0.8).contains(&half), "one piece of two: {half}");

    // A name whose id is no instance, and lights, are left out; a frame of another size gives none.
    let mut renamed = truth.clone();
    renamed.objects[k].name = "table_99".into();
    let v = psdr::stages::mask_ious(&renamed, &tf, &inst, &[]).unwrap();
    assert_eq!(v["objects"].as_array().unwrap().len(), 1, "{v}");
    let small = Instances { width: w / 2, height: h / 2, ids: vec![0; w * h / 4], instances: vec![] };
    assert!(psdr::stages::mask_ious(&truth, &tf, &small, &[]).is_none());
}
