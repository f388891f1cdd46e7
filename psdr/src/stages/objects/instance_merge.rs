//! Split pieces of one object become one instance before the object stage places anything ("model no more
//! than a scene needs"): a segmenter often cuts a sofa in two where a lamp's pole or a table leg stands in
//! front of it. Two instances of one class are merged when they do not touch, yet at least `min_bridges`
//! image rows or columns run from one to the other across a single nearer instance only, with the depth on
//! both sides of that occluder within `depth_tolerance` (relative) of each other: the surface goes on
//! behind it. Two chairs side by side touch, or are parted by floor, and stay two. The crossing lines must
//! also span a share of the smaller piece across them (`min_span`, a quarter in room.rhai): an occluder that cuts one object does
//! so over its whole height (or width), while two chairs behind one table meet across it in a few rows only
//! (a real room's two chairs were merged on 3 rows, each 30 high).

use crate::vision::{ClassKind, Instances};

/// One merge, for the run's log.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MergedInstance {
    /// The instance that remains (the larger piece).
    pub into: u16,
    pub merged: u16,
    pub class: String,
    /// Rows and columns that cross the occluder from one piece to the other.
    pub bridges: usize,
    pub occluder: u16,
}

/// Whether instances `a` and `b` share a 4-neighbour pixel edge.
fn touching(inst: &Instances, a: u16, b: u16) -> bool {
    let (w, h) = (inst.width, inst.height);
    (0..w * h).any(|p| {
        inst.ids[p] == a
            && ((p % w + 1 < w && inst.ids[p + 1] == b)
                || (p % w > 0 && inst.ids[p - 1] == b)
                || (p + w < w * h && inst.ids[p + w] == b)
                || (p >= w && inst.ids[p - w] == b))
    })
}

/// Rows and columns an instance spans (bounding box height and width), 0 for an absent one.
fn extent(inst: &Instances, id: u16) -> (usize, usize) {
    let w = inst.width;
    let (mut y0, mut y1, mut x0, mut x1) = (usize::MAX, 0, usize::MAX, 0);
    for (p, _) in inst.ids.iter().enumerate().filter(|(_, v)| **v == id) {
        (y0, y1, x0, x1) = (y0.min(p / w), y1.max(p / w), x0.min(p % w), x1.max(p % w));
    }
    if y0 == usize::MAX {
        (0, 0)
    } else {
        (y1 - y0 + 1, x1 - x0 + 1)
    }
}

/// Rows and columns crossing from `a` to `b` (either order) through one nearer instance, and that occluder:
/// (rows, columns, occluder).
fn bridges(inst: &Instances, depth: &[f32], a: u16, b: u16, depth_tolerance: f32) -> (usize, usize, u16) {
    let (w, h) = (inst.width, inst.height);
    let mut occluder = 0;
    // A line of pixels (index sequence): every run piece -> occluder -> other piece; 1 if it has one.
    let mut scan = |line: &mut dyn Iterator<Item = usize>| -> usize {
        let mut count = 0;
        let mut last: Option<(u16, usize)> = None; // the last piece pixel seen and its index
        let mut between: Option<u16> = None; // the single instance since then, if one
        let (mut clean, mut farthest) = (true, 0.0f32); // one nearer instance only; its farthest pixel
        for p in line {
            let id = inst.ids[p];
            if id == a || id == b {
                if let (Some((prev, q)), Some(c), true) = (last, between, clean) {
                    let (dq, dp) = (depth[q], depth[p]);
                    let near = dq > 0.0 && dp > 0.0 && (dq - dp).abs() <= depth_tolerance * dq.max(dp);
                    if prev != id && near && farthest < dq.min(dp) {
                        count += 1;
                        occluder = c;
                    }
                }
                (last, between, clean, farthest) = (Some((id, p)), None, true, 0.0);
            } else if last.is_some() {
                match between {
                    None => between = Some(id),
                    Some(c) if c == id => {}
                    Some(_) => clean = false,
                }
                // Unlabelled or unmeasured pixels cannot show an occluder.
                clean &= id != 0 && depth[p] > 0.0;
                farthest = farthest.max(depth[p]);
            }
        }
        count.min(1)
    };
    let rows: usize = (0..h).map(|y| scan(&mut (0..w).map(|x| y * w + x))).sum();
    let columns: usize = (0..w).map(|x| scan(&mut (0..h).map(|y| y * w + x))).sum();
    (rows, columns, occluder)
}

