//! Buffer layouts shared by the CPU renderer and the Vulkan kernels.
//! GLSL twin: shaders/render/layout.glsl (std430). Field order, sizes and padding must match exactly;
//! the layout round-trip test in tests/ writes these from Rust and reads them back from a kernel.

use bytemuck::{Pod, Zeroable};

/// Marks "no index" in u32 fields (no light, no texture, no object).
pub const NONE: u32 = u32::MAX;

/// A BVH node: obvhs `CwBvhNode`, a compressed 8-wide node (Ylitie et al. 2017; 80 bytes): the node's grid
/// origin `p` and power-of-two scales `e`, which slots hold inner children (`imask`), the index of the first
/// child node and first triangle, per-slot meta bytes (inner: 24 + slot; leaf: unary triangle count in bits
/// 5-7, offset from the first triangle in bits 0-4) and the child boxes as 8-bit grid coordinates.
pub type BvhNode = obvhs::cwbvh::node::CwBvhNode;

/// Triangle data needed for intersection, in world space (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct TriangleGeom {
    pub v0: [f32; 3],
    pub material: u32,
    pub e1: [f32; 3],
    pub object: u32,
    pub e2: [f32; 3],
    /// Index into the light list, or NONE when the triangle does not emit.
    pub light: u32,
}

/// Per-vertex shading attributes of a triangle and its per-triangle frame (128 bytes, two cache lines).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct TriangleShading {
    pub n0: [f32; 3],
    /// SHADING_HAS_NORMALS: vertex normals (else flat shading); SHADING_HAS_UVS; SHADING_HAS_TANGENT.
    pub flags: u32,
    pub n1: [f32; 3],
    /// Index into the emitter list, or NONE.
    pub emitter: u32,
    pub n2: [f32; 3],
    pub _pad0: u32,
    pub uv0: [f32; 2],
    pub uv1: [f32; 2],
    pub uv2: [f32; 2],
    pub _pad1: [u32; 2],
    /// Unit geometric normal, on the winding side: `(e1 x e2).normalize()`, once per triangle instead of at
    /// every hit (it sat on the critical path of every shading point).
    pub ng: [f32; 3],
    pub _pad2: u32,
    /// dp/du' and dp/dv' for the material's transformed uv (the tangent frame's directions before
    /// orthonormalisation), when the flags have SHADING_HAS_TANGENT (uvs, and a non-degenerate uv map).
    pub dpdu: [f32; 3],
    pub _pad3: u32,
    pub dpdv: [f32; 3],
    pub _pad4: u32,
}

pub const SHADING_HAS_NORMALS: u32 = 1;
pub const SHADING_HAS_UVS: u32 = 2;
pub const SHADING_HAS_TANGENT: u32 = 4;

/// A material (80 bytes). Texture indices are NONE for constants.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct MaterialGpu {
    pub albedo: [f32; 3],
    pub albedo_tex: u32,
    pub roughness: f32,
    pub roughness_tex: u32,
    pub specular: f32,
    pub specular_tex: u32,
    pub normal_tex: u32,
    pub _pad: [u32; 3],
    /// uv' = (row0.x u + row0.y v + row0.z, row1.x u + row1.y v + row1.z).
    pub uv_row0: [f32; 4],
    pub uv_row1: [f32; 4],
}

/// Where a texture's texels start in the shared texel buffer (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct TextureGpu {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub channels: u32,
}

/// An area emitter (32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct EmitterGpu {
    pub radiance: [f32; 3],
    pub two_sided: u32,
    /// `scene::Emitter::sky_gradient`.
    pub sky_gradient: [f32; 3],
    pub _pad0: f32,
}

/// One emitting triangle in the light-selection distribution (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct LightGpu {
    pub triangle: u32,
    pub emitter: u32,
    /// Inclusive prefix sum of selection probabilities (the last light's cdf is 1).
    pub cdf: f32,
    /// Probability of selecting this light.
    pub pmf: f32,
}

/// Pinhole camera (64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct CameraGpu {
    pub origin: [f32; 3],
    pub tan_half_fov: f32,
    pub forward: [f32; 3],
    pub aspect: f32,
    pub right: [f32; 3],
    pub width: u32,
    pub up: [f32; 3],
    pub height: u32,
}

/// Per-frame constants (push constants on the GPU, 32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct FrameParams {
    pub seed: u32,
    pub spp: u32,
    pub max_depth: u32,
    pub rr_depth: u32,
    pub light_count: u32,
    pub object_count: u32,
    /// First sample index of this pass (the GPU renders in passes of samples).
    pub sample_begin: u32,
    /// Number of samples in this pass.
    pub sample_count: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_are_multiples_of_16_for_std430_arrays() {
        assert_eq!(std::mem::size_of::<BvhNode>(), 80);
        assert_eq!(std::mem::size_of::<TriangleGeom>(), 48);
        assert_eq!(std::mem::size_of::<TriangleShading>(), 128);
        assert_eq!(std::mem::size_of::<MaterialGpu>(), 80);
        assert_eq!(std::mem::size_of::<TextureGpu>(), 16);
        assert_eq!(std::mem::size_of::<EmitterGpu>(), 32);
        assert_eq!(std::mem::size_of::<LightGpu>(), 16);
        assert_eq!(std::mem::size_of::<CameraGpu>(), 64);
        assert_eq!(std::mem::size_of::<FrameParams>(), 32);
    }
}
