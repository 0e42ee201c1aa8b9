//! [`GpuFded`]: fDED with the distance stages (5: lattice minimum, 6: refinement over the
//! winning slot) on the GPU (`fded.wgsl`), and the host stages shared with the CPU reference:
//! stages 1–4 (robot points, robot removal at the lattice samples, robot and object lattices)
//! before, and the obstacle-side refinement and stage 7 (normals, velocities, base frame) after.

use std::time::Instant;

use cowork_depth::Intrinsics;
use cowork_robot::RobotModel;

use super::context::GpuContext;
use super::{GpuError, Result};
use crate::layout::LinkBest;
use crate::params::{Backend, FdedParams};
use crate::pipeline::{Fded, FdedOutput, Frame};

const SHADER: &str = include_str!("fded.wgsl");
/// Workgroups per row of a dispatch grid (under the 65 535 limit of one dimension).
const GRID_X: u32 = 32_768;

/// Entry points of `fded.wgsl`, in dispatch order.
const ENTRIES: [&str; 4] = ["lattice_min", "link_reduce", "refine_points", "refine_link"];

/// The uniform block of `fded.wgsl` (field order and types must match `struct Params`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Uniforms {
    n_obj: u32,
    n_lattice: u32,
    links: u32,
    max_count: u32,
}

/// Device buffers, sized once.
#[derive(Debug)]
struct DeviceBuffers {
    uniforms: wgpu::Buffer,
    objects: wgpu::Buffer,
    lattice: wgpu::Buffer,
    lattice_info: wgpu::Buffer,
    points: wgpu::Buffer,
    slot_points: wgpu::Buffer,
    link_out: wgpu::Buffer,
    staging: wgpu::Buffer,
    bind: wgpu::BindGroup,
}

/// fDED on a wgpu device: same inputs, outputs and parameters as [`crate::Fded`]; the results
/// agree with the CPU path up to floating-point contraction on the device (see the `gpu` test).
///
/// Per frame the host runs the CPU's stages 1–4 (work ∝ robot points and lattice samples),
/// uploads the lattices and the robot points, runs four compute dispatches for the robot ×
/// object distances, reads back the per-link pairs, and finishes exactly as the CPU path does.
#[derive(Debug)]
pub struct GpuFded {
    ctx: GpuContext,
    host: Fded,
    pipelines: Vec<wgpu::ComputePipeline>,
    dev: DeviceBuffers,
    objects: Vec<[f32; 4]>,
    link_out: Vec<[u32; 4]>,
}

/// `(x, y)` workgroup counts covering `groups` workgroups.
fn grid(groups: u32) -> (u32, u32) {
    if groups <= GRID_X {
        (groups.max(1), 1)
    } else {
        (GRID_X, groups.div_ceil(GRID_X))
    }
}

