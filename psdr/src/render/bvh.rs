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
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv_det = 1.0 / det;
    let s = origin - Vec3::from(tri.v0);
    let u = s.dot(p) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv_det;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv_det;
    Some((t, u, v))
}

/// Closest hit with t in (0, t_max). Counts nothing; callers count rays.
pub fn trace_closest(nodes: &[BvhNode], tris: &[TriangleGeom], origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
    let inv_dir = safe_inverse(dir);
    let mut best = Hit { t: t_max, u: 0.0, v: 0.0, triangle: u32::MAX };
    // Each stack entry keeps the entry distance of its box, computed when its parent was visited: a popped
    // node is skipped when a hit found since then is nearer (the same test as re-intersecting its box).
    let mut stack = [0u32; BVH_STACK_SIZE];
    let mut stack_t = [0.0f32; BVH_STACK_SIZE];
    let mut sp = 1usize;
    stack[0] = 0;
    stack_t[0] = intersect_aabb(&nodes[0], origin, inv_dir, best.t);
    if stack_t[0] == f32::INFINITY {
        return None;
    }
    while sp > 0 {
        sp -= 1;
        if stack_t[sp] > best.t {
            continue;
        }
        let node = &nodes[stack[sp] as usize];
        if node.prim_count > 0 {
            for i in node.first_index..node.first_index + node.prim_count {
                if let Some((t, u, v)) = intersect_triangle(&tris[i as usize], origin, dir) {
                    if t > 0.0 && t < best.t {
                        best = Hit { t, u, v, triangle: i };
                    }
                }
            }
        } else {
            // Visit the nearer child first: push it last.
            let l = node.first_index;
            let r = l + 1;
            let tl = intersect_aabb(&nodes[l as usize], origin, inv_dir, best.t);
            let tr = intersect_aabb(&nodes[r as usize], origin, inv_dir, best.t);
            let (near, far, t_near, t_far) = if tl <= tr { (l, r, tl, tr) } else { (r, l, tr, tl) };
            if t_far != f32::INFINITY {
                (stack[sp], stack_t[sp]) = (far, t_far);
                sp += 1;
            }
            if t_near != f32::INFINITY {
                (stack[sp], stack_t[sp]) = (near, t_near);
                sp += 1;
            }
        }
    }
    (best.triangle != u32::MAX).then_some(best)
}

/// True when anything blocks the segment (0, t_max).
pub fn trace_occluded(nodes: &[BvhNode], tris: &[TriangleGeom], origin: Vec3, dir: Vec3, t_max: f32) -> bool {
    let inv_dir = safe_inverse(dir);
    if intersect_aabb(&nodes[0], origin, inv_dir, t_max) == f32::INFINITY {
        return false;
    }
    // Only nodes whose box the segment enters are pushed, so a popped node needs no second box test.
    let mut stack = [0u32; BVH_STACK_SIZE];
    let mut sp = 1usize;
    stack[0] = 0;
    while sp > 0 {
        sp -= 1;
        let node = &nodes[stack[sp] as usize];
        if node.prim_count > 0 {
            for i in node.first_index..node.first_index + node.prim_count {
                if let Some((t, _, _)) = intersect_triangle(&tris[i as usize], origin, dir) {
                    if t > 0.0 && t < t_max {
                        return true;
                    }
                }
            }
        } else {
            // Test both child boxes here and push only those the segment enters (any order finds a blocker).
            let l = node.first_index;
            if intersect_aabb(&nodes[l as usize], origin, inv_dir, t_max) != f32::INFINITY {
                stack[sp] = l;
                sp += 1;
            }
            if intersect_aabb(&nodes[l as usize + 1], origin, inv_dir, t_max) != f32::INFINITY {
                stack[sp] = l + 1;
                sp += 1;
            }
        }
    }
    false
}
