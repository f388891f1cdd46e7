//! The BVHs of the last few triangle sets `SceneData::build` flattened. The stages render one geometry many
//! times over, changing only what the BVH does not see: a unit render per candidate light (the ceiling search
//! makes 7-19 per height, 8-9 heights), a render per albedo-division round, the light-scale search's passes.
//! Each of those built the BVH afresh, serially, while the render threads waited (about a third of the
//! ceiling search on real-furniture rooms). A build whose triangles are bit for bit those of a cached one takes
//! its tree and order instead; the build is deterministic, so the scene data is the same either way.

use super::layout::{BvhNode, TriangleGeom};
use std::sync::Mutex;

/// Triangle sets kept: the current geometry, and the few a search moves between (a trial and its base).
const ENTRIES: usize = 4;

/// One triangle's corner and edges, as bits (the key compares floats exactly).
type Corners = [u32; 9];

struct Entry {
    triangles: Vec<Corners>,
    nodes: Vec<BvhNode>,
    order: Vec<u32>,
}

/// Builds, most recently used last.
#[derive(Default)]
pub(crate) struct BvhCache {
    entries: Vec<Entry>,
}

/// The one `SceneData::build` uses.
static CACHE: Mutex<BvhCache> = Mutex::new(BvhCache { entries: Vec::new() });

fn corners(t: &TriangleGeom) -> Corners {
    let [a, b, c] = [t.v0, t.e1, t.e2].map(|v| v.map(f32::to_bits));
    [a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]]
}

impl BvhCache {
    /// The nodes and order cached for exactly `tris`, made the most recent.
    fn find(&mut self, tris: &[TriangleGeom]) -> Option<(Vec<BvhNode>, Vec<u32>)> {
        let same =
            |e: &Entry| e.triangles.len() == tris.len() && e.triangles.iter().zip(tris).all(|(k, t)| *k == corners(t));
        let i = self.entries.iter().position(same)?;
        let entry = self.entries.remove(i);
        let found = (entry.nodes.clone(), entry.order.clone());
        self.entries.push(entry);
        Some(found)
    }

    /// Keeps a build of `tris`, forgetting the least recently used beyond `ENTRIES`.
    fn keep(&mut self, tris: &[TriangleGeom], nodes: &[BvhNode], order: &[u32]) {
        if self.entries.len() >= ENTRIES {
            self.entries.remove(0);
        }
        let triangles = tris.iter().map(corners).collect();
        self.entries.push(Entry { triangles, nodes: nodes.to_vec(), order: order.to_vec() });
    }

    /// The BVH nodes and the triangle order (leaf order to scene order) of `tris`: a cached build's when one
    /// was made for exactly these triangles, else `build()`'s, which is then cached (an error is not).
    fn get_or_build<E>(
        cache: &Mutex<BvhCache>,
        tris: &[TriangleGeom],
        build: impl FnOnce() -> Result<(Vec<BvhNode>, Vec<u32>), E>,
    ) -> Result<(Vec<BvhNode>, Vec<u32>), E> {
        let lock = || cache.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(found) = lock().find(tris) {
            return Ok(found);
        }
        // Built outside the lock: renders of other geometry on other threads do not wait for it.
        let (nodes, order) = build()?;
        lock().keep(tris, &nodes, &order);
        Ok((nodes, order))
    }
}

/// `BvhCache::get_or_build` on the process's cache.
pub(crate) fn cached_bvh<E>(
    tris: &[TriangleGeom],
    build: impl FnOnce() -> Result<(Vec<BvhNode>, Vec<u32>), E>,
) -> Result<(Vec<BvhNode>, Vec<u32>), E> {
    BvhCache::get_or_build(&CACHE, tris, build)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(x: f32) -> TriangleGeom {
        TriangleGeom { v0: [x, 0.0, 0.0], e1: [1.0, 0.0, 0.0], e2: [0.0, 1.0, 0.0], ..Default::default() }
    }

    /// A second build of the same triangles takes the first's result without building; a triangle moved by
    /// one ulp is another geometry and builds; past `ENTRIES` other geometries the first is forgotten.
    #[test]
    fn the_same_triangles_reuse_the_build_and_moved_ones_do_not() {
        let cache = Mutex::new(BvhCache::default());
        let builds = std::cell::Cell::new(0);
        let get = |tris: &[TriangleGeom], order: Vec<u32>| {
            BvhCache::get_or_build::<()>(&cache, tris, || {
                builds.set(builds.get() + 1);
                Ok((vec![BvhNode::default()], order))
            })
            .unwrap()
            .1
        };
        let tris = vec![tri(1.0), tri(2.0)];
        assert_eq!(get(&tris, vec![1, 0]), vec![1, 0]);
        assert_eq!((get(&tris, vec![0, 1]), builds.get()), (vec![1, 0], 1));
        let moved = vec![tri(1.0), tri(f32::from_bits(2.0f32.to_bits() + 1))];
        assert_eq!((get(&moved, vec![0, 1]), builds.get()), (vec![0, 1], 2));
        for k in 0..ENTRIES {
            get(&[tri(10.0 + k as f32)], vec![0]);
        }
        assert_eq!((get(&tris, vec![0, 1]), builds.get()), (vec![0, 1], 3 + ENTRIES));
    }
}
