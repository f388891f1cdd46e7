//! Ray-scene intersection: stack-based BVH2 traversal and Moller-Trumbore triangles.
//! GLSL twin: shaders/bvh.glsl (same function names, same order of operations).

use super::layout::{BvhNode, TriangleGeom};
use super::scene_data::BVH_STACK_SIZE;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub triangle: u32,
}

/// Direction components this small are nudged so 1/d stays finite (avoids 0 * inf = NaN in the slab test).
const MIN_DIR: f32 = 1e-12;

#[inline(always)]
pub fn safe_inverse(d: Vec3) -> Vec3 {
    let f = |x: f32| if x.abs() < MIN_DIR { 1.0 / MIN_DIR.copysign(x) } else { 1.0 / x };
    Vec3::new(f(d.x), f(d.y), f(d.z))
}

/// Entry distance of the ray into the node's box, or +inf when it misses within [0, t_max).
#[inline(always)]
pub fn intersect_aabb(node: &BvhNode, origin: Vec3, inv_dir: Vec3, t_max: f32) -> f32 {
    let t1 = (node.min - origin) * inv_dir;
    let t2 = (node.max - origin) * inv_dir;
    let t_near = t1.min(t2).max_element().max(0.0);
    let t_far = t1.max(t2).min_element().min(t_max);
    if t_near <= t_far {
        t_near
    } else {
        f32::INFINITY
    }
}

/// Distance to the triangle and barycentrics (u, v), or None. Both faces are hit.
#[inline(always)]
pub fn intersect_triangle(tri: &TriangleGeom, origin: Vec3, dir: Vec3) -> Option<(f32, f32, f32)> {
    let e1 = Vec3::from(tri.e1);
    let e2 = Vec3::from(tri.e2);
    let p = dir.cross(e2);
    let det = e1.dot(p);
    let inv_det = 1.0 / det;
    let s = origin - Vec3::from(tri.v0);
    let u = s.dot(p) * inv_det;
    let q = s.cross(e1);
    let v = dir.dot(q) * inv_det;
    let t = e2.dot(q) * inv_det;
    // The early-outs, evaluated together (one hard-to-predict branch instead of four).
    let v_outside = (v < 0.0) | (u + v > 1.0);
    let ok = (det != 0.0) & det.is_finite() & (0.0..=1.0).contains(&u) & !v_outside;
    ok.then_some((t, u, v))
}

/// The two children of an inner node, `nodes[l]` and `nodes[l + 1]`, against one ray: their `intersect_aabb`
/// values, computed together. On x86_64 this is four-wide SSE2 (`sse::RaySse::pair`): per lane the same subtract,
/// multiply, min and max as `intersect_aabb`, so every value and decision is the same (min/max select exactly;
/// the operands are never NaN because `safe_inverse` keeps 1/d finite). Elsewhere it is two `intersect_aabb` calls.
/// CPU only: the GLSL twin calls `intersect_aabb` twice, which is what this computes.
pub struct RayBoxes {
    #[cfg(not(target_arch = "x86_64"))]
    origin: Vec3,
    #[cfg(not(target_arch = "x86_64"))]
    inv_dir: Vec3,
    #[cfg(target_arch = "x86_64")]
    sse: sse::RaySse,
}

impl RayBoxes {
    #[inline(always)]
    pub fn new(origin: Vec3, inv_dir: Vec3) -> RayBoxes {
        RayBoxes {
            #[cfg(not(target_arch = "x86_64"))]
            origin,
            #[cfg(not(target_arch = "x86_64"))]
            inv_dir,
            #[cfg(target_arch = "x86_64")]
            sse: sse::RaySse::new(origin, inv_dir),
        }
    }

