//! Synchronous buffer readback: copy into a mappable buffer, map, copy out.

use crate::device::{Gpu, GpuError};

/// A MAP_READ | COPY_DST buffer of `size` bytes.
pub fn staging(gpu: &Gpu, label: &str, size: u64) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Maps the first `size` bytes of `buffer` (after the submitted copies into it complete) and
/// passes them to `f`.
pub fn read<T>(gpu: &Gpu, buffer: &wgpu::Buffer, size: u64, f: impl FnOnce(&[u8]) -> T) -> Result<T, GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, ..size, move |r| {
        let _ = tx.send(r);
    });
    gpu.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Readback(e.to_string()))?;
    rx.recv().map_err(|e| GpuError::Readback(e.to_string()))?.map_err(|e| GpuError::Readback(e.to_string()))?;
    let out = {
        let view = buffer.get_mapped_range(..size).map_err(|e| GpuError::Readback(format!("{e:?}")))?;
        f(&view)
    };
    buffer.unmap();
    gpu.check()?;
    Ok(out)
}