/// `inst` with split pieces merged, and what was merged. `min_span`: the share of the smaller piece's extent
/// (rows for row crossings, columns for column crossings) the crossing lines must span.
pub fn merge_split_instances(
    inst: &Instances,
    depth: &[f32],
    min_bridges: usize,
    depth_tolerance: f32,
    min_span: f32,
) -> (Instances, Vec<MergedInstance>) {
    let mut out = inst.clone();
    let mut merges = vec![];
    loop {
        let pieces: Vec<_> = out.instances.iter().filter(|i| i.kind == ClassKind::Furniture).cloned().collect();
        let mut found = None;
        'pairs: for (k, a) in pieces.iter().enumerate() {
            for b in pieces.iter().skip(k + 1).filter(|b| b.class == a.class) {
                if touching(&out, a.id, b.id) {
                    continue;
                }
                let (rows, columns, occluder) = bridges(&out, depth, a.id, b.id, depth_tolerance);
                let (ea, eb) = (extent(&out, a.id), extent(&out, b.id));
                let need = |span: usize| min_bridges.max(1).max((min_span * span as f32).ceil() as usize);
                let n = rows + columns;
                if rows >= need(ea.0.min(eb.0)) || columns >= need(ea.1.min(eb.1)) {
                    let (into, merged) = if a.pixels >= b.pixels { (a, b) } else { (b, a) };
                    found = Some(MergedInstance {
                        into: into.id,
                        merged: merged.id,
                        class: a.class.clone(),
                        bridges: n,
                        occluder,
                    });
                    break 'pairs;
                }
            }
        }
        let Some(m) = found else { break };
        out.ids.iter_mut().filter(|v| **v == m.merged).for_each(|v| *v = m.into);
        let moved = out.instances.iter().find(|i| i.id == m.merged).map_or(0, |i| i.pixels);
        out.instances.retain(|i| i.id != m.merged);
        if let Some(i) = out.instances.iter_mut().find(|i| i.id == m.into) {
            i.pixels += moved;
        }
        merges.push(m);
    }
    (out, merges)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vision::Instance;

    /// A 40 x 40 map: instance ids drawn as rectangles (later ones in front), depth per id.
    fn map(rects: &[(u16, &str, [usize; 4], f32)]) -> (Instances, Vec<f32>) {
        let (w, h) = (40, 40);
        let (mut ids, mut depth) = (vec![1u16; w * h], vec![4.0f32; w * h]); // 1: the wall behind
        for &(id, _, [x0, y0, x1, y1], d) in rects {
            for y in y0..y1 {
                for x in x0..x1 {
                    (ids[y * w + x], depth[y * w + x]) = (id, d);
                }
            }
        }
        let instance = |id: u16, class: &str, kind| {
            let pixels = ids.iter().filter(|v| **v == id).count();
            Instance { id, label: Some(class.into()), class: class.into(), kind, pixels }
        };
        let mut instances = vec![instance(1, "wall", ClassKind::Structure)];
        for &(id, class, _, _) in rects {
            instances.push(instance(id, class, ClassKind::Furniture));
        }
        (Instances { width: w, height: h, ids, instances }, depth)
    }

    #[test]
    fn a_cut_object_is_merged_and_two_chairs_behind_a_table_are_not() {
        // A sofa 30 wide and 12 high, its instance cut in two by a pole in front over its whole height: one sofa.
        let (inst, depth) = map(&[
            (2, "sofa", [5, 20, 18, 32], 3.0),
            (3, "sofa", [21, 20, 35, 32], 3.0),
            (4, "lamp", [18, 10, 21, 40], 2.0),
        ]);
        let (merged, log) = merge_split_instances(&inst, &depth, 3, 0.1, 0.25);
        assert_eq!(log.len(), 1, "{log:?}");
        assert_eq!(merged.instances.iter().filter(|i| i.class == "sofa").count(), 1);
        // Two chairs 8 wide, 24 high, 6 apart, with a table in front that overlaps both and fills the gap
        // between them over 4 rows only (its top): two chairs.
        let (inst, depth) = map(&[
            (4, "chair", [8, 8, 16, 32], 3.0),
            (5, "chair", [22, 8, 30, 32], 3.0),
            (6, "table", [14, 20, 24, 24], 2.0),
        ]);
        // Without the span criterion these would merge: 4 rows cross the table top from one chair to the other.
        assert_eq!(bridges(&inst, &depth, 4, 5, 0.1).0, 4);
        let (_, log) = merge_split_instances(&inst, &depth, 3, 0.1, 0.25);
        assert!(log.is_empty(), "{log:?}");
    }
}