    /// (intersect_aabb(nodes[l]), intersect_aabb(nodes[l + 1])) for the same `t_max`.
    #[inline(always)]
    pub fn pair(&self, nodes: &[BvhNode], l: usize, t_max: f32) -> (f32, f32) {
        let pair: &[BvhNode; 2] = nodes[l..l + 2].try_into().expect("inner nodes have two children");
        #[cfg(target_arch = "x86_64")]
        {
            self.sse.pair(pair, t_max)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            (
                intersect_aabb(&pair[0], self.origin, self.inv_dir, t_max),
                intersect_aabb(&pair[1], self.origin, self.inv_dir, t_max),
            )
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod sse {
    use super::BvhNode;
    use glam::Vec3;
    use std::arch::x86_64::*;

    // Bvh2Node is `min: Vec3, prim_count: u32, max: Vec3, first_index: u32` (32 bytes): lanes 0-2 are the bounds.
    const _: () = assert!(std::mem::size_of::<BvhNode>() == 32);

    pub struct RaySse {
        origin: __m128,
        inv_dir: __m128,
        /// All ones in lanes 0-2: clears the node's prim_count / first_index lane.
        xyz: __m128,
    }

    impl RaySse {
        #[inline(always)]
        pub fn new(origin: Vec3, inv_dir: Vec3) -> RaySse {
            // SAFETY: SSE2 is part of the x86_64 baseline.
            unsafe {
                RaySse {
                    origin: _mm_set_ps(0.0, origin.z, origin.y, origin.x),
                    inv_dir: _mm_set_ps(0.0, inv_dir.z, inv_dir.y, inv_dir.x),
                    xyz: _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1)),
                }
            }
        }

        /// Per child: t1 = (min - o) * inv, t2 = (max - o) * inv, near = max(t1.min(t2) over xyz, 0),
        /// far = min(t1.max(t2) over xyz, t_max), entry = near if near <= far else inf. Lane 3 of each box is
        /// zeroed first, so (0 - 0) * 0 = +0 there: it is the `max(0)` of near, and for far it is replaced by t_max.
        #[inline(always)]
        pub fn pair(&self, pair: &[BvhNode; 2], t_max: f32) -> (f32, f32) {
            // SAFETY: SSE2 is part of the x86_64 baseline; `pair` is 64 readable bytes (two 32-byte nodes).
            unsafe {
                let p = pair.as_ptr() as *const f32;
                let lmin = _mm_and_ps(_mm_loadu_ps(p), self.xyz);
                let lmax = _mm_and_ps(_mm_loadu_ps(p.add(4)), self.xyz);
                let rmin = _mm_and_ps(_mm_loadu_ps(p.add(8)), self.xyz);
                let rmax = _mm_and_ps(_mm_loadu_ps(p.add(12)), self.xyz);
                let l1 = _mm_mul_ps(_mm_sub_ps(lmin, self.origin), self.inv_dir);
                let l2 = _mm_mul_ps(_mm_sub_ps(lmax, self.origin), self.inv_dir);
                let r1 = _mm_mul_ps(_mm_sub_ps(rmin, self.origin), self.inv_dir);
                let r2 = _mm_mul_ps(_mm_sub_ps(rmax, self.origin), self.inv_dir);
                let t_max4 = _mm_set_ps(t_max, 0.0, 0.0, 0.0);
                let (ln, lf) = (_mm_min_ps(l1, l2), _mm_or_ps(_mm_max_ps(l1, l2), t_max4));
                let (rn, rf) = (_mm_min_ps(r1, r2), _mm_or_ps(_mm_max_ps(r1, r2), t_max4));
                // Horizontal max (near) and min (far) of both boxes at once: lanes 0 (left) and 1 (right).
                let n = _mm_max_ps(_mm_unpacklo_ps(ln, rn), _mm_unpackhi_ps(ln, rn));
                let n = _mm_max_ps(n, _mm_movehl_ps(n, n));
                let f = _mm_min_ps(_mm_unpacklo_ps(lf, rf), _mm_unpackhi_ps(lf, rf));
                let f = _mm_min_ps(f, _mm_movehl_ps(f, f));
                let enter = _mm_cmple_ps(n, f);
                let t = _mm_or_ps(_mm_and_ps(enter, n), _mm_andnot_ps(enter, _mm_set1_ps(f32::INFINITY)));
                (_mm_cvtss_f32(t), _mm_cvtss_f32(_mm_shuffle_ps::<0b01>(t, t)))
            }
        }
    }
}

/// Uninitialised traversal stack storage (only entries below the stack pointer are ever read).
#[inline(always)]
fn stack_storage<T: Copy>() -> [std::mem::MaybeUninit<T>; BVH_STACK_SIZE] {
    [std::mem::MaybeUninit::uninit(); BVH_STACK_SIZE]
}

/// Closest hit with t in (0, t_max). Counts nothing; callers count rays.
pub fn trace_closest(nodes: &[BvhNode], tris: &[TriangleGeom], origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
    let inv_dir = safe_inverse(dir);
    let boxes = RayBoxes::new(origin, inv_dir);
    let mut best = Hit { t: t_max, u: 0.0, v: 0.0, triangle: u32::MAX };
    if intersect_aabb(&nodes[0], origin, inv_dir, best.t) == f32::INFINITY {
        return None;
    }
    // Each stack entry keeps the entry distance of its box, computed when its parent was visited: a popped
    // node is skipped when a hit found since then is nearer (the same test as re-intersecting its box).
    // The nearer child of an inner node is visited next without a round trip through the stack (its entry
    // distance is at most best.t, so the pop test would pass).
    let mut stack = stack_storage::<(u32, f32)>();
    let mut sp = 0usize;
    let mut node_index = 0u32;
    loop {
        let node = &nodes[node_index as usize];
        if node.prim_count > 0 {
            let first = node.first_index as usize;
            for (k, tri) in tris[first..first + node.prim_count as usize].iter().enumerate() {
                if let Some((t, u, v)) = intersect_triangle(tri, origin, dir) {
                    if t > 0.0 && t < best.t {
                        best = Hit { t, u, v, triangle: (first + k) as u32 };
                    }
                }
            }
        } else {
            // Visit the nearer child first, the farther one after it (from the stack).
            let l = node.first_index;
            let r = l + 1;
            let (tl, tr) = boxes.pair(nodes, l as usize, best.t);
            let (near, far, t_near, t_far) = if tl <= tr { (l, r, tl, tr) } else { (r, l, tr, tl) };
            if t_far != f32::INFINITY {
                stack[sp].write((far, t_far));
                sp += 1;
            }
            if t_near != f32::INFINITY {
                node_index = near;
                continue;
            }
        }
        // Pop the next node that a hit found since it was pushed does not rule out.
        loop {
            if sp == 0 {
                return (best.triangle != u32::MAX).then_some(best);
            }
            sp -= 1;
            // SAFETY: entries below `sp` were written before (the push site writes before incrementing `sp`).
            let (index, t_entry) = unsafe { stack[sp].assume_init() };
            if t_entry <= best.t {
                node_index = index;
                break;
            }
        }
    }
}

/// True when anything blocks the segment (0, t_max).
pub fn trace_occluded(nodes: &[BvhNode], tris: &[TriangleGeom], origin: Vec3, dir: Vec3, t_max: f32) -> bool {
    let inv_dir = safe_inverse(dir);
    if intersect_aabb(&nodes[0], origin, inv_dir, t_max) == f32::INFINITY {
        return false;
    }
    let boxes = RayBoxes::new(origin, inv_dir);
    // Only nodes whose box the segment enters are visited or pushed, so a popped node needs no second box test.
    let mut stack = stack_storage::<u32>();
    let mut sp = 0usize;
    let mut node_index = 0u32;
    loop {
        let node = &nodes[node_index as usize];
        if node.prim_count > 0 {
            let first = node.first_index as usize;
            for tri in &tris[first..first + node.prim_count as usize] {
                if let Some((t, _, _)) = intersect_triangle(tri, origin, dir) {
                    if t > 0.0 && t < t_max {
                        return true;
                    }
                }
            }
        } else {
            // Test both child boxes here; visit the left one next if the segment enters it, push the right one
            // if it enters that too (any order finds a blocker).
            let l = node.first_index;
            let (tl, tr) = boxes.pair(nodes, l as usize, t_max);
            if tl != f32::INFINITY {
                if tr != f32::INFINITY {
                    stack[sp].write(l + 1);
                    sp += 1;
                }
                node_index = l;
                continue;
            }
            if tr != f32::INFINITY {
                node_index = l + 1;
                continue;
            }
        }
        if sp == 0 {
            return false;
        }
        sp -= 1;
        // SAFETY: entries below `sp` were written before (the push site writes before incrementing `sp`).
        node_index = unsafe { stack[sp].assume_init() };
    }
}
