//! std430 layout round trip: Rust `#[repr(C)]` Pod structs written to buffers, transformed field by field by
//! `shaders/std430_layout.comp`, read back and compared bit-exactly. The renderer's shared structs (BVH nodes,
//! materials, lights) follow the same pattern: keep each Rust twin and its GLSL struct field-for-field equal.

mod common;

use bytemuck::{Pod, Zeroable};
use common::{assert_no_validation_errors, context};
use psdr_vk::{include_spirv, Buffer, Groups, Kernel};

/// GLSL `Node`: `vec3 bmin; uint prim_count; vec3 bmax; uint first_index;` (32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
struct Node {
    bmin: [f32; 3],
    prim_count: u32,
    bmax: [f32; 3],
    first_index: u32,
}

/// GLSL `Material`: `vec4 albedo; vec2 uv_scale; float roughness; uint flags;` (32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
struct Material {
    albedo: [f32; 4],
    uv_scale: [f32; 2],
    roughness: f32,
    flags: u32,
}

/// GLSL `Mixed`: `float a; vec2 b; float c;`. std430 aligns vec2 to 8 bytes and the struct size to its
/// alignment, so Rust needs explicit padding after `a` and after `c` (24 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
struct Mixed {
    a: f32,
    _pad0: u32,
    b: [f32; 2],
    c: f32,
    _pad1: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Push {
    nodes: u32,
    materials: u32,
    mixed: u32,
    scale: f32,
}

const _: () = assert!(std::mem::size_of::<Node>() == 32);
const _: () = assert!(std::mem::size_of::<Material>() == 32);
const _: () = assert!(std::mem::size_of::<Mixed>() == 24);

/// Distinct, exactly representable values per element and field.
fn f(i: usize, k: usize) -> f32 {
    (i * 8 + k) as f32 * 0.125 - 3.0
}

#[test]
fn std430_structs_round_trip_exactly() {
    let Some(ctx) = context("std430_structs_round_trip_exactly") else {
        return;
    };
    let kernel: Kernel<Push> =
        Kernel::new(&ctx, "std430_layout", &include_spirv!("std430_layout").unwrap(), 6).unwrap();
    let (n_nodes, n_materials, n_mixed) = (100usize, 37usize, 65usize);
    let nodes: Vec<Node> = (0..n_nodes)
        .map(|i| Node {
            bmin: [f(i, 0), f(i, 1), f(i, 2)],
            prim_count: i as u32 * 3 + 1,
            bmax: [f(i, 3), f(i, 4), f(i, 5)],
            first_index: 1000 + i as u32,
        })
        .collect();
    let materials: Vec<Material> = (0..n_materials)
        .map(|i| Material {
            albedo: [f(i, 0), f(i, 1), f(i, 2), f(i, 3)],
            uv_scale: [f(i, 4), f(i, 5)],
            roughness: (i as f32) / 64.0,
            flags: 0x1234_5600 | i as u32,
        })
        .collect();
    let mixed: Vec<Mixed> =
        (0..n_mixed).map(|i| Mixed { a: f(i, 0), _pad0: 0, b: [f(i, 1), f(i, 2)], c: f(i, 3), _pad1: 0 }).collect();
    let push = Push { nodes: n_nodes as u32, materials: n_materials as u32, mixed: n_mixed as u32, scale: 2.0 };

    let nodes_in = Buffer::from_slice(&ctx, "nodes_in", &nodes).unwrap();
    let materials_in = Buffer::from_slice(&ctx, "materials_in", &materials).unwrap();
    let mixed_in = Buffer::from_slice(&ctx, "mixed_in", &mixed).unwrap();
    let nodes_out = Buffer::<Node>::zeroed(&ctx, "nodes_out", n_nodes).unwrap();
    let materials_out = Buffer::<Material>::zeroed(&ctx, "materials_out", n_materials).unwrap();
    let mixed_out = Buffer::<Mixed>::zeroed(&ctx, "mixed_out", n_mixed).unwrap();
    kernel
        .dispatch(
            &[&nodes_in, &materials_in, &mixed_in, &nodes_out, &materials_out, &mixed_out],
            &push,
            Groups::linear(2), // 128 invocations of 64 cover the longest array
        )
        .unwrap();

    // The CPU twin of the kernel's transforms.
    let expected_nodes: Vec<Node> = nodes
        .iter()
        .map(|n| Node {
            bmin: n.bmin.map(|v| v + 1.0),
            prim_count: n.prim_count * 2,
            bmax: n.bmax.map(|v| v * push.scale),
            first_index: n.first_index + 7,
        })
        .collect();
    let expected_materials: Vec<Material> = materials
        .iter()
        .map(|m| Material {
            albedo: [m.albedo[2], m.albedo[1], m.albedo[0], m.albedo[3]],
            uv_scale: m.uv_scale.map(|v| v * push.scale),
            roughness: 1.0 - m.roughness,
            flags: m.flags ^ 0xff,
        })
        .collect();
    let expected_mixed: Vec<Mixed> =
        mixed.iter().map(|x| Mixed { a: x.b[0], _pad0: 0, b: [x.c, x.a], c: x.b[1], _pad1: 0 }).collect();

    assert_eq!(nodes_out.download().unwrap(), expected_nodes);
    assert_eq!(materials_out.download().unwrap(), expected_materials);
    // Padding is never written by the kernel: it stays as zero-filled, so a whole-struct compare works.
    assert_eq!(mixed_out.download().unwrap(), expected_mixed);
    assert_no_validation_errors(&ctx);
}
