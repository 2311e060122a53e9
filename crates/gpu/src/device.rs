//! Device set-up: prefer a hardware adapter, fall back to a software one (lavapipe), or take
//! the one named by `--adapter`. Features the renderer needs are requested when the adapter
//! has them; what is missing is reported by [`Gpu::missing`].

use std::sync::{Arc, Mutex};

/// Why no device could be made.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no Vulkan adapter found: install a Vulkan driver (on Debian/Ubuntu without a GPU: `apt-get install -y mesa-vulkan-drivers libvulkan1`)"
    )]
    NoAdapter,
    #[error("no adapter matches {wanted:?}; available: {available}")]
    NoSuchAdapter { wanted: String, available: String },
    #[error("adapter {adapter} lacks {what}, which osw needs")]
    Missing { adapter: String, what: String },
    #[error("could not create a device on {adapter}: {source}")]
    RequestDevice { adapter: String, source: wgpu::RequestDeviceError },
    #[error("GPU readback failed: {0}")]
    Readback(String),
    #[error("GPU error: {0}")]
    Device(String),
}

/// A device and its queue, and the instance and adapter they came from (a window's surface
/// is made from them).
pub struct Gpu {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub features: wgpu::Features,
    first_error: Arc<Mutex<Option<String>>>,
}

/// Features the exact box test and the item buffer need.
pub const WANTED: wgpu::Features = wgpu::Features::SHADER_EARLY_DEPTH_TEST.union(wgpu::Features::PRIMITIVE_INDEX);

/// Features used where the adapter has them: pipeline statistics count a pass's fragments
/// (`RenderOptions::count_fragments`), timestamps time a pass on the GPU (`RenderOptions::time_gpu`),
/// 64-bit floats place an instance's vertices exactly as its placed copy would be
/// (`crate::uses`).
pub const OPTIONAL: wgpu::Features =
    wgpu::Features::PIPELINE_STATISTICS_QUERY.union(wgpu::Features::TIMESTAMP_QUERY).union(wgpu::Features::SHADER_F64);

/// A software adapter (lavapipe) mallocs each draw's vertex and binning memory and frees it
/// when the draw is done; glibc then hands the freed top of its heaps back to the kernel, and
/// the next draw takes every page again as a zeroed page fault. Heaps are kept instead (their
/// peak stays resident, as it would be on a GPU): a third of the page faults
/// (docs/measurements/2026-12-04-instances-10b-walk.md).
fn keep_freed_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt sets one of glibc's malloc parameters; every value of this one is valid.
    unsafe {
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
    }
}

/// Mesa's implicit device-select layer asks a Wayland compositor which GPU drives the display,
/// and on a host without `XDG_RUNTIME_DIR` (a headless server) libwayland prints "error:
/// XDG_RUNTIME_DIR is invalid or not set" for every adapter list, though nothing failed. osw
/// picks its adapter itself (`--adapter`) and its window is X11, so where no compositor can be
/// reached the loader is told to leave the layer out (`NODEVICE_SELECT=1`, the layer's own
/// switch). Processes osw starts inherit it. Call first in `main`, before any other thread.
pub fn quiet_device_select() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() && std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: called first in main, while no other thread can read the environment.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

impl Gpu {
    /// Opens an adapter: `name` picks the first whose name contains it (case-insensitive);
    /// `None` prefers a hardware adapter and falls back to a software one.
    pub fn new(name: Option<&str>) -> Result<Gpu, GpuError> {
        Gpu::with_instance(name, wgpu::InstanceDescriptor::new_without_display_handle())
    }

    /// As [`Gpu::new`], on an instance that can make surfaces for windows of `display`.
    pub fn for_display(name: Option<&str>, display: Box<dyn wgpu::wgt::WgpuHasDisplayHandle>) -> Result<Gpu, GpuError> {
        Gpu::with_instance(name, wgpu::InstanceDescriptor::new_with_display_handle(display))
    }

    fn with_instance(name: Option<&str>, mut desc: wgpu::InstanceDescriptor) -> Result<Gpu, GpuError> {
        desc.backends = wgpu::Backends::VULKAN;
        let instance = wgpu::Instance::new(desc);
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter);
        }
        let rank = |a: &wgpu::Adapter| match a.get_info().device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Other => 3,
            wgpu::DeviceType::Cpu => 4,
        };
        let adapter = match name {
            Some(want) => {
                let names = adapters.iter().map(|a| a.get_info().name).collect::<Vec<_>>().join(", ");
                adapters
                    .into_iter()
                    .find(|a| a.get_info().name.to_lowercase().contains(&want.to_lowercase()))
                    .ok_or(GpuError::NoSuchAdapter { wanted: want.to_owned(), available: names })?
            }
            None => adapters.into_iter().min_by_key(rank).ok_or(GpuError::NoAdapter)?,
        };
        let info = adapter.get_info();
        if info.device_type == wgpu::DeviceType::Cpu {
            keep_freed_heap();
        }
        let features = adapter.features() & (WANTED | OPTIONAL);
        if !features.contains(WANTED) {
            return Err(GpuError::Missing { adapter: info.name.clone(), what: format!("{:?}", WANTED - features) });
        }
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: adapter.limits().max_storage_buffer_binding_size,
            // The vertex arena and a pass's indices are one buffer each.
            max_buffer_size: adapter.limits().max_buffer_size,
            // The texture atlas's pages are one array (crate::atlas).
            max_texture_array_layers: adapter.limits().max_texture_array_layers,
            ..wgpu::Limits::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("osw"),
            required_features: features,
            required_limits: limits,
            ..Default::default()
        }))
        .map_err(|source| GpuError::RequestDevice { adapter: info.name.clone(), source })?;
        // wgpu panics on an uncaptured error by default; keep the first one instead and
        // report it from the next wait, so a GPU error is an error message, not a crash.
        let first_error = Arc::new(Mutex::new(None));
        let slot = Arc::clone(&first_error);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut s = slot.lock().unwrap_or_else(|p| p.into_inner());
            s.get_or_insert_with(|| e.to_string());
        }));
        Ok(Gpu { instance, adapter, device, queue, info, features, first_error })
    }

    /// Waits until the GPU has finished all submitted work; reports the first GPU error since
    /// the device was made.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Device(e.to_string()))?;
        self.check()
    }

    /// The first GPU error since the device was made, if any.
    pub fn check(&self) -> Result<(), GpuError> {
        match self.first_error.lock().unwrap_or_else(|p| p.into_inner()).as_ref() {
            Some(e) => Err(GpuError::Device(e.clone())),
            None => Ok(()),
        }
    }
}
