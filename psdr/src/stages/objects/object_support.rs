//! Where a placed object stands: on the floor, on another object (`resting_on`), mounted on a wall (`wall_below`)
//! or with its back to a wall (`back_to_the_wall`, the prior that breaks near-ties of the pose search, else
//! the front towards the camera).

use crate::scene::{MeshPart, Scene};
use crate::vision::Instances;
use glam::{Quat, Vec3};

/// Where an instance's points are: the floor-plane box of their 10-90 % range and the heights of their 2 % and
/// 95 % points.
#[derive(Clone, Copy)]
pub(super) struct Extent {
    pub lo: Vec3,
    pub hi: Vec3,
    pub bottom: f32,
    pub top: f32,
}

/// The top of the highest other instance whose floor-plane box holds this one's centre and whose points end
/// below this one's bottom (a lamp on a table: the lamp's thin base may be hidden, so its lowest visible points
/// can be well above the table): what it stands on, if anything.
fn resting_on(e: &Extent, centre: Vec3, others: &[Extent], floor_y: f32) -> Option<f32> {
    others
        .iter()
        .filter(|o| {
            o.top > floor_y + 0.15
                && o.top < e.bottom + 0.15
                && (o.lo.x..=o.hi.x).contains(&centre.x)
                && (o.lo.z..=o.hi.z).contains(&centre.z)
        })
        .map(|o| o.top)
        .reduce(f32::max)
}

/// Classes that stand on the floor (`vision::classes`' canonical names): never on another object nor hung,
/// whatever the lowest points the mask shows. Thin legs vanish from a mask at the working size, and a chair's
/// seat then looks like its bottom (real room07's chrome-legged chair was set on a neighbour's top, 0.48 m up,
/// and floated there). Lamps, plants, shelves and cabinets (a wall cupboard) may stand anywhere.
const FLOOR_STANDING: &[&str] = &["sofa", "armchair", "chair", "table", "desk", "bed", "bookcase", "wardrobe"];

/// The height an object's model stands at: the floor, unless its class may stand elsewhere and its lowest
/// points seen are well above the floor; then on another instance whose points end right under them (a lamp
/// on a table: `resting_on`), else at its lowest points where it is a lamp high up (hanging) or `mounted` (its
/// mask has wall right under it). A table whose legs are hidden still stands on the floor.
pub(super) fn base_height(
    class: &str,
    e: &Extent,
    centre: Vec3,
    others: &[Extent],
    floor_y: f32,
    mounted: bool,
) -> f32 {
    if e.bottom <= floor_y + 0.15 || FLOOR_STANDING.contains(&class) {
        return floor_y;
    }
    let hanging = (class == "lamp" && e.bottom > floor_y + 1.2) || mounted;
    match resting_on(e, centre, others, floor_y) {
        Some(top) => top,
        None if hanging => e.bottom,
        None => floor_y,
    }
}

/// Whether instance `other` hides instance `id`'s bottom rather than holding it up: where `id`'s pixels have
/// `other`'s right below them in the image, `other` is mostly nearer the camera by more than `margin` metres
/// of depth (`ObjectInitOptions::occluder_depth`). The visible bottom of an object behind another ends at the
/// other's top, as a lamp's on a table does (real room09's shelf behind an armchair was put on the armchair,
/// half its height).
pub(super) fn hides_bottom(ids: &[u16], depth: &[f32], width: usize, id: u16, other: u16, margin: f32) -> bool {
    let (mut nearer, mut seen) = (0usize, 0usize);
    for p in 0..ids.len().saturating_sub(width) {
        let (a, b) = (depth[p], depth[p + width]);
        if ids[p] != id || ids[p + width] != other || a <= 0.0 || b <= 0.0 {
            continue;
        }
        seen += 1;
        if b < a - margin {
            nearer += 1;
        }
    }
    2 * nearer > seen
}

/// A wall of the room: a point on it, its normal into the room, its name.
pub(super) struct Wall {
    pub point: Vec3,
    pub normal: Vec3,
    pub name: String,
}