impl GpuFded {
    /// Validates like [`crate::Fded::new`], compiles the shaders and sizes every device buffer.
    /// `params.backend` is ignored (this type is the GPU path).
    pub fn new(ctx: GpuContext, model: &RobotModel, intrinsics: &Intrinsics, params: FdedParams) -> Result<Self> {
        let host = Fded::host(model, intrinsics, FdedParams { backend: Backend::Gpu, threads: 1, ..params })?;
        let needed = 8;
        let have = ctx.limits().max_storage_buffers_per_shader_stage;
        if have < needed {
            return Err(GpuError::Unsupported {
                reason: format!("adapter allows {have} storage buffers per stage, fDED needs {needed}"),
            });
        }
        let buf = host.buffers();
        let links = model.link_count() as u64;
        let points = buf.cam_points.len().max(1) as u64;
        let samples = buf.lattice_robot.len().max(1) as u64;
        let lattice_cap = buf.robot_lattice.capacity().max(1) as u64;
        let refine_cap = links * points;
        let max_binding = ctx.limits().max_storage_buffer_binding_size;
        if refine_cap * 16 > max_binding || samples * 16 > max_binding {
            return Err(GpuError::Unsupported {
                reason: format!("fDED buffers exceed the adapter's storage binding size {max_binding} B"),
            });
        }
        let layout_entries: Vec<wgpu::BindGroupLayoutEntry> = (0..9)
            .map(|binding| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: match binding {
                        0 => wgpu::BufferBindingType::Uniform,
                        1..=5 => wgpu::BufferBindingType::Storage { read_only: true },
                        _ => wgpu::BufferBindingType::Storage { read_only: false },
                    },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect();
        let device = ctx.device();
        let bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("fded"),
            entries: &layout_entries,
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("fded"),
            bind_group_layouts: &[Some(&bgl)],
            immediate_size: 0,
        });
        let pipelines = ctx.compute_pipelines_with_layout("fded.wgsl", SHADER, &ENTRIES, &layout)?;
        let uniforms = ctx.uniform_buffer("fded uniforms", std::mem::size_of::<Uniforms>() as u64);
        let objects = ctx.storage_buffer("fded objects", samples * 16);
        let lattice = ctx.storage_buffer("fded lattice", lattice_cap * 16);
        let lattice_info = ctx.storage_buffer("fded lattice info", lattice_cap * 16);
        let points_buf = ctx.storage_buffer("fded points", points * 16);
        let slot_points = ctx.storage_buffer("fded slot points", points * 4);
        let scratch_lattice = ctx.storage_buffer("fded scratch lattice", lattice_cap * 16);
        let scratch_refine = ctx.storage_buffer("fded scratch refine", refine_cap * 16);
        let link_out = ctx.storage_buffer("fded link_out", links * 16);
        let staging = ctx.readback_buffer("fded staging", links * 16);
        let buffers = [
            &uniforms, &objects, &lattice, &lattice_info, &points_buf, &slot_points, &scratch_lattice, &scratch_refine,
            &link_out,
        ];
        let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
            .collect();
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("fded"),
            layout: &bgl,
            entries: &entries,
        });
        Ok(Self {
            objects: Vec::with_capacity(samples as usize),
            link_out: vec![[0; 4]; links as usize],
            dev: DeviceBuffers {
                uniforms,
                objects,
                lattice,
                lattice_info,
                points: points_buf,
                slot_points,
                link_out,
                staging,
                bind,
            },
            pipelines,
            host,
            ctx,
        })
    }

    /// The device in use.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The parameters in use (`backend` = [`Backend::Gpu`]).
    pub fn params(&self) -> &FdedParams {
        self.host.params()
    }

    /// The robot model.
    pub fn model(&self) -> &RobotModel {
        self.host.model()
    }

    /// The camera intrinsics.
    pub fn intrinsics(&self) -> &Intrinsics {
        self.host.intrinsics()
    }

    /// An output with one entry per link, to be filled by [`process`](Self::process).
    pub fn new_output(&self) -> FdedOutput {
        self.host.new_output()
    }

    /// The host-side buffers of the last frame (robot points, lattices, per-link pairs).
    pub fn buffers(&self) -> &crate::Buffers {
        self.host.buffers()
    }

    /// Forgets the previous frame (obstacle velocities restart at zero).
    pub fn reset_tracks(&mut self) {
        self.host.reset_tracks();
    }

    /// Where the table plane is ([`crate::Fded::set_table_frame`]).
    pub fn set_table_frame(&mut self, table_from_base: nalgebra::Isometry3<f64>) {
        self.host.set_table_frame(table_from_base);
    }

    /// The frame of the table plane ← robot base.
    pub fn table_frame(&self) -> &nalgebra::Isometry3<f64> {
        self.host.table_frame()
    }

    /// Runs the pipeline on one frame and fills `out`, as [`crate::Fded::process`] does.
    ///
    /// Timings: stages 1–4 as on the CPU; `minimum_us` the device part from upload to the end
    /// of the readback (the two stages are not timed one by one on the device), `refine_us`
    /// the host's obstacle-side refinement, `output_us` normals, velocities and the base frame.
    pub fn process(&mut self, frame: &Frame<'_>, out: &mut FdedOutput) -> Result<()> {
        let mut times = self.host.front(frame)?;
        let t1 = Instant::now();
        self.host.group_slots();
        let buf = self.host.buffers();
        let links = self.host.model().link_count() as u32;
        self.objects.clear();
        self.objects.extend(
            buf.obj_ray_x
                .iter()
                .zip(&buf.obj_ray_y)
                .zip(&buf.obj_depth)
                .zip(&buf.obj_cap)
                .map(|(((&x, &y), &d), &c)| [x, y, d, c]),
        );
        let max_count = buf.robot_lattice_info.iter().map(|i| i[3]).max().unwrap_or(0);
        let u = Uniforms {
            n_obj: self.objects.len() as u32,
            n_lattice: buf.robot_lattice.len() as u32,
            links,
            max_count,
        };
        let (ctx, dev) = (&self.ctx, &self.dev);
        ctx.upload(&dev.uniforms, &[u])?;
        ctx.upload(&dev.objects, &self.objects)?;
        ctx.upload(&dev.lattice, &buf.robot_lattice)?;
        ctx.upload(&dev.lattice_info, &buf.robot_lattice_info)?;
        ctx.upload(&dev.points, &buf.cam_points)?;
        ctx.upload(&dev.slot_points, &buf.slot_points)?;
        let mut enc = ctx.device().create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("fded frame"),
        });
        let groups = [u.n_lattice, links, links * max_count.max(1), links];
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("fded"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &dev.bind, &[]);
            for (pipeline, &g) in self.pipelines.iter().zip(&groups) {
                let (x, y) = grid(g);
                pass.set_pipeline(pipeline);
                pass.dispatch_workgroups(x, y, 1);
            }
        }
        let link_bytes = u64::from(links) * 16;
        enc.copy_buffer_to_buffer(&dev.link_out, 0, &dev.staging, 0, link_bytes);
        ctx.queue().submit([enc.finish()]);
        ctx.read_mapped_parts(&dev.staging, &mut [bytemuck::cast_slice_mut(&mut self.link_out)])?;
        let t2 = Instant::now();
        let buf = self.host.buffers_mut();
        for (lb, o) in buf.link_best.iter_mut().zip(&self.link_out) {
            let [d, rp, j, k] = *o;
            *lb = if rp == u32::MAX || j == u32::MAX || k == u32::MAX {
                LinkBest::NONE
            } else {
                LinkBest {
                    dist2: f32::from_bits(d),
                    robot_point: rp,
                    object_pixel: buf.obj_pixel.get(j as usize).copied().unwrap_or(u32::MAX),
                    lattice: k,
                }
            };
        }
        self.host.refine_obstacles(frame);
        let t3 = Instant::now();
        self.host.finish(frame, out);
        times.set_back([t1, t2, t3, Instant::now()]);
        out.times = times;
        Ok(())
    }
}
