//! [`GpuFded`]: the fDED pipeline with stages 1–6 on the GPU (`fded.wgsl`), mirroring the CPU
//! reference stage by stage, and stage 7 (normals, velocities, base frame) on the host from the
//! GPU's closest pairs and filtered depth.

use std::time::Instant;

use cowork_depth::Intrinsics;
use cowork_robot::{DOF, JointVector, LinkPoses, MAX_LINKS, RobotModel};
use nalgebra::{Isometry3, Point3, Vector3};

use super::context::GpuContext;
use super::{GpuError, Result};
use crate::cam::Cam;
use crate::layout::Buffers;
use crate::params::{Backend, FdedParams};
use crate::pipeline::{FdedOutput, Frame, FrameCounts, LinkDistance, StageTimes, cam_of};
use crate::raster::{RobotMeshes, transform_vertices};
use crate::stages::obstacle_normal;
use crate::Error;

const SHADER: &str = include_str!("fded.wgsl");
const WG: u32 = 64;
/// Workgroups per row of a dispatch grid (under the 65 535 limit of one dimension).
const GRID_X: u32 = 32_768;

/// Entry points of `fded.wgsl`, in dispatch order.
const ENTRIES: [&str; 8] = [
    "raster_depth",
    "raster_label",
    "resolve",
    "lattice_pick",
    "lattice_min",
    "link_reduce",
    "refine_tile",
    "refine_link",
];

/// The uniform block of `fded.wgsl` (field order and types must match `struct Params`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Uniforms {
    width: u32,
    height: u32,
    tile: u32,
    tiles_x: u32,
    tiles_y: u32,
    links: u32,
    step_x: u32,
    step_y: u32,
    fx: f32,
    fy: f32,
    cx: f32,
    cy: f32,
    delta: f32,
    min_depth: f32,
    max_depth: f32,
    near: f32,
    table_on: u32,
    r20: f32,
    r21: f32,
    r22: f32,
    tz: f32,
    zlim: f32,
    tri_count: u32,
    refine_obstacle: u32,
}

#[derive(Debug, Clone, Copy, Default)]
struct Track {
    valid: bool,
    stamp: f64,
    point: Point3<f64>,
    velocity: Vector3<f64>,
}

/// Device buffers, sized once.
#[derive(Debug)]
struct DeviceBuffers {
    uniforms: wgpu::Buffer,
    vertices: wgpu::Buffer,
    depth: wgpu::Buffer,
    zbuf: wgpu::Buffer,
    filtered: wgpu::Buffer,
    tiles: wgpu::Buffer,
    counters: wgpu::Buffer,
    link_out: wgpu::Buffer,
    staging: wgpu::Buffer,
    bind: wgpu::BindGroup,
}

