//! Typed storage buffers in device memory: create, upload, download, zero.
//! Host-mapped coherent memory (lavapipe, integrated GPUs, resizable BAR) is copied directly;
//! anything else goes through a temporary staging buffer and a transfer on the queue.

use std::marker::PhantomData;
use std::sync::Arc;

use ash::vk;
use bytemuck::Pod;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use crate::context::{Context, ContextInner};
use crate::error::{Result, VkError, VkResultExt};

/// A Vulkan buffer with its memory; the untyped core of [`Buffer`] and of staging buffers.
pub(crate) struct RawBuffer {
    ctx: Arc<ContextInner>,
    pub(crate) handle: vk::Buffer,
    allocation: Option<Allocation>,
    /// Size of the Vulkan buffer: the data size rounded up to 4 bytes, at least 4 (Vulkan forbids empty buffers).
    pub(crate) bytes: u64,
    pub(crate) name: String,
}

impl RawBuffer {
    pub(crate) fn new(
        ctx: &Arc<ContextInner>,
        name: &str,
        data_bytes: u64,
        location: MemoryLocation,
        usage: vk::BufferUsageFlags,
    ) -> Result<Self> {
        let bytes = data_bytes.max(4).next_multiple_of(4);
        let max = ctx.caps.max_storage_buffer_range;
        if usage.contains(vk::BufferUsageFlags::STORAGE_BUFFER) && bytes > max {
            return Err(VkError::BufferTooLarge { name: name.into(), bytes, max });
        }
        let d = &ctx.device;
        let info = vk::BufferCreateInfo::default().size(bytes).usage(usage).sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        let handle = unsafe { d.create_buffer(&info, None) }.call("vkCreateBuffer")?;
        // SAFETY: `handle` was just created on this device.
        let requirements = unsafe { d.get_buffer_memory_requirements(handle) };
        let allocated = ctx.lock_allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear: true,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        });
        let allocation = match allocated {
            Ok(a) => a,
            Err(source) => {
                // SAFETY: unbound, unused buffer.
                unsafe { d.destroy_buffer(handle, None) };
                return Err(VkError::Allocation { name: name.into(), source });
            }
        };
        // Constructed before binding so that Drop cleans up if binding fails.
        let raw = Self { ctx: ctx.clone(), handle, allocation: Some(allocation), bytes, name: name.into() };
        let a = raw.allocation.as_ref().expect("just set");
        // SAFETY: memory from the allocator satisfies `requirements`; offset is the allocation's own.
        unsafe { d.bind_buffer_memory(handle, a.memory(), a.offset()) }.call("vkBindBufferMemory")?;
        Ok(raw)
    }

    /// Host pointer to the buffer's bytes when its memory is mapped and coherent (no flushes needed).
    pub(crate) fn mapped(&self) -> Option<*mut u8> {
        let a = self.allocation.as_ref()?;
        if !a.memory_properties().contains(vk::MemoryPropertyFlags::HOST_COHERENT) {
            return None;
        }
        a.mapped_ptr().map(|p| p.as_ptr().cast::<u8>())
    }

    /// Mapped pointer unless the context forces the staging path.
    fn direct(&self) -> Option<*mut u8> {
        if self.ctx.force_staging {
            None
        } else {
            self.mapped()
        }
    }

    fn staging(&self, bytes: u64, location: MemoryLocation) -> Result<(RawBuffer, *mut u8)> {
        let usage = match location {
            MemoryLocation::CpuToGpu => vk::BufferUsageFlags::TRANSFER_SRC,
            _ => vk::BufferUsageFlags::TRANSFER_DST,
        };
        let staging = RawBuffer::new(&self.ctx, &format!("{} (staging)", self.name), bytes, location, usage)?;
        let ptr = staging.mapped().ok_or_else(|| VkError::Allocation {
            name: staging.name.clone(),
            source: gpu_allocator::AllocationError::FailedToMap("staging memory is not host-coherent".into()),
        })?;
        Ok((staging, ptr))
    }

    /// Copies `src` into the buffer at byte `offset`. Caller checked the range.
    fn write_bytes(&mut self, offset: u64, src: &[u8]) -> Result<()> {
        if src.is_empty() {
            return Ok(());
        }
        if let Some(ptr) = self.direct() {
            // SAFETY: `offset + src.len() <= bytes` (checked by the caller) inside a live mapping; `&mut self`
            // means no batch borrows this buffer, and submissions are waited for, so the GPU is not using it.
            unsafe { std::ptr::copy_nonoverlapping(src.as_ptr(), ptr.add(offset as usize), src.len()) };
            return Ok(());
        }
        let (staging, ptr) = self.staging(src.len() as u64, MemoryLocation::CpuToGpu)?;
        // SAFETY: the staging mapping holds at least `src.len()` bytes and nothing else uses it yet.
        unsafe { std::ptr::copy_nonoverlapping(src.as_ptr(), ptr, src.len()) };
        let region = vk::BufferCopy::default().src_offset(0).dst_offset(offset).size(src.len() as u64);
        self.ctx.submit_and_wait(|d, cmd| {
            // SAFETY: both buffers are live and large enough for `region`.
            unsafe { d.cmd_copy_buffer(cmd, staging.handle, self.handle, &[region]) };
            Ok(())
        })
    }

    /// Copies bytes from `offset` out of the buffer into `dst`. Caller checked the range.
    fn read_bytes(&self, offset: u64, dst: &mut [u8]) -> Result<()> {
        if dst.is_empty() {
            return Ok(());
        }
        if let Some(ptr) = self.direct() {
            // SAFETY: range inside a live mapping (checked by the caller); every submission is waited for and ends
            // with a host-read barrier, so device writes are visible.
            unsafe { std::ptr::copy_nonoverlapping(ptr.add(offset as usize), dst.as_mut_ptr(), dst.len()) };
            return Ok(());
        }
        let (staging, ptr) = self.staging(dst.len() as u64, MemoryLocation::GpuToCpu)?;
        let region = vk::BufferCopy::default().src_offset(offset).dst_offset(0).size(dst.len() as u64);
        self.ctx.submit_and_wait(|d, cmd| {
            // SAFETY: both buffers are live and large enough for `region`.
            unsafe { d.cmd_copy_buffer(cmd, self.handle, staging.handle, &[region]) };
            Ok(())
        })?;
        // SAFETY: the copy finished (waited) and the staging mapping holds `dst.len()` bytes.
        unsafe { std::ptr::copy_nonoverlapping(ptr, dst.as_mut_ptr(), dst.len()) };
        Ok(())
    }

    fn zero(&mut self) -> Result<()> {
        if let Some(ptr) = self.direct() {
            // SAFETY: the whole mapping is `bytes` long; not in use by the GPU (see write_bytes).
            unsafe { std::ptr::write_bytes(ptr, 0, self.bytes as usize) };
            return Ok(());
        }
        self.ctx.submit_and_wait(|d, cmd| {
            // SAFETY: live buffer created with TRANSFER_DST.
            unsafe { d.cmd_fill_buffer(cmd, self.handle, 0, vk::WHOLE_SIZE, 0) };
            Ok(())
        })
    }
}

