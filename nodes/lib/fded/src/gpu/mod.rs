//! wgpu compute path of fDED (thesis Sec. 5.1.2): the distance stages (5: lattice minimum, 6:
//! refinement over the winning tile) as WGSL compute shaders on any Vulkan adapter (Mesa's
//! lavapipe software adapter included), on the lattices the host builds with the CPU
//! reference's own stages 1–4; stage 7 also runs on the host.
//!
//! [`GpuContext`] owns the device; it is `None` when no adapter exists (or when
//! `COWORK_FDED_BACKEND=cpu`), and the caller then runs the CPU path.

mod context;
mod engine;
mod pipeline;

pub use context::{BACKEND_ENV, BackendRequest, GpuContext};
pub use engine::FdedEngine;
pub use pipeline::GpuFded;

/// Errors of the GPU path. Every one of them means "use the CPU path for this frame".
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    /// `COWORK_FDED_BACKEND` holds something other than `cpu`, `gpu` or `auto`.
    #[error("COWORK_FDED_BACKEND={value:?}: expected cpu, gpu or auto")]
    BadBackendEnv {
        /// The value found.
        value: String,
    },
    /// The GPU backend was forced but no adapter exists.
    #[error("COWORK_FDED_BACKEND=gpu but no wgpu (Vulkan) adapter was found")]
    NoAdapter,
    /// The adapter refused to open a device.
    #[error("wgpu adapter {adapter:?} refused a device: {reason}")]
    RequestDevice {
        /// Adapter name.
        adapter: String,
        /// wgpu's message.
        reason: String,
    },
    /// A WGSL module or pipeline failed validation.
    #[error("WGSL module {module:?} failed validation: {reason}")]
    Shader {
        /// Module label.
        module: String,
        /// wgpu's message.
        reason: String,
    },
    /// A buffer is smaller than the data meant for it.
    #[error("GPU buffer {buffer} too small: {needed} bytes needed, {capacity} available")]
    BufferTooSmall {
        /// Which buffer.
        buffer: &'static str,
        /// Bytes needed.
        needed: u64,
        /// Bytes available.
        capacity: u64,
    },
    /// Mapping a readback buffer failed.
    #[error("mapping a GPU readback buffer failed: {reason}")]
    Map {
        /// wgpu's message.
        reason: String,
    },
    /// Waiting on the device failed.
    #[error("waiting on the GPU failed: {reason}")]
    Poll {
        /// wgpu's message.
        reason: String,
    },
    /// The device was lost.
    #[error("the wgpu device was lost")]
    DeviceLost,
    /// The adapter cannot run the fDED shaders with these parameters.
    #[error("the wgpu adapter cannot run fDED: {reason}")]
    Unsupported {
        /// What is missing.
        reason: String,
    },
    /// Bad parameters or a bad frame: the same errors as the CPU path.
    #[error(transparent)]
    Fded(#[from] crate::Error),
}

/// Result of the GPU path.
pub type Result<T, E = GpuError> = std::result::Result<T, E>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backend_env_values_parse() {
        assert_eq!(BackendRequest::parse("CPU").ok(), Some(BackendRequest::Cpu));
        assert_eq!(BackendRequest::parse("gpu").ok(), Some(BackendRequest::Gpu));
        assert_eq!(BackendRequest::parse("wgpu").ok(), Some(BackendRequest::Gpu));
        assert_eq!(BackendRequest::parse("").ok(), Some(BackendRequest::Auto));
        assert!(matches!(
            BackendRequest::parse("cuda"),
            Err(GpuError::BadBackendEnv { .. })
        ));
    }

    /// A trivial kernel through the whole plumbing (upload, dispatch, readback) on whatever
    /// adapter exists; skipped with a notice when none does.
    #[test]
    fn trivial_kernel_round_trip() {
        let Some(ctx) = GpuContext::open().expect("opening the adapter") else {
            eprintln!("NOTICE: no wgpu adapter; trivial kernel test skipped");
            return;
        };
        let wgsl = "
            @group(0) @binding(0) var<storage, read_write> data: array<u32>;
            @group(0) @binding(1) var<storage, read_write> total: atomic<u32>;
            @compute @workgroup_size(64)
            fn main(@builtin(global_invocation_id) id: vec3<u32>) {
                if (id.x < arrayLength(&data)) {
                    data[id.x] = data[id.x] * 3u + 1u;
                    atomicAdd(&total, data[id.x]);
                }
            }";
        let pipelines = ctx.compute_pipelines("trivial", wgsl, &["main"]).expect("pipeline");
        let input: Vec<u32> = (0..1000).collect();
        let data = ctx.storage_buffer_init("data", &input);
        let total = ctx.storage_buffer_init("total", &[0u32]);
        let bind = ctx.device().create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipelines[0].get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: data.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: total.as_entire_binding() },
            ],
        });
        let mut encoder = ctx.device().create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipelines[0]);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(1000u32.div_ceil(64), 1, 1);
        }
        ctx.queue().submit([encoder.finish()]);
        let mut out = vec![0u32; 1000];
        ctx.read_buffer(&data, &mut out).expect("readback");
        let mut sum = [0u32];
        ctx.read_buffer(&total, &mut sum).expect("readback");
        let expected: Vec<u32> = input.iter().map(|v| v * 3 + 1).collect();
        assert_eq!(out, expected);
        assert_eq!(sum[0], expected.iter().sum::<u32>());
        eprintln!("trivial kernel ran on {:?}", ctx.adapter_name());
    }

    #[test]
    fn bad_wgsl_is_an_error_not_a_panic() {
        let Some(ctx) = GpuContext::open().expect("opening the adapter") else {
            eprintln!("NOTICE: no wgpu adapter; shader error test skipped");
            return;
        };
        let err = ctx
            .compute_pipelines("broken", "@compute @workgroup_size(1) fn main() { let x: u32 = 1.5; }", &["main"])
            .expect_err("invalid WGSL must be rejected");
        assert!(matches!(err, GpuError::Shader { .. }), "{err}");
    }
}
