//! [`FdedEngine`]: the backend choice (CPU reference or wgpu) behind one `process` call, with
//! the CPU as the fallback whenever no adapter exists or the device fails.

use cowork_depth::Intrinsics;
use cowork_robot::RobotModel;

use super::context::{BackendRequest, GpuContext};
use super::pipeline::GpuFded;
use super::{GpuError, Result};
use crate::params::{Backend, FdedParams};
use crate::pipeline::{Fded, FdedOutput, Frame};

/// fDED on the backend chosen at start-up.
///
/// Choice ([`FdedEngine::new`]): `COWORK_FDED_BACKEND` (`cpu`, `gpu`, `auto`) when set, else the
/// `request` argument. `Auto` takes the GPU when an adapter exists and the shaders build, else
/// the CPU; `Gpu` makes the absence of an adapter an error; `Cpu` never opens a device. A GPU
/// failure during a frame (device lost, readback error) switches the engine to the CPU for
/// good and the frame is computed there, so a caller never sees a GPU error from `process`.
#[derive(Debug)]
pub enum FdedEngine {
    /// The CPU reference.
    Cpu(Box<Fded>),
    /// The wgpu compute path.
    Gpu(Box<GpuFded>),
}

impl FdedEngine {
    /// Builds the engine (see the type's docs for the choice). `params.backend` is overridden
    /// by the choice; everything else in `params` applies to both backends.
    pub fn new(
        model: &RobotModel,
        intrinsics: &Intrinsics,
        params: FdedParams,
        request: BackendRequest,
    ) -> Result<Self> {
        let request = match std::env::var_os(super::BACKEND_ENV) {
            Some(_) => BackendRequest::from_env()?,
            None => request,
        };
        let cpu = |params: FdedParams| -> Result<Self> {
            let params = FdedParams { backend: Backend::Cpu, ..params };
            Ok(Self::Cpu(Box::new(Fded::new(model, intrinsics, params)?)))
        };
        match request {
            BackendRequest::Cpu => cpu(params),
            BackendRequest::Gpu => {
                let ctx = GpuContext::open()?.ok_or(GpuError::NoAdapter)?;
                Ok(Self::Gpu(Box::new(GpuFded::new(ctx, model, intrinsics, params)?)))
            }
            BackendRequest::Auto => {
                params.validate()?;
                let gpu = match GpuContext::open() {
                    Ok(Some(ctx)) => GpuFded::new(ctx, model, intrinsics, params.clone()),
                    Ok(None) => return cpu(params),
                    Err(e) => Err(e),
                };
                match gpu {
                    Ok(g) => Ok(Self::Gpu(Box::new(g))),
                    // Input errors are the same on both paths; report them.
                    Err(GpuError::Fded(e)) => Err(GpuError::Fded(e)),
                    Err(e) => {
                        tracing::warn!("fDED: GPU path unavailable ({e}); using the CPU");
                        cpu(params)
                    }
                }
            }
        }
    }

    /// `"wgpu"` or `"cpu"`, as `cowork_msgs/LinkDistances.backend` names them.
    pub fn backend_name(&self) -> &'static str {
        match self {
            Self::Cpu(_) => "cpu",
            Self::Gpu(_) => "wgpu",
        }
    }

    /// The adapter's name on the GPU path.
    pub fn adapter_name(&self) -> Option<&str> {
        match self {
            Self::Cpu(_) => None,
            Self::Gpu(g) => Some(g.context().adapter_name()),
        }
    }

    /// The parameters in use.
    pub fn params(&self) -> &FdedParams {
        match self {
            Self::Cpu(c) => c.params(),
            Self::Gpu(g) => g.params(),
        }
    }

    /// The robot model.
    pub fn model(&self) -> &RobotModel {
        match self {
            Self::Cpu(c) => c.model(),
            Self::Gpu(g) => g.model(),
        }
    }

    /// An output sized for this robot.
    pub fn new_output(&self) -> FdedOutput {
        match self {
            Self::Cpu(c) => c.new_output(),
            Self::Gpu(g) => g.new_output(),
        }
    }

    /// Where the table plane is ([`Fded::set_table_frame`]).
    pub fn set_table_frame(&mut self, table_from_base: nalgebra::Isometry3<f64>) {
        match self {
            Self::Cpu(c) => c.set_table_frame(table_from_base),
            Self::Gpu(g) => g.set_table_frame(table_from_base),
        }
    }

    /// Runs one frame (see [`Fded::process`]). Input errors are returned as
    /// [`crate::Error`]; a device failure moves the engine to the CPU and retries the frame there.
    pub fn process(&mut self, frame: &Frame<'_>, out: &mut FdedOutput) -> crate::Result<()> {
        let failure = match self {
            Self::Cpu(c) => return c.process(frame, out),
            Self::Gpu(g) => match g.process(frame, out) {
                Ok(()) => return Ok(()),
                Err(GpuError::Fded(e)) => return Err(e),
                Err(e) => e,
            },
        };
        tracing::error!("fDED: GPU frame failed ({failure}); switching to the CPU path for good");
        let Self::Gpu(g) = self else {
            unreachable!("only the GPU arm falls through")
        };
        let params = FdedParams { backend: Backend::Cpu, ..g.params().clone() };
        let mut cpu = Fded::new(g.model(), g.intrinsics(), params)?;
        cpu.set_table_frame(*g.table_frame());
        *self = Self::Cpu(Box::new(cpu));
        match self {
            Self::Cpu(c) => c.process(frame, out),
            Self::Gpu(_) => unreachable!("just replaced by the CPU path"),
        }
    }
}