impl Drop for RawBuffer {
    fn drop(&mut self) {
        // SAFETY: no submission is in flight that uses this buffer: batches borrow buffers until they have been
        // waited for. The buffer is destroyed before its memory is returned to the allocator.
        unsafe { self.ctx.device.destroy_buffer(self.handle, None) };
        if let Some(a) = self.allocation.take() {
            if let Err(e) = self.ctx.lock_allocator().free(a) {
                eprintln!("psdr-vk: freeing buffer {:?} failed: {e}", self.name);
            }
        }
    }
}

/// A storage buffer of `len` values of `T`, laid out exactly as `bytemuck` sees `T`
/// (make `T` `#[repr(C)]` and match it with a std430 struct in GLSL).
pub struct Buffer<T: Pod> {
    pub(crate) raw: RawBuffer,
    len: usize,
    _elements: PhantomData<T>,
}

impl<T: Pod> Buffer<T> {
    /// A buffer of `len` zeroes.
    pub fn zeroed(ctx: &Context, name: &str, len: usize) -> Result<Self> {
        let mut b = Self::uninit(ctx, name, len)?;
        b.raw.zero()?;
        Ok(b)
    }

    /// A buffer holding a copy of `data`.
    pub fn from_slice(ctx: &Context, name: &str, data: &[T]) -> Result<Self> {
        let mut b = Self::uninit(ctx, name, data.len())?;
        b.upload(data)?;
        Ok(b)
    }

