//! The BVHs of the last few triangle sets `SceneData::build` flattened. The stages render one geometry many
//! times over, changing only what the BVH does not see: a unit render per candidate light (the ceiling search
//! makes 7-19 per height, 8-9 heights), a render per albedo-division round, the light-scale search's passes.
//! Each of those built the BVH afresh, serially, while the render threads waited (about a third of the
//! ceiling search on real-furniture rooms). A build whose triangles are bit for bit those of a cached one takes
//! its tree and order instead; the build is deterministic, so the scene data is the same either way.
//! A set that differs from a cached one in a few triangles (a light moved, a wall stretched) takes that one's
//! tree refitted to it (`bvh_refit`): the same hits up to exact ties, no build.

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

/// A triangle set is refitted from a cached one when at most this fraction of its triangles moved; more, and
/// the cached tree's topology may no longer suit it (an object pose search moves thousands).
const REFIT_MAX_MOVED: usize = 64; // 1 in this many

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

    /// The tree of the cached set with the fewest moved triangles, refitted to `tris`, where at most
    /// 1/`REFIT_MAX_MOVED` of them moved; its order (the leaves' triangles are the same ones).
    fn refit_nearest(&self, tris: &[TriangleGeom]) -> Option<(Vec<BvhNode>, Vec<u32>)> {
        let limit = tris.len() / REFIT_MAX_MOVED;
        let moved = |e: &Entry| -> Option<usize> {
            if e.triangles.len() != tris.len() {
                return None;
            }
            let mut n = 0;
            for (k, t) in e.triangles.iter().zip(tris) {
                n += usize::from(*k != corners(t));
                if n > limit {
                    return None;
                }
            }
            Some(n)
        };
        let entry = self.entries.iter().filter_map(|e| Some((moved(e)?, e))).min_by_key(|(n, _)| *n)?.1;
        let mut nodes = entry.nodes.clone();
        super::bvh_refit::refit(&mut nodes, &|j| &tris[entry.order[j] as usize]);
        Some((nodes, entry.order.clone()))
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
    /// was made for exactly these triangles, else a cached one refitted where few triangles moved
    /// (`refit_nearest`; not cached: a refit is cheap), else `build()`'s, which is then cached (an error is not).
    fn get_or_build<E>(
        cache: &Mutex<BvhCache>,
        tris: &[TriangleGeom],
        build: impl FnOnce() -> Result<(Vec<BvhNode>, Vec<u32>), E>,
    ) -> Result<(Vec<BvhNode>, Vec<u32>), E> {
        let lock = || cache.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(found) = lock().find(tris) {
            return Ok(found);
        }
        if let Some(refitted) = lock().refit_nearest(tris) {
            return Ok(refitted);
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

    /// A set with one triangle in `REFIT_MAX_MOVED` moved takes a cached tree refitted (no build, the cached
    /// order); with one more moved it builds.
    #[test]
    fn a_few_moved_triangles_refit_a_cached_tree_and_more_build() {
        let cache = Mutex::new(BvhCache::default());
        let builds = std::cell::Cell::new(0);
        let get = |tris: &[TriangleGeom]| {
            BvhCache::get_or_build::<()>(&cache, tris, || {
                builds.set(builds.get() + 1);
                let b = crate::render::scene_data::build_bvh(tris);
                Ok((b.nodes, b.primitive_indices))
            })
            .unwrap()
        };
        let n = 4 * REFIT_MAX_MOVED;
        let tris: Vec<TriangleGeom> = (0..n).map(|i| tri(i as f32)).collect();
        let (_, order) = get(&tris);
        let shifted = |count: usize| -> Vec<TriangleGeom> {
            let mut t = tris.clone();
            for k in 0..count {
                t[k * 3].v0[1] += 0.5;
            }
            t
        };
        let (_, refit_order) = get(&shifted(4));
        assert_eq!((builds.get(), &refit_order), (1, &order));
        get(&shifted(5));
        assert_eq!(builds.get(), 2);
    }
}
