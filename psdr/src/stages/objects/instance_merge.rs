//! Split pieces of one object become one instance before the object stage places anything ("model no more
//! than a scene needs"): a segmenter often cuts a sofa in two where a lamp's pole or a table leg stands in
//! front of it. Two instances of one class are merged when they do not touch, yet at least `min_bridges`
//! image rows or columns run from one to the other across a single nearer instance only, with the depth on
//! both sides of that occluder within `depth_tolerance` (relative) of each other: the surface goes on
//! behind it. Two chairs side by side touch, or are parted by floor, and stay two.

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

/// Rows and columns crossing from `a` to `b` (either order) through one nearer instance, and that occluder.
fn bridges(inst: &Instances, depth: &[f32], a: u16, b: u16, depth_tolerance: f32) -> (usize, u16) {
    let (w, h) = (inst.width, inst.height);
    let mut count = 0;
    let mut occluder = 0;
    // A line of pixels (index sequence): every run piece -> occluder -> other piece.
    let mut scan = |line: &mut dyn Iterator<Item = usize>| {
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
    };
    for y in 0..h {
        scan(&mut (0..w).map(|x| y * w + x));
    }
    for x in 0..w {
        scan(&mut (0..h).map(|y| y * w + x));
    }
    (count, occluder)
}

/// `inst` with split pieces merged, and what was merged.
pub fn merge_split_instances(
    inst: &Instances,
    depth: &[f32],
    min_bridges: usize,
    depth_tolerance: f32,
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
                let (n, occluder) = bridges(&out, depth, a.id, b.id, depth_tolerance);
                if n >= min_bridges.max(1) {
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