/// fDED on a wgpu device: same inputs, outputs and parameters as [`crate::Fded`]; the results
/// agree with the CPU path up to floating-point contraction on the device (see the `gpu` test).
///
/// Per frame the host does forward kinematics and moves the ≈ 5 k mesh vertices to the camera
/// frame (as the CPU path does; tens of µs), uploads them with the depth image, runs eight
/// compute dispatches, reads back the per-link pairs and the filtered depth, and computes
/// normals and velocities exactly as the CPU path does.
#[derive(Debug)]
pub struct GpuFded {
    ctx: GpuContext,
    model: RobotModel,
    meshes: RobotMeshes,
    intrinsics: Intrinsics,
    cam: Cam,
    params: FdedParams,
    /// Host mirror: rays, camera-frame vertices, and the filtered depth read back each frame.
    host: Buffers,
    poses: LinkPoses,
    tracks: Vec<Track>,
    uniforms: Uniforms,
    pipelines: Vec<wgpu::ComputePipeline>,
    dev: DeviceBuffers,
    link_out: Vec<[u32; 4]>,
    counters: [u32; 4],
    tri_count: u32,
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
    pub fn new(
        ctx: GpuContext,
        model: &RobotModel,
        intrinsics: &Intrinsics,
        params: FdedParams,
    ) -> Result<Self> {
        params.validate()?;
        let cam = cam_of(intrinsics)?;
        let links = model.link_count();
        if links > MAX_LINKS {
            return Err(Error::TooManyLinks { links, max: MAX_LINKS }.into());
        }
        let meshes = RobotMeshes::from_model(model);
        if meshes.is_empty() {
            return Err(Error::NoMeshes { robot: model.name().to_owned() }.into());
        }
        let mut host = Buffers::new(cam.width, cam.height, links, meshes.vertices.len(), 1, params.tile_size);
        for (u, r) in host.ray_x.iter_mut().enumerate() {
            *r = ((u as f64 - intrinsics.cx) / intrinsics.fx) as f32;
        }
        for (v, r) in host.ray_y.iter_mut().enumerate() {
            *r = ((v as f64 - intrinsics.cy) / intrinsics.fy) as f32;
        }
        let tile = params.tile_size;
        let tiles_x = cam.width.div_ceil(tile);
        let tiles_y = cam.height.div_ceil(tile);
        let tri_count = meshes.triangles.len() as u32;
        let uniforms = Uniforms {
            width: cam.width,
            height: cam.height,
            tile,
            tiles_x,
            tiles_y,
            links: links as u32,
            step_x: params.step_x,
            step_y: params.step_y,
            fx: cam.fx,
            fy: cam.fy,
            cx: cam.cx,
            cy: cam.cy,
            delta: params.robot_delta as f32,
            min_depth: params.min_depth as f32,
            max_depth: params.max_depth as f32,
            near: params.near_clip as f32,
            table_on: 0,
            r20: 0.0,
            r21: 0.0,
            r22: 0.0,
            tz: 0.0,
            zlim: 0.0,
            tri_count,
            refine_obstacle: u32::from(params.refine_obstacle),
        };

        let needed = 13;
        let have = ctx.limits().max_storage_buffers_per_shader_stage;
        if have < needed {
            return Err(GpuError::Unsupported {
                reason: format!("adapter allows {have} storage buffers per stage, fDED needs {needed}"),
            });
        }
        let n = u64::from(cam.width) * u64::from(cam.height);
        let slots = u64::from(tiles_x) * u64::from(tiles_y) * links as u64;
        let scratch_len = slots + links as u64 * u64::from(tile) * u64::from(tile);
        let max_binding = ctx.limits().max_storage_buffer_binding_size;
        if scratch_len * 16 > u64::from(max_binding) || n * 16 > u64::from(max_binding) {
            return Err(GpuError::Unsupported {
                reason: format!("buffers for T_s = {tile} exceed the adapter's binding size {max_binding} B"),
            });
        }

        let triangles: Vec<u32> = meshes.triangles.iter().flatten().copied().collect();
        let mut rays = host.ray_x.clone();
        rays.extend_from_slice(&host.ray_y);
        let layout_entries: Vec<wgpu::BindGroupLayoutEntry> = (0..14)
            .map(|binding| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: if binding == 0 {
                        wgpu::BufferBindingType::Uniform
                    } else {
                        wgpu::BufferBindingType::Storage { read_only: false }
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

        let uniform_buf = ctx.uniform_buffer("fded uniforms", std::mem::size_of::<Uniforms>() as u64);
        let vertices = ctx.storage_buffer("fded vertices", (meshes.vertices.len() * 16) as u64);
        let tri_buf = ctx.storage_buffer_init("fded triangles", &triangles);
        let depth = ctx.storage_buffer("fded depth", n * 4);
        let rays_buf = ctx.storage_buffer_init("fded rays", &rays);
        let zbuf = ctx.storage_buffer("fded zbuf", n * 8);
        let vdepth = ctx.storage_buffer("fded virtual depth", n * 4);
        let labels = ctx.storage_buffer("fded labels", n * 4);
        let filtered = ctx.storage_buffer("fded filtered", n * 4);
        let tiles = ctx.storage_buffer("fded tiles", slots * 8);
        let objects = ctx.storage_buffer("fded objects", n * 16);
        let counters = ctx.storage_buffer("fded counters", 16);
        let scratch = ctx.storage_buffer("fded scratch", scratch_len * 16);
        let link_out = ctx.storage_buffer("fded link_out", links as u64 * 32);
        let staging = ctx.readback_buffer("fded staging", links as u64 * 32 + 16 + n * 4);
        let buffers = [
            &uniform_buf, &vertices, &tri_buf, &depth, &rays_buf, &zbuf, &vdepth, &labels, &filtered,
            &tiles, &objects, &counters, &scratch, &link_out,
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
            model: model.clone(),
            meshes,
            intrinsics: *intrinsics,
            cam,
            params: FdedParams { backend: Backend::Gpu, ..params },
            host,
            poses: LinkPoses::new(),
            tracks: vec![Track::default(); links],
            uniforms,
            pipelines,
            dev: DeviceBuffers {
                uniforms: uniform_buf,
                vertices,
                depth,
                zbuf,
                filtered,
                tiles,
                counters,
                link_out,
                staging,
                bind,
            },
            link_out: vec![[0; 4]; 2 * links],
            counters: [0; 4],
            tri_count,
            ctx,
        })
    }

    /// The device in use.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The parameters in use (`backend` = [`Backend::Gpu`]).
    pub fn params(&self) -> &FdedParams {
        &self.params
    }

    /// The robot model.
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// The camera intrinsics.
    pub fn intrinsics(&self) -> &Intrinsics {
        &self.intrinsics
    }

    /// An output with one entry per link, to be filled by [`process`](Self::process).
    pub fn new_output(&self) -> FdedOutput {
        FdedOutput {
            stamp: 0.0,
            links: (0..self.model.link_count()).map(LinkDistance::none).collect(),
            closest: None,
            times: StageTimes::default(),
            counts: FrameCounts::default(),
        }
    }

    /// The filtered depth of the last frame, read back from the device (m, 0 = not an obstacle).
    pub fn filtered(&self) -> &[f32] {
        &self.host.filtered
    }

    /// Forgets the previous frame (obstacle velocities restart at zero).
    pub fn reset_tracks(&mut self) {
        self.tracks.fill(Track::default());
    }

    /// Runs the pipeline on one frame and fills `out`, as [`crate::Fded::process`] does.
    ///
    /// Timings: `virtual_depth_us` is the host part (kinematics, vertex transform, uploads),
    /// `minimum_us` the device part from submit to the end of the readback (the stages are not
    /// timed one by one on the device), `output_us` normals, velocities and the base frame.
    pub fn process(&mut self, frame: &Frame<'_>, out: &mut FdedOutput) -> Result<()> {
        let t0 = Instant::now();
        self.check(frame)?;
        let cam_from_base = frame.camera_pose.inverse();
        let mut q = JointVector::zeros();
        if let Some(j) = frame.joints {
            q.copy_from_slice(j);
        }
        self.model.forward_kinematics(&q, &mut self.poses);
        transform_vertices(&self.meshes, &self.poses, &cam_from_base, &mut self.host);
        let p = &self.params;
        let mut u = self.uniforms;
        if let Some(z) = p.table_z {
            let m = frame.camera_pose.rotation.to_rotation_matrix();
            let m = m.matrix();
            u.table_on = 1;
            u.r20 = m[(2, 0)] as f32;
            u.r21 = m[(2, 1)] as f32;
            u.r22 = m[(2, 2)] as f32;
            u.tz = frame.camera_pose.translation.vector.z as f32;
            u.zlim = (z + p.table_margin) as f32;
        }
        let ctx = &self.ctx;
        let dev = &self.dev;
        ctx.upload(&dev.uniforms, &[u])?;
        ctx.upload(&dev.vertices, &self.host.cam_vertices)?;
        ctx.upload(&dev.depth, &frame.depth.data)?;
        let t1 = Instant::now();

        let mut enc = ctx.device().create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("fded frame"),
        });
        enc.clear_buffer(&dev.zbuf, 0, None);
        enc.clear_buffer(&dev.tiles, 0, None);
        enc.clear_buffer(&dev.counters, 0, None);
        let n = self.cam.width * self.cam.height;
        let links = self.model.link_count() as u32;
        let slots = self.uniforms.tiles_x * self.uniforms.tiles_y * links;
        let tile_px = self.uniforms.tile * self.uniforms.tile;
        let groups = [
            self.tri_count.div_ceil(WG),
            self.tri_count.div_ceil(WG),
            n.div_ceil(WG),
            n.div_ceil(WG),
            slots,
            links,
            links * tile_px,
            links,
        ];
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
        let link_bytes = u64::from(links) * 32;
        enc.copy_buffer_to_buffer(&dev.link_out, 0, &dev.staging, 0, link_bytes);
        enc.copy_buffer_to_buffer(&dev.counters, 0, &dev.staging, link_bytes, 16);
        enc.copy_buffer_to_buffer(&dev.filtered, 0, &dev.staging, link_bytes + 16, u64::from(n) * 4);
        ctx.queue().submit([enc.finish()]);
        ctx.read_mapped_parts(
            &dev.staging,
            &mut [
                bytemuck::cast_slice_mut(&mut self.link_out),
                bytemuck::cast_slice_mut(&mut self.counters[..]),
                bytemuck::cast_slice_mut(&mut self.host.filtered),
            ],
        )?;
        let t2 = Instant::now();
        self.finish(frame, out);
        let t3 = Instant::now();
        let us = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e6;
        out.times = StageTimes {
            virtual_depth_us: us(t0, t1),
            filter_us: 0.0,
            lattices_us: 0.0,
            minimum_us: us(t1, t2),
            refine_us: 0.0,
            output_us: us(t2, t3),
            total_us: us(t0, t3),
        };
        Ok(())
    }

    /// The same input checks as the CPU path, with the same errors.
    fn check(&self, frame: &Frame<'_>) -> Result<()> {
        let d = frame.depth;
        if d.width != self.cam.width
            || d.height != self.cam.height
            || d.data.len() != self.cam.width as usize * self.cam.height as usize
        {
            return Err(Error::SizeMismatch {
                got_width: d.width,
                got_height: d.height,
                got_len: d.data.len(),
                width: self.cam.width,
                height: self.cam.height,
            }
            .into());
        }
        let Some(j) = frame.joints else {
            return Err(Error::MissingJointState { stamp: frame.stamp }.into());
        };
        if j.len() != DOF {
            return Err(Error::JointCount { got: j.len(), expected: DOF }.into());
        }
        if !j.iter().all(|v| v.is_finite()) {
            return Err(Error::NotFinite { what: "joint position" }.into());
        }
        let p = frame.camera_pose;
        if !(p.translation.vector.iter().all(|v| v.is_finite())
            && p.rotation.coords.iter().all(|v| v.is_finite()))
        {
            return Err(Error::NotFinite { what: "camera pose" }.into());
        }
        if !frame.stamp.is_finite() {
            return Err(Error::NotFinite { what: "frame stamp" }.into());
        }
        Ok(())
    }

    /// Stage 7 and the output, as the CPU path's `finish`, from the device's per-link pairs.
    fn finish(&mut self, frame: &Frame<'_>, out: &mut FdedOutput) {
        let links = self.model.link_count();
        if out.links.len() != links {
            out.links.clear();
            out.links.extend((0..links).map(LinkDistance::none));
        }
        let buf = &self.host;
        let w = buf.width as usize;
        let window =
            (self.params.normal_fraction * f64::from(buf.width) * f64::from(buf.height)).round() as usize;
        let base_from_cam: &Isometry3<f64> = frame.camera_pose;
        let (alpha, vmax) = (self.params.velocity_smoothing, self.params.max_obstacle_speed);
        out.stamp = frame.stamp;
        out.closest = None;
        let mut closest = f64::INFINITY;
        for l in 0..links {
            let [dist2_bits, rp, op, _tile] = self.link_out[2 * l];
            let [dr_bits, _, _, _] = self.link_out[2 * l + 1];
            let track = &mut self.tracks[l];
            if rp == u32::MAX || op == u32::MAX {
                out.links[l] = LinkDistance::none(l);
                track.valid = false;
                continue;
            }
            let (rp, op) = (rp as usize, op as usize);
            let dr = f32::from_bits(dr_bits);
            let r = Vector3::new(buf.ray_x[rp % w] * dr, buf.ray_y[rp / w] * dr, dr);
            let d_o = buf.filtered[op].max(dr);
            let o = Vector3::new(buf.ray_x[op % w] * d_o, buf.ray_y[op / w] * d_o, d_o);
            let n_cam = obstacle_normal(buf, op as u32, window.max(9), self.params.normal_sigma as f32, &r)
                .or_else(|| (r - o).try_normalize(1e-9))
                .unwrap_or_else(Vector3::zeros);
            let robot_point = base_from_cam * Point3::from(r.cast::<f64>());
            let obstacle_point = base_from_cam * Point3::from(o.cast::<f64>());
            let normal = base_from_cam.rotation * n_cam.cast::<f64>();
            let dt = frame.stamp - track.stamp;
            let velocity = if track.valid && dt > 0.0 {
                let raw = (obstacle_point - track.point) / dt;
                if raw.norm() <= vmax {
                    raw * alpha + track.velocity * (1.0 - alpha)
                } else {
                    Vector3::zeros()
                }
            } else {
                Vector3::zeros()
            };
            *track = Track { valid: true, stamp: frame.stamp, point: obstacle_point, velocity };
            let distance = f64::from(f32::from_bits(dist2_bits)).sqrt();
            out.links[l] = LinkDistance {
                link: l,
                valid: true,
                distance,
                robot_point,
                obstacle_point,
                normal,
                obstacle_velocity: velocity,
            };
            if distance < closest {
                closest = distance;
                out.closest = Some(l);
            }
        }
        out.counts = FrameCounts {
            robot_lattice: self.counters[1] as usize,
            object_lattice: self.counters[0] as usize,
        };
    }
}