/// The scene's walls: objects named `wall*` whose surface stands upright (a rectangle facing +z, turned).
pub(super) fn walls_of(scene: &Scene) -> Vec<Wall> {
    scene
        .objects
        .iter()
        .filter(|o| o.name.starts_with("wall"))
        .map(|o| Wall { point: o.pose.translation, normal: o.pose.rotation * Vec3::Z, name: o.name.clone() })
        .filter(|w| w.normal.y.abs() < 0.1)
        .collect()
}

/// How far a model's back may stand from a wall and still count as turned to it, metres (furniture along a
/// wall keeps a skirting board's or a radiator's distance, or a walkway's).
const AGAINST_WALL: f32 = 0.5;

/// The nearest wall within `AGAINST_WALL` of the centre's footprint edge `reach` (half the model's depth).
pub(super) fn wall_behind(walls: &[Wall], centre: Vec3, reach: f32) -> Option<&Wall> {
    walls
        .iter()
        .map(|w| (w, (centre - w.point).dot(w.normal) - reach))
        .filter(|(_, gap)| (-0.1..AGAINST_WALL).contains(gap))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(w, _)| w)
}

/// The model's back as it stands at `yaw` degrees (its local -z).
pub(super) fn back(yaw_deg: f32) -> Vec3 {
    Quat::from_rotation_y(yaw_deg.to_radians()) * -Vec3::Z
}

/// A pose the finalists' search found: (yaw degrees, score, IoU, translation, scale).
pub(super) type FoundPose = (f32, f32, f32, Vec3, f32);

/// The best of `found` (yaw, score, iou, translation, scale); among poses within `tie` of it, one whose back faces
/// a wall it stands against (the model's half depth `reach` from its centre), if any; else, among them, the one
/// whose front (local +z) faces the camera at `eye` most (furniture is photographed from the front: a cabinet
/// turned round differs by its handles, a few pixels).
pub(super) fn back_to_the_wall(
    found: &[FoundPose],
    walls: &[Wall],
    reach: f32,
    tie: f32,
    eye: Vec3,
) -> Option<FoundPose> {
    let best = *found.iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
    let facing = |f: &FoundPose| wall_behind(walls, f.3, reach).map_or(0.0, |w| back(f.0).dot(-w.normal));
    let ties = || found.iter().filter(|f| f.1 >= best.1 - tie);
    let backed =
        ties().filter(|f| facing(f) > 0.7).max_by(|a, b| facing(a).total_cmp(&facing(b)).then(a.1.total_cmp(&b.1)));
    let to_eye = |f: &FoundPose| (-back(f.0)).dot((eye - f.3).normalize_or_zero());
    let fronted = ties().max_by(|a, b| to_eye(a).total_cmp(&to_eye(b)).then(a.1.total_cmp(&b.1)));
    Some(*backed.or(fronted).unwrap_or(&best))
}

/// Half the model's extent along its local z (front to back).
pub(super) fn half_depth(parts: &[MeshPart]) -> f32 {
    let (lo, hi) =
        parts.iter().flat_map(|p| &p.positions).fold((f32::MAX, f32::MIN), |(lo, hi), v| (lo.min(v.z), hi.max(v.z)));
    if lo <= hi {
        (hi - lo) / 2.0
    } else {
        0.0
    }
}