    fn uninit(ctx: &Context, name: &str, len: usize) -> Result<Self> {
        let bytes = (len as u64).saturating_mul(std::mem::size_of::<T>() as u64);
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_SRC
            | vk::BufferUsageFlags::TRANSFER_DST;
        Ok(Self {
            raw: RawBuffer::new(&ctx.inner, name, bytes, MemoryLocation::GpuOnly, usage)?,
            len,
            _elements: PhantomData,
        })
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Bytes of data (`len * size_of::<T>()`).
    pub fn size_bytes(&self) -> u64 {
        (self.len * std::mem::size_of::<T>()) as u64
    }

    pub fn name(&self) -> &str {
        &self.raw.name
    }

    /// True when uploads and downloads are plain memory copies (no staging buffer, no queue submission).
    pub fn is_host_mapped(&self) -> bool {
        self.raw.direct().is_some()
    }

    /// Replaces the whole contents; `data.len()` must equal `len()`.
    pub fn upload(&mut self, data: &[T]) -> Result<()> {
        self.check_len("upload", self.len, data.len())?;
        self.raw.write_bytes(0, bytemuck::cast_slice(data))
    }

    /// Writes `data` starting at element `first`.
    pub fn upload_at(&mut self, first: usize, data: &[T]) -> Result<()> {
        self.check_range("upload_at", first, data.len())?;
        self.raw.write_bytes((first * std::mem::size_of::<T>()) as u64, bytemuck::cast_slice(data))
    }

    /// Reads the whole contents.
    pub fn download(&self) -> Result<Vec<T>> {
        let mut out = vec![T::zeroed(); self.len];
        self.download_into(&mut out)?;
        Ok(out)
    }

    /// Reads the whole contents into `out` (`out.len()` must equal `len()`), reusing the caller's memory.
    pub fn download_into(&self, out: &mut [T]) -> Result<()> {
        self.check_len("download_into", self.len, out.len())?;
        self.raw.read_bytes(0, bytemuck::cast_slice_mut(out))
    }

    /// Reads `count` elements starting at element `first`.
    pub fn download_range(&self, first: usize, count: usize) -> Result<Vec<T>> {
        self.check_range("download_range", first, count)?;
        let mut out = vec![T::zeroed(); count];
        self.raw.read_bytes((first * std::mem::size_of::<T>()) as u64, bytemuck::cast_slice_mut(&mut out))?;
        Ok(out)
    }

    /// Sets every byte to zero now (inside a [`crate::Batch`], use `Batch::fill_zero` instead).
    pub fn fill_zero(&mut self) -> Result<()> {
        self.raw.zero()
    }

    fn check_len(&self, what: &'static str, expected: usize, got: usize) -> Result<()> {
        if expected != got {
            return Err(VkError::LengthMismatch { name: self.raw.name.clone(), what, expected, got });
        }
        Ok(())
    }

    fn check_range(&self, what: &'static str, first: usize, count: usize) -> Result<()> {
        match first.checked_add(count) {
            Some(end) if end <= self.len => Ok(()),
            _ => Err(VkError::LengthMismatch {
                name: self.raw.name.clone(),
                what,
                expected: self.len.saturating_sub(first),
                got: count,
            }),
        }
    }
}

impl<T: Pod> std::fmt::Debug for Buffer<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Buffer")
            .field("name", &self.raw.name)
            .field("len", &self.len)
            .field("element_bytes", &std::mem::size_of::<T>())
            .finish()
    }
}

/// A whole buffer as bound to a kernel's storage-buffer binding.
#[derive(Clone, Copy)]
pub struct BufferBinding<'a> {
    pub(crate) handle: vk::Buffer,
    pub(crate) range: u64,
    pub(crate) ctx_id: usize,
    pub(crate) name: &'a str,
}

/// Anything that can be bound as a storage buffer: lets one slice hold buffers of different element types,
/// as in `kernel.dispatch(&[&nodes, &triangles, &image], ...)`.
pub trait StorageBinding: sealed::Sealed {
    fn binding(&self) -> BufferBinding<'_>;
}

impl<T: Pod> StorageBinding for Buffer<T> {
    fn binding(&self) -> BufferBinding<'_> {
        BufferBinding {
            handle: self.raw.handle,
            range: self.raw.bytes,
            ctx_id: self.raw.ctx.id(),
            name: &self.raw.name,
        }
    }
}

mod sealed {
    pub trait Sealed {}
    impl<T: bytemuck::Pod> Sealed for super::Buffer<T> {}
}
