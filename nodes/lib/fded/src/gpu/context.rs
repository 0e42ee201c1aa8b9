//! Device and adapter plumbing: adapter selection, storage buffers, WGSL compute pipelines and
//! blocking readback. Nothing here knows about fDED; the pipeline in `super::pipeline` builds on it.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use wgpu::util::DeviceExt as _;

use super::{GpuError, Result};

/// Environment variable that forces the fDED backend: `cpu` (never touch a GPU), `gpu` (fail
/// when no adapter exists) or `auto` (the default: GPU when an adapter exists, else CPU).
pub const BACKEND_ENV: &str = "COWORK_FDED_BACKEND";

/// What [`BACKEND_ENV`] asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BackendRequest {
    /// Use the CPU even when an adapter exists.
    Cpu,
    /// Use a GPU adapter; its absence is an error.
    Gpu,
    /// GPU when an adapter exists, else CPU.
    Auto,
}

impl BackendRequest {
    /// Reads [`BACKEND_ENV`]; unset or empty means [`BackendRequest::Auto`].
    pub fn from_env() -> Result<Self> {
        match std::env::var(BACKEND_ENV) {
            Ok(value) => Self::parse(&value),
            Err(std::env::VarError::NotPresent) => Ok(Self::Auto),
            Err(std::env::VarError::NotUnicode(_)) => Err(GpuError::BadBackendEnv {
                value: "<not unicode>".to_owned(),
            }),
        }
    }

    /// Parses `cpu`, `gpu`, `wgpu` or `auto` (case-insensitive; empty means auto).
    pub fn parse(value: &str) -> Result<Self> {
        match value.trim().to_ascii_lowercase().as_str() {
            "cpu" => Ok(Self::Cpu),
            "gpu" | "wgpu" => Ok(Self::Gpu),
            "" | "auto" => Ok(Self::Auto),
            _ => Err(GpuError::BadBackendEnv {
                value: value.to_owned(),
            }),
        }
    }
}

/// A wgpu device and queue on the first usable Vulkan adapter (a software adapter such as
/// Mesa's lavapipe counts).
#[derive(Debug)]
pub struct GpuContext {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    lost: Arc<AtomicBool>,
}

impl GpuContext {
    /// Opens a device, honouring [`BACKEND_ENV`]: `Ok(None)` when it says `cpu` or when no adapter
    /// exists under `auto`; `Err` when it says `gpu` and no adapter exists, or when it is malformed.
    pub fn new() -> Result<Option<Self>> {
        match BackendRequest::from_env()? {
            BackendRequest::Cpu => Ok(None),
            BackendRequest::Auto => Self::open(),
            BackendRequest::Gpu => Self::open()?.map(Some).ok_or(GpuError::NoAdapter),
        }
    }

