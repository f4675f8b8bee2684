//! The graphics device: instance, adapter and device creation.
//!
//! The viewer asks for Vulkan and GL only. On machines without a GPU, Mesa provides both in
//! software (lavapipe for Vulkan, llvmpipe for GL), which is what the tests and the benchmark
//! in `docs/explanation/performance.md` run on. `WGPU_BACKEND` and the other wgpu environment variables
//! still override the choice.

use crate::error::{Error, Result};

/// An adapter and the device and queue opened on it. Rendering code takes the device and
/// queue as arguments, so tests can pass their own.
#[derive(Debug)]
pub struct Gpu {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
}

/// The backends tried, in turn: Vulkan (lavapipe on machines without a GPU), then GL only
/// where Vulkan has no adapter, so the same machine always gets the same driver.
pub const BACKENDS: [wgpu::Backends; 2] = [wgpu::Backends::VULKAN, wgpu::Backends::GL];

/// An instance of `backends`, modified by wgpu's environment variables (`WGPU_BACKEND`
/// replaces them). `display` is the window system's connection, which GL needs to present
/// to a window.
pub fn instance(
    backends: wgpu::Backends,
    display: Option<winit::event_loop::OwnedDisplayHandle>,
) -> wgpu::Instance {
    let mut descriptor = match display {
        Some(display) => wgpu::InstanceDescriptor::new_with_display_handle(Box::new(display)),
        None => wgpu::InstanceDescriptor::new_without_display_handle(),
    };
    descriptor.backends = backends;
    wgpu::Instance::new(descriptor.with_env())
}

impl Gpu {
    /// The default adapter for offscreen work (a GPU if there is one).
    pub fn headless() -> Result<Gpu> {
        let mut failures = Vec::new();
        for backends in BACKENDS {
            let instance = instance(backends, None);
            let options = wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            };
            match pollster::block_on(instance.request_adapter(&options)) {
                Ok(adapter) => return Gpu::open(instance, adapter),
                Err(err) => failures.push(format!("{backends:?}: {err}")),
            }
        }
        Err(Error::NoAdapter(failures.join("; ")))
    }

    /// The adapter the tests' golden images were made with: Mesa's software Vulkan driver
    /// (lavapipe), else a software GL driver (llvmpipe), else whatever exists. `None` only
    /// when there is no adapter at all.
    pub fn software() -> Result<Option<Gpu>> {
        let rank = |adapter: &wgpu::Adapter| {
            let info = adapter.get_info();
            let software = info.device_type == wgpu::DeviceType::Cpu;
            match (software, info.backend) {
                (true, wgpu::Backend::Vulkan) => 0,
                (true, _) => 1,
                _ => 2,
            }
        };
        let mut best: Option<(wgpu::Instance, wgpu::Adapter)> = None;
        for backends in BACKENDS {
            let instance = instance(backends, None);
            let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
            if let Some(adapter) = adapters.into_iter().min_by_key(rank) {
                if best.as_ref().is_none_or(|(_, b)| rank(&adapter) < rank(b)) {
                    best = Some((instance, adapter));
                }
            }
            if best.as_ref().is_some_and(|(_, b)| rank(b) == 0) {
                break; // lavapipe: GL has nothing better
            }
        }
        best.map(|(instance, adapter)| Gpu::open(instance, adapter))
            .transpose()
    }

    /// Opens a device with the adapter's own limits (large scenes need large storage
    /// buffers), after checking that it can read storage buffers in vertex shaders.
    pub fn open(instance: wgpu::Instance, adapter: wgpu::Adapter) -> Result<Gpu> {
        let downlevel = adapter.get_downlevel_capabilities();
        if !downlevel
            .flags
            .contains(wgpu::DownlevelFlags::VERTEX_STORAGE)
        {
            return Err(Error::Device(format!(
                "{} cannot read storage buffers in vertex shaders, which the per-vertex transfer needs",
                describe(&adapter)
            )));
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("prt-view"),
            required_features: wgpu::Features::empty(),
            required_limits: adapter.limits(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|err| Error::Device(err.to_string()))?;
        Ok(Gpu {
            instance,
            adapter,
            device,
            queue,
        })
    }

    /// "llvmpipe (LLVM 15.0.6, 256 bits), Vulkan, Cpu": for reports and benchmark tables.
    pub fn description(&self) -> String {
        describe(&self.adapter)
    }
}

fn describe(adapter: &wgpu::Adapter) -> String {
    let info = adapter.get_info();
    format!("{}, {:?}, {:?}", info.name, info.backend, info.device_type)
}
