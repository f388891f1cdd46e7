//! A material per wall (`stages::own_materials`, room.rhai's light stage at its second pass), on the
//! known-geometry room whose left wall is painted blue beside cream ones: with the room box's one "wall"
//! material the division can only find a colour between the two (the blue wall's albedo far off); with a
//! material per wall, divided out and joined back where alike (`join_alike_materials`, room.rhai's
//! tolerance 0.4), the blue wall keeps its own, the cream walls and the one behind the camera (no pixel)
//! share one, each seen wall's albedo within 5 % of its paint, and the image comes closer. Painted all cream,
//! the four walls end as one material. True lights, segments from the truth's object ids, 128 x 96 pixels.

use glam::Vec3;
use psdr::backend::CpuBackend;
use psdr::render::{render_cpu, Frame, SceneData};
use psdr::scene::{Color, Material, Scene};
use psdr::stages::{
    divide_albedos, join_alike_materials, own_materials, relative_rmse_downsampled, Division, JoinedMaterials, Segment,
};
use psdr_tests::known_geometry::{truth_room, truth_segments};

const WALLS: [&str; 4] = ["wall_x0", "wall_x1", "wall_z0", "wall_z1"];

fn render(s: &Scene, spp: u32) -> Frame {
    let mut settings = s.settings.clone();
    settings.spp = spp;
    render_cpu(&SceneData::build(s).unwrap(), &settings, &|_, _| {})
}

fn object(s: &Scene, name: &str) -> usize {
    s.objects.iter().position(|o| o.name == name).unwrap()
}

fn albedo_of(s: &Scene, object_name: &str) -> Vec3 {
    let Color::Constant(a) = s.materials[s.objects[object(s, object_name)].parts[0].material].albedo else {
        panic!("{object_name}: a constant albedo")
    };
    a
}

/// The walls', floor's, ceiling's and furniture's segments (the lights left out).
fn segments(s: &Scene, photo: &Frame) -> Vec<Segment> {
    let structure = ["floor", "ceiling", "cabinet_7", "table_8"];
    truth_segments(s, photo, |o| WALLS.contains(&o.name.as_str()) || structure.contains(&o.name.as_str()))
}

/// room.rhai's steps: a material per wall, an albedo division of the walls, the alike joined back.
fn split_divide_join(s: &mut Scene, photo: &Frame, division: &Division) -> JoinedMaterials {
    let walls: Vec<String> = WALLS.map(String::from).to_vec();
    let copies = own_materials(s, &walls).unwrap();
    assert_eq!(copies.len(), 4, "{copies:?}");
    assert!(s.materials.iter().all(|m| m.name != "wall"), "the shared material is gone");
    let segs: Vec<Segment> =
        segments(s, photo).into_iter().filter(|x| s.materials[x.material].name.starts_with("wall_")).collect();
    divide_albedos(&mut CpuBackend, s, &photo.radiance, &segs, division).unwrap();
    let seen: Vec<(String, f64)> =
        segs.iter().map(|x| (s.materials[x.material].name.clone(), x.mask.iter().map(|&v| v as f64).sum())).collect();
    join_alike_materials(s, &seen, &walls, 0.4, "wall").unwrap().unwrap()
}

fn relative(a: Vec3, truth: Vec3) -> f32 {
    (a - truth).length() / truth.length()
}

#[test]
fn a_blue_wall_beside_cream_ones_gets_its_own_albedo() {
    let (mut truth, _) = truth_room();
    truth.settings.max_depth = 8;
    let blue = Vec3::new(0.25, 0.35, 0.6);
    truth.materials.push(Material::diffuse("wall_blue", blue));
    let x0 = object(&truth, "wall_x0");
    truth.objects[x0].parts[0].material = truth.materials.len() - 1;
    let cream = albedo_of(&truth, "wall_x1");
    let photo = render(&truth, 256);

    // The start: the room box's one grey "wall" on all four, the rest at its true values.
    let mut start = truth.clone();
    start.materials.pop();
    let wall = start.materials.iter().position(|m| m.name == "wall").unwrap();
    start.objects[x0].parts[0].material = wall;
    start.materials[wall].albedo = Color::Constant(Vec3::splat(0.5));
    let division = Division { rounds: 3, spp: 32, tolerance: 0.0, direct_spp: 0 };

    let mut shared = start.clone();
    let shared_segments = segments(&shared, &photo);
    divide_albedos(&mut CpuBackend, &mut shared, &photo.radiance, &shared_segments, &division).unwrap();

    let mut own = start.clone();
    let joined = split_divide_join(&mut own, &photo, &division);
    eprintln!("{joined:?}");
    assert_eq!(joined.apart, ["wall_x0"]);
    assert_eq!(joined.members, ["wall_x1", "wall_z0", "wall_z1"]);
    let seen: Vec<String> = joined.distances.iter().map(|(n, _)| n.clone()).collect();

    let shared_wall = albedo_of(&shared, "wall_x0");
    eprintln!(
        "shared wall {shared_wall:?}: {:.3} off the blue wall, {:.3} off the cream ones",
        relative(shared_wall, blue),
        relative(shared_wall, cream)
    );
    assert!(relative(shared_wall, blue) > 0.15, "one material cannot be both paints: {shared_wall:?}");
    let mut seen_walls = 0;
    for w in WALLS {
        let (own_albedo, paint) = (albedo_of(&own, w), if w == "wall_x0" { blue } else { cream });
        let is_seen = seen.iter().any(|n| n == w);
        eprintln!("{w}: {own_albedo:?} ({} off its paint, seen {is_seen})", relative(own_albedo, paint));
        if is_seen {
            seen_walls += 1;
            assert!(relative(own_albedo, paint) < 0.05, "{w}: {own_albedo:?} against {paint:?}");
        }
    }
    assert!(seen_walls >= 3, "{seen:?}");
    // The wall behind the camera has no pixel: it shares the cream walls' material.
    let material = |s: &Scene, o: &str| s.objects[object(s, o)].parts[0].material;
    assert_eq!(material(&own, "wall_z1"), material(&own, "wall_x1"));
    assert_eq!(own.materials[material(&own, "wall_z1")].name, "wall");
    assert_eq!(own.materials.len(), start.materials.len() + 1, "one material more: the blue wall's");

    let (w, h) = (truth.camera.width as usize, truth.camera.height as usize);
    let err = |s: &Scene| relative_rmse_downsampled(&render(s, 64).radiance, &photo.radiance, w, h, 1);
    let (e_shared, e_own) = (err(&shared), err(&own));
    eprintln!("image RMSE: one wall material {e_shared:.4}, one per wall {e_own:.4}");
    assert!(e_own < 0.8 * e_shared, "per wall {e_own} against shared {e_shared}");

    // All cream: the walls the photo shows alike are one material again.
    let mut cream_truth = truth.clone();
    cream_truth.objects[x0].parts[0].material = cream_truth.objects[object(&cream_truth, "wall_x1")].parts[0].material;
    let cream_photo = render(&cream_truth, 256);
    let mut alike = start.clone();
    let joined = split_divide_join(&mut alike, &cream_photo, &division);
    eprintln!("all cream: {joined:?}");
    assert!(joined.apart.is_empty() && joined.members.len() == 4, "{joined:?}");
    assert_eq!(alike.materials.len(), start.materials.len());
    assert!(relative(Vec3::from(joined.albedo), cream) < 0.05, "{:?}", joined.albedo);
}