    /// Opens a device on the first usable adapter, ignoring [`BACKEND_ENV`]; `Ok(None)` when there
    /// is no adapter at all. Cost: tens of milliseconds (driver start-up); do it once.
    pub fn open() -> Result<Option<Self>> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN;
        let instance = wgpu::Instance::new(desc);
        let adapter = match pollster::block_on(
            instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            }),
        ) {
            Ok(adapter) => adapter,
            Err(err) => {
                tracing::debug!(%err, "no wgpu adapter");
                return Ok(None);
            }
        };
        let info = adapter.get_info();
        // Ask for what the adapter offers: the frame buffers are a few MB, far inside any limit,
        // but the workgroup-size and binding-count limits of the defaults are tighter.
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("cowork_fded"),
            required_features: wgpu::Features::empty(),
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|err| GpuError::RequestDevice {
            adapter: info.name.clone(),
            reason: err.to_string(),
        })?;
        let lost = Arc::new(AtomicBool::new(false));
        let lost_flag = Arc::clone(&lost);
        device.set_device_lost_callback(move |reason, message| {
            tracing::error!(?reason, %message, "wgpu device lost");
            lost_flag.store(true, Ordering::Relaxed);
        });
        tracing::info!(adapter = %info.name, backend = ?info.backend, device_type = ?info.device_type, "wgpu device opened");
        Ok(Some(Self {
            device,
            queue,
            info,
            limits,
            lost,
        }))
    }

    /// The adapter's name, e.g. `llvmpipe (LLVM 19.1.7, 256 bits)` for lavapipe.
    pub fn adapter_name(&self) -> &str {
        &self.info.name
    }

    /// Full adapter information.
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// The device limits in force.
    pub fn limits(&self) -> &wgpu::Limits {
        &self.limits
    }

    /// The wgpu device.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The wgpu queue.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Compiles a WGSL module and builds one compute pipeline per entry point, with the layout
    /// inferred from the shader. Validation errors come back as [`GpuError::Shader`].
    pub fn compute_pipelines(
        &self,
        label: &str,
        wgsl: &str,
        entry_points: &[&str],
    ) -> Result<Vec<wgpu::ComputePipeline>> {
        self.build_pipelines(label, wgsl, entry_points, None)
    }

    /// As [`compute_pipelines`](Self::compute_pipelines) with one explicit layout shared by
    /// every entry point (so one bind group serves them all).
    pub fn compute_pipelines_with_layout(
        &self,
        label: &str,
        wgsl: &str,
        entry_points: &[&str],
        layout: &wgpu::PipelineLayout,
    ) -> Result<Vec<wgpu::ComputePipeline>> {
        self.build_pipelines(label, wgsl, entry_points, Some(layout))
    }

    fn build_pipelines(
        &self,
        label: &str,
        wgsl: &str,
        entry_points: &[&str],
        layout: Option<&wgpu::PipelineLayout>,
    ) -> Result<Vec<wgpu::ComputePipeline>> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(wgsl.into()),
            });
        let pipelines = entry_points
            .iter()
            .map(|entry| {
                self.device
                    .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(entry),
                        layout,
                        module: &module,
                        entry_point: Some(entry),
                        compilation_options: wgpu::PipelineCompilationOptions::default(),
                        cache: None,
                    })
            })
            .collect();
        if let Some(err) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Shader {
                module: label.to_owned(),
                reason: err.to_string(),
            });
        }
        Ok(pipelines)
    }

    /// A storage buffer of `size` bytes (rounded up to 4) usable as copy source and destination.
    pub fn storage_buffer(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(4).next_multiple_of(4),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    }

    /// A storage buffer initialised with `data`.
    pub fn storage_buffer_init<T: bytemuck::Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        if bytes.is_empty() {
            return self.storage_buffer(label, 4);
        }
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
            })
    }

    /// A uniform buffer of `size` bytes, written with [`GpuContext::upload`].
    pub fn uniform_buffer(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(16).next_multiple_of(16),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// A mappable buffer that readback copies land in.
    pub fn readback_buffer(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(4).next_multiple_of(4),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Queues a write of `data` at the start of `buffer` (takes effect at the next submit).
    pub fn upload<T: bytemuck::Pod>(&self, buffer: &wgpu::Buffer, data: &[T]) -> Result<()> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        if bytes.len() as u64 > buffer.size() {
            return Err(GpuError::BufferTooSmall {
                buffer: "upload target",
                needed: bytes.len() as u64,
                capacity: buffer.size(),
            });
        }
        if !bytes.is_empty() {
            self.queue.write_buffer(buffer, 0, bytes);
        }
        Ok(())
    }

    /// Blocks until everything submitted so far has finished.
    pub fn wait(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|err| GpuError::Poll {
                reason: err.to_string(),
            })?;
        self.check_lost()
    }

    /// Maps `staging` (already filled by a submitted copy), copies its first `out.len()` elements
    /// into `out` and unmaps it. Blocks on the device.
    pub fn read_mapped<T: bytemuck::Pod>(&self, staging: &wgpu::Buffer, out: &mut [T]) -> Result<()> {
        self.read_mapped_parts(staging, &mut [bytemuck::cast_slice_mut(out)])
    }

    /// Maps `staging` once and copies consecutive byte ranges of it into `parts`, in order
    /// (each part starts where the previous one ended). Blocks on the device.
    pub fn read_mapped_parts(&self, staging: &wgpu::Buffer, parts: &mut [&mut [u8]]) -> Result<()> {
        let bytes: u64 = parts.iter().map(|p| p.len() as u64).sum();
        if bytes == 0 {
            return Ok(());
        }
        if bytes > staging.size() {
            return Err(GpuError::BufferTooSmall {
                buffer: "readback staging",
                needed: bytes,
                capacity: staging.size(),
            });
        }
        let slice = staging.slice(..bytes);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |result| {
            // The receiver lives until after the poll below; a send error cannot happen.
            let _ = tx.send(result);
        });
        self.wait()?;
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(err)) => {
                return Err(GpuError::Map {
                    reason: err.to_string(),
                });
            }
            Err(_) => {
                return Err(GpuError::Map {
                    reason: "map callback never ran".to_owned(),
                });
            }
        }
        {
            let view = slice.get_mapped_range().map_err(|err| GpuError::Map {
                reason: err.to_string(),
            })?;
            let mut src: &[u8] = &view;
            for part in parts.iter_mut() {
                let (head, rest) = src.split_at(part.len());
                part.copy_from_slice(head);
                src = rest;
            }
        }
        staging.unmap();
        Ok(())
    }

    /// Copies `src` to a fresh staging buffer and reads it back: a convenience for tests and
    /// one-off reads (the fDED pipeline keeps its staging buffers).
    pub fn read_buffer<T: bytemuck::Pod>(&self, src: &wgpu::Buffer, out: &mut [T]) -> Result<()> {
        let bytes = std::mem::size_of_val(out) as u64;
        let staging = self.readback_buffer("read_buffer staging", bytes);
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("read_buffer"),
            });
        encoder.copy_buffer_to_buffer(src, 0, &staging, 0, bytes.next_multiple_of(4));
        self.queue.submit([encoder.finish()]);
        self.read_mapped(&staging, out)
    }

    /// Whether the device was lost (driver reset, out of memory): the caller should fall back
    /// to the CPU.
    pub fn is_lost(&self) -> bool {
        self.lost.load(Ordering::Relaxed)
    }

    fn check_lost(&self) -> Result<()> {
        if self.is_lost() {
            Err(GpuError::DeviceLost)
        } else {
            Ok(())
        }
    }
}
