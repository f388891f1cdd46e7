//! The real-furniture evaluation rooms (`psdr_tests::real_rooms`, what bench_real_rooms runs), drawn as the
//! benchmark draws them (its seed, 512 x 384) but only the first four, without their photos: 4-7 objects of
//! installed Sweet Home 3D models each, inside the room's walls and apart from each other, each named CLASS_ID
//! after an instance of the masks labelled with its class and showing at least 300 pixels; 1-3 ceiling lights;
//! rooms of 3.5-6.5 m, a camera at 1.3-1.7 m with a fov of 50-70 degrees; the same rooms again from the same
//! seed. A held-out database lists every installed model but the room's. Skipped without the libraries.

use psdr::db::{default_db, ModelSet};
use psdr_tests::real_rooms::{build_scene, generate_rooms, held_out_db, quads_overlap, MIN_PIXELS_512};
use std::path::Path;

#[test]
fn real_rooms_are_furnished_as_specified_and_held_out_databases_leave_their_models_out() {
    if !Path::new(psdr::db::SWEET_HOME_3D_FURNITURE).is_dir() {
        eprintln!("skipped: the Sweet Home 3D furniture libraries are not installed");
        return;
    }
    let db = default_db(None, &Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/models")).unwrap();
    let (w, h) = (512, 384);
    let rooms = generate_rooms(&db, 4, 2027, w, h).unwrap();
    let again = generate_rooms(&db, 4, 2027, w, h).unwrap();
    for (r, a) in rooms.iter().zip(&again) {
        let same = r.items.len() == a.items.len()
            && r.items
                .iter()
                .zip(&a.items)
                .all(|(x, y)| x.model.path == y.model.path && x.at == y.at && x.yaw == y.yaw);
        assert!(same, "{}: another seed's furniture", r.name);
    }
    for r in &rooms {
        let s = &r.spec;
        assert!((3.5..=6.5).contains(&s.w) && (3.5..=6.5).contains(&s.d), "{}: {} x {} m", r.name, s.w, s.d);
        assert!((1.3..=1.7).contains(&s.cam.y) && (50.0..=70.0).contains(&s.fov), "{}: {s:?}", r.name);
        assert!((4..=7).contains(&r.items.len()), "{}: {} objects", r.name, r.items.len());
        assert!((1..=3).contains(&r.lights.len()), "{}: {} lights", r.name, r.lights.len());
        for (i, a) in r.items.iter().enumerate() {
            let corners = a.footprint(0.0);
            assert!(
                corners.iter().all(|c| c.x.abs() < s.w / 2.0 && c.y.abs() < s.d / 2.0),
                "{}: {} in a wall",
                r.name,
                i
            );
            for b in &r.items[i + 1..] {
                assert!(!quads_overlap(&corners, &b.footprint(0.0)), "{}: {} and {} overlap", r.name, a.class, b.class);
            }
        }
        let (scene, built, _) = build_scene(r, w, h).unwrap();
        let inst = &built.instances;
        for (k, it) in r.items.iter().enumerate() {
            let o = &scene.objects[built.first_furniture + k];
            let id: u16 = o.name.strip_prefix(&format!("{}_", it.class)).and_then(|i| i.parse().ok()).unwrap();
            let i = inst.instances.iter().find(|i| i.id == id).unwrap_or_else(|| panic!("{}: no instance", o.name));
            assert_eq!(i.label.as_deref(), Some(it.class.as_str()));
            assert!(i.pixels >= MIN_PIXELS_512, "{}: {} pixels", o.name, i.pixels);
            assert_eq!(i.pixels, inst.ids.iter().filter(|&&v| v == id).count());
        }
        let lights: Vec<&str> = scene.objects.iter().filter(|o| o.emitter.is_some()).map(|o| o.name.as_str()).collect();
        assert_eq!(lights.len(), r.lights.len() + 1, "{lights:?}");
        assert!(lights.contains(&"window") && lights.contains(&"light_0"), "{lights:?}");
    }
    // Held out: the first room's models.
    let dir = psdr_tests::temp_dir("real-rooms-held-out");
    let files: Vec<_> = rooms[0].items.iter().map(|i| i.model.path.clone()).collect();
    let dropped = held_out_db(&db, &files, &dir).unwrap();
    let distinct = files.iter().collect::<std::collections::HashSet<_>>().len();
    assert_eq!(dropped, distinct);
    let (all, held) = (ModelSet::from_folder(&db).unwrap(), ModelSet::from_folder(&dir).unwrap());
    assert_eq!(held.models.len() + distinct, all.models.len());
    assert!(held.models.iter().all(|m| !files.contains(&m.path)));
    assert!(held.skipped.is_empty(), "{:?}", held.skipped.first());
}