/// Of the columns of instance `id`, the fraction where the first pixel under its lowest pixel is a wall.
pub(super) fn wall_below(inst: &Instances, id: u16) -> f32 {
    let (w, h) = (inst.width, inst.height);
    let is_wall = |v: u16| inst.instances.iter().any(|i| i.id == v && i.class == "wall");
    let (mut columns, mut walls) = (0, 0);
    for x in 0..w {
        let Some(y) = (0..h).rev().find(|&y| inst.ids[y * w + x] == id) else { continue };
        if y + 1 < h {
            columns += 1;
            walls += is_wall(inst.ids[(y + 1) * w + x]) as usize;
        }
    }
    if columns == 0 {
        0.0
    } else {
        walls as f32 / columns as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::ObjectInitOptions;

    /// Without a wall behind it, of two near-tied poses the one facing the camera wins, whichever scored a
    /// hair better; a pose outside the tie is not taken for facing the camera.
    #[test]
    fn near_ties_away_from_walls_face_the_camera() {
        let eye = Vec3::new(0.0, 1.5, 3.0);
        let at = Vec3::new(0.0, 0.0, 0.0);
        // Yaw 0: local +z (the front) points at +z, towards the eye; yaw 180 turns the back to it.
        let found = [(180.0, 0.800, 0.9, at, 1.0), (0.0, 0.795, 0.9, at, 1.0)];
        assert_eq!(back_to_the_wall(&found, &[], 0.3, 0.02, eye).unwrap().0, 0.0);
        let far = [(180.0, 0.800, 0.9, at, 1.0), (0.0, 0.700, 0.8, at, 1.0)];
        assert_eq!(back_to_the_wall(&far, &[], 0.3, 0.02, eye).unwrap().0, 180.0);
    }

    /// A chair whose legs the mask lost (lowest points 0.45 m up) beside a stool-high instance whose box holds
    /// its centre stands on the floor; a lamp seen the same way stands on that instance, and one with nothing
    /// under it on the floor unless it is mounted or high up.
    #[test]
    fn furniture_stands_on_the_floor_a_lamp_on_what_is_under_it() {
        let at = |bottom: f32, top: f32| Extent {
            lo: Vec3::new(-0.3, 0.0, -0.3),
            hi: Vec3::new(0.3, 0.0, 0.3),
            bottom,
            top,
        };
        let seat_up = at(0.45, 0.9);
        let stool = [at(0.0, 0.40)];
        let c = Vec3::ZERO;
        assert_eq!(base_height("chair", &seat_up, c, &stool, 0.0, false), 0.0);
        assert_eq!(base_height("chair", &seat_up, c, &stool, 0.0, true), 0.0);
        assert_eq!(base_height("lamp", &seat_up, c, &stool, 0.0, false), 0.40);
        assert_eq!(base_height("lamp", &seat_up, c, &[], 0.0, false), 0.0);
        assert_eq!(base_height("cabinet", &seat_up, c, &[], 0.0, true), 0.45);
        assert_eq!(base_height("lamp", &at(1.5, 1.8), c, &[], 0.0, false), 1.5);
        // Its centre outside the stool's box: nothing holds it.
        assert_eq!(base_height("plant", &seat_up, Vec3::new(1.0, 0.0, 0.0), &stool, 0.0, false), 0.0);
    }

    /// Instance 1 over instance 2 in a 4-column image (rows 0-2 and 3-5): 2 hides 1's bottom where it is 0.5 m
    /// nearer the camera (an armchair before a shelf), not where it is 2 cm nearer (a table's top under a
    /// lamp), nor where 1 is over something else.
    #[test]
    fn a_nearer_instance_below_hides_the_bottom_a_level_one_holds_it() {
        let ids: Vec<u16> = (0..24).map(|p| if p < 12 { 1 } else { 2 }).collect();
        let depth_with = |below: f32| -> Vec<f32> { (0..24).map(|p| if p < 12 { 3.0 } else { below }).collect() };
        let margin = ObjectInitOptions::default().occluder_depth;
        assert!(hides_bottom(&ids, &depth_with(2.5), 4, 1, 2, margin));
        assert!(!hides_bottom(&ids, &depth_with(2.98), 4, 1, 2, margin));
        assert!(!hides_bottom(&ids, &depth_with(2.5), 4, 1, 3, margin));
        assert!(!hides_bottom(&ids, &depth_with(2.5), 4, 2, 1, margin));
        // A margin past the armchair's 0.5 m makes it a support again.
        assert!(!hides_bottom(&ids, &depth_with(2.5), 4, 1, 2, 0.6));
    }
}
