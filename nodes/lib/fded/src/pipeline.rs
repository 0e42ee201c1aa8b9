//! The per-frame pipeline: [`Fded`] owns the buffers and runs the stages in order.

use std::time::Instant;

use crate::cam::Cam;
use crate::error::{Error, Result};
use crate::layout::{Buffers, LinkBest};
use crate::params::{Backend, FdedParams};
use crate::raster::{RobotMeshes, render_virtual_depth, transform_vertices};
use crate::stages::{
    FilterConsts, Objects, filter_rows, lattice_minimum, object_lattice, obstacle_normal,
    refine_obstacle, refine_tile, robot_lattice,
};
use cowork_depth::{DepthImage, Intrinsics};
use cowork_robot::{DOF, JointVector, LinkPoses, MAX_LINKS, RobotModel};
use nalgebra::{Isometry3, Point3, Vector3};

/// One depth frame and the robot state it was taken at.
#[derive(Debug, Clone, Copy)]
pub struct Frame<'a> {
    /// Acquisition time, s (any epoch; only differences are used, for the obstacle velocity).
    pub stamp: f64,
    /// The real depth image (m, 0 = no return; NaN is treated as no return).
    pub depth: &'a DepthImage,
    /// Pose of the camera optical frame in the robot base frame (base ← camera).
    pub camera_pose: &'a Isometry3<f64>,
    /// Joint positions (rad), base to tip; `None` when no joint state has arrived.
    pub joints: Option<&'a [f64]>,
}

/// The result for one link. Points and vectors in the robot **base frame** (m, m/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkDistance {
    /// Link index (as in [`RobotModel::link_names`]).
    pub link: usize,
    /// `false` when the link is not visible or no obstacle point exists; the other fields are
    /// then zero (distance: `f64::INFINITY`).
    pub valid: bool,
    /// Robot–obstacle distance (eq. 5.15 with the gray area), m.
    pub distance: f64,
    /// Closest robot point.
    pub robot_point: Point3<f64>,
    /// Closest obstacle point (on its pixel's ray, at max(d_o, d_r) per eq. 5.17).
    pub obstacle_point: Point3<f64>,
    /// Unit obstacle surface normal at the obstacle point, pointing towards the robot.
    pub normal: Vector3<f64>,
    /// Velocity of the link's closest obstacle point from consecutive frames, m/s.
    pub obstacle_velocity: Vector3<f64>,
}

impl LinkDistance {
    /// The "nothing seen" value for link `link`.
    pub fn none(link: usize) -> Self {
        Self {
            link,
            valid: false,
            distance: f64::INFINITY,
            robot_point: Point3::origin(),
            obstacle_point: Point3::origin(),
            normal: Vector3::zeros(),
            obstacle_velocity: Vector3::zeros(),
        }
    }
}

/// Wall-clock time of each stage of the last frame, µs.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// Forward kinematics + vertex transform + rasterised virtual depth.
    pub virtual_depth_us: f64,
    /// Robot removal, table and range filtering.
    pub filter_us: f64,
    /// Robot and object lattices.
    pub lattices_us: f64,
    /// Per-link minimum over the lattices.
    pub minimum_us: f64,
    /// Refinement in the winning tiles (and around the obstacle points).
    pub refine_us: f64,
    /// Normals, velocities and the move to the base frame.
    pub output_us: f64,
    /// The whole call.
    pub total_us: f64,
}

impl StageTimes {
    /// Distance part only (lattices, minimum, refinement): what the thesis's tables time.
    pub fn distance_us(&self) -> f64 {
        self.lattices_us + self.minimum_us + self.refine_us
    }
}

/// Sizes of the last frame's lattices.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameCounts {
    /// Robot lattice points.
    pub robot_lattice: usize,
    /// Object lattice points.
    pub object_lattice: usize,
}

/// Per-frame output, sized once by [`Fded::new_output`] and refilled by [`Fded::process`].
#[derive(Debug, Clone, PartialEq)]
pub struct FdedOutput {
    /// Stamp of the frame, s.
    pub stamp: f64,
    /// One entry per link of the model, base first.
    pub links: Vec<LinkDistance>,
    /// Index into `links` of the smallest valid distance (the global minimum).
    pub closest: Option<usize>,
    /// Stage timings.
    pub times: StageTimes,
    /// Point-set sizes.
    pub counts: FrameCounts,
}

impl FdedOutput {
    /// The global minimum, if any link saw an obstacle.
    pub fn minimum(&self) -> Option<&LinkDistance> {
        self.closest.map(|i| &self.links[i])
    }
}

#[derive(Debug, Clone, Copy, Default)]
struct Track {
    valid: bool,
    stamp: f64,
    point: Point3<f64>,
    velocity: Vector3<f64>,
}

/// fDED on the CPU: robot–obstacle distances in depth space (thesis Sec. 5.1.2).
///
/// Build once per camera and robot with [`Fded::new`], then call [`process`](Fded::process)
/// per frame. After the first frame a call allocates nothing when `threads = 1` (with more
/// threads the work is shared through a persistent rayon pool).
#[derive(Debug)]
pub struct Fded {
    model: RobotModel,
    meshes: RobotMeshes,
    intrinsics: Intrinsics,
    cam: Cam,
    params: FdedParams,
    buf: Buffers,
    poses: LinkPoses,
    tracks: Vec<Track>,
    pool: Option<rayon::ThreadPool>,
}

impl Fded {
    /// Validates everything once and sizes every buffer.
    ///
    /// Errors: bad parameters or intrinsics, a model without meshes or with more than
    /// [`MAX_LINKS`] links, [`Backend::Gpu`] (the GPU path lives in `gpu/`), or no threads.
    pub fn new(model: &RobotModel, intrinsics: &Intrinsics, params: FdedParams) -> Result<Self> {
        params.validate()?;
        if params.backend != Backend::Cpu {
            return Err(Error::BackendUnavailable {
                backend: params.backend,
                reason: "this type is the CPU pipeline; build the GPU pipeline from the gpu module",
            });
        }
        let cam = cam_of(intrinsics)?;
        let links = model.link_count();
        if links > MAX_LINKS {
            return Err(Error::TooManyLinks {
                links,
                max: MAX_LINKS,
            });
        }
        let meshes = RobotMeshes::from_model(model);
        if meshes.is_empty() {
            return Err(Error::NoMeshes {
                robot: model.name().to_owned(),
            });
        }
        let mut buf = Buffers::new(
            cam.width,
            cam.height,
            links,
            meshes.vertices.len(),
            params.threads,
            params.tile_size,
        );
        for (u, r) in buf.ray_x.iter_mut().enumerate() {
            *r = ((u as f64 - intrinsics.cx) / intrinsics.fx) as f32;
        }
        for (v, r) in buf.ray_y.iter_mut().enumerate() {
            *r = ((v as f64 - intrinsics.cy) / intrinsics.fy) as f32;
        }
        let pool = if params.threads > 1 {
            Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(params.threads)
                    .thread_name(|i| format!("fded-{i}"))
                    .build()
                    .map_err(|e| Error::ThreadPool {
                        threads: params.threads,
                        message: e.to_string(),
                    })?,
            )
        } else {
            None
        };
        Ok(Self {
            model: model.clone(),
            meshes,
            intrinsics: *intrinsics,
            cam,
            params,
            buf,
            poses: LinkPoses::new(),
            tracks: vec![Track::default(); links],
            pool,
        })
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

    /// The parameters in use.
    pub fn params(&self) -> &FdedParams {
        &self.params
    }

    /// The camera intrinsics.
    pub fn intrinsics(&self) -> &Intrinsics {
        &self.intrinsics
    }

    /// The robot model.
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// The working buffers as the last frame left them (virtual depth, filtered depth,
    /// lattices, per-link pairs).
    pub fn buffers(&self) -> &Buffers {
        &self.buf
    }

    /// The robot's flattened meshes.
    pub fn meshes(&self) -> &RobotMeshes {
        &self.meshes
    }

    /// Forgets the previous frame (obstacle velocities restart at zero).
    pub fn reset_tracks(&mut self) {
        self.tracks.fill(Track::default());
    }

    /// Runs stages 1–2 only: renders the virtual depth for `frame` and filters its depth into
    /// [`Buffers::filtered`]. The baselines share this front end.
    pub fn prepare(&mut self, frame: &Frame<'_>) -> Result<()> {
        self.check(frame)?;
        self.render(frame);
        self.filter(frame);
        Ok(())
    }

    /// Stage 1 (after [`check`](Self::check)): forward kinematics, vertices to the camera
    /// frame, rasterised virtual depth.
    fn render(&mut self, frame: &Frame<'_>) {
        let cam_from_base = frame.camera_pose.inverse();
        let mut q = JointVector::zeros();
        if let Some(j) = frame.joints {
            q.copy_from_slice(j);
        }
        self.model.forward_kinematics(&q, &mut self.poses);
        transform_vertices(&self.meshes, &self.poses, &cam_from_base, &mut self.buf);
        render_virtual_depth(&self.meshes, &self.cam, self.params.near_clip as f32, &mut self.buf);
    }

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
            });
        }
        let Some(j) = frame.joints else {
            return Err(Error::MissingJointState { stamp: frame.stamp });
        };
        if j.len() != DOF {
            return Err(Error::JointCount {
                got: j.len(),
                expected: DOF,
            });
        }
        if !j.iter().all(|v| v.is_finite()) {
            return Err(Error::NotFinite {
                what: "joint position",
            });
        }
        let p = frame.camera_pose;
        if !(p.translation.vector.iter().all(|v| v.is_finite())
            && p.rotation.coords.iter().all(|v| v.is_finite()))
        {
            return Err(Error::NotFinite {
                what: "camera pose",
            });
        }
        if !frame.stamp.is_finite() {
            return Err(Error::NotFinite {
                what: "frame stamp",
            });
        }
        Ok(())
    }

    fn filter(&mut self, frame: &Frame<'_>) {
        let p = &self.params;
        let table = p.table_z.map(|z| {
            let r = frame.camera_pose.rotation.to_rotation_matrix();
            let m = r.matrix();
            [
                m[(2, 0)] as f32,
                m[(2, 1)] as f32,
                m[(2, 2)] as f32,
                frame.camera_pose.translation.vector.z as f32,
                (z + p.table_margin) as f32,
            ]
        });
        let k = FilterConsts {
            delta: p.robot_delta as f32,
            min_depth: p.min_depth as f32,
            max_depth: p.max_depth as f32,
            table,
        };
        let buf = &mut self.buf;
        let depth = &frame.depth.data[..];
        let (vd, rx, ry) = (&buf.virtual_depth[..], &buf.ray_x[..], &buf.ray_y[..]);
        let w = buf.width as usize;
        let h = buf.height as usize;
        match &self.pool {
            None => filter_rows(depth, vd, rx, ry, &k, 0, &mut buf.filtered),
            Some(pool) => {
                let parts = pool.current_num_threads();
                let rows = h.div_ceil(parts);
                pool.install(|| {
                    split_run(&mut buf.filtered, rows * w, 0, &|start: usize, chunk: &mut [f32]| {
                        filter_rows(depth, vd, rx, ry, &k, start / w, chunk);
                    });
                });
            }
        }
    }

    /// Runs the whole pipeline on one frame and fills `out` (sized by
    /// [`new_output`](Self::new_output); other sizes are resized).
    ///
    /// Errors (the frame is not processed, the previous output is left as it was): image size
    /// differs from the intrinsics, missing or wrong-length joint state, NaN joints or camera
    /// pose. Invalid depth pixels (0, NaN, out of range) are simply not obstacles.
    pub fn process(&mut self, frame: &Frame<'_>, out: &mut FdedOutput) -> Result<()> {
        let t0 = Instant::now();
        self.check(frame)?;
        self.render(frame);
        let t1 = Instant::now();
        self.filter(frame);
        let t1b = Instant::now();
        let links = self.model.link_count();
        let (tile, sx, sy) = (self.params.tile_size, self.params.step_x, self.params.step_y);
        robot_lattice(&mut self.buf, tile, links);
        object_lattice(&mut self.buf, sx, sy);
        let t2 = Instant::now();
        self.minimum();
        let t3 = Instant::now();
        self.refine();
        let t4 = Instant::now();
        self.finish(frame, out);
        let t5 = Instant::now();
        let us = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e6;
        out.times = StageTimes {
            virtual_depth_us: us(t0, t1),
            filter_us: us(t1, t1b),
            lattices_us: us(t1b, t2),
            minimum_us: us(t2, t3),
            refine_us: us(t3, t4),
            output_us: us(t4, t5),
            total_us: us(t0, t5),
        };
        Ok(())
    }

    /// Stage 5: per-link minimum over the robot × object lattices, split over the object
    /// lattice between the workers.
    fn minimum(&mut self) {
        let tile = self.params.tile_size;
        let tiles_x = self.cam.width.div_ceil(tile);
        let w = self.cam.width;
        let tile_of = move |p: u32| (p / w / tile) * tiles_x + (p % w) / tile;
        let buf = &mut self.buf;
        let n = buf.obj_depth.len();
        for part in buf.partial_best.iter_mut() {
            part.fill(LinkBest::NONE);
        }
        let parts = buf.partial_best.len();
        {
            let (robot, robot_pixel) = (&buf.robot_lattice[..], &buf.robot_lattice_pixel[..]);
            let (ox, oy, od, opix) = (&buf.obj_ray_x[..], &buf.obj_ray_y[..], &buf.obj_depth[..], &buf.obj_pixel[..]);
            let work = |part: usize, best: &mut [LinkBest]| {
                let r = part_range(n, parts, part);
                let obj = Objects {
                    ray_x: &ox[r.clone()],
                    ray_y: &oy[r.clone()],
                    depth: &od[r.clone()],
                };
                lattice_minimum(robot, robot_pixel, obj, &opix[r], tile_of, best);
            };
            run_parts(self.pool.as_ref(), &mut buf.partial_best, &work);
        }
        merge(&buf.partial_best, &mut buf.link_best);
    }

    /// Stage 6: refinement over every robot pixel of each link's winning tile (split over the
    /// object lattice between the workers), then the optional obstacle-side refinement.
    fn refine(&mut self) {
        let p = &self.params;
        let cam = self.cam;
        let buf = &mut self.buf;
        let n = buf.obj_depth.len();
        let parts = buf.partial_best.len();
        for part in buf.partial_best.iter_mut() {
            part.copy_from_slice(&buf.link_best);
        }
        {
            let (vd, labels, rx, ry) = (&buf.virtual_depth[..], &buf.labels[..], &buf.ray_x[..], &buf.ray_y[..]);
            let (ox, oy, od, opix) = (&buf.obj_ray_x[..], &buf.obj_ray_y[..], &buf.obj_depth[..], &buf.obj_pixel[..]);
            let link_best = &buf.link_best[..];
            let tile_size = p.tile_size;
            let work = |part: usize, best: &mut [LinkBest]| {
                let r = part_range(n, parts, part);
                let obj = Objects {
                    ray_x: &ox[r.clone()],
                    ray_y: &oy[r.clone()],
                    depth: &od[r.clone()],
                };
                for (l, lb) in link_best.iter().enumerate() {
                    if lb.is_some() {
                        refine_tile(vd, labels, rx, ry, &cam, tile_size, lb.tile, l as u8, obj, &opix[r.clone()], &mut best[l]);
                    }
                }
            };
            run_parts(self.pool.as_ref(), &mut buf.partial_best, &work);
        }
        merge(&buf.partial_best, &mut buf.link_best);
        if p.refine_obstacle {
            for l in 0..buf.link_best.len() {
                let mut b = buf.link_best[l];
                refine_obstacle(buf, &cam, p.tile_size, (p.step_x, p.step_y), l as u8, &mut b);
                buf.link_best[l] = b;
            }
        }
    }

    /// Stage 7 and the output: normals, velocities, base-frame points, global minimum.
    fn finish(&mut self, frame: &Frame<'_>, out: &mut FdedOutput) {
        let links = self.model.link_count();
        if out.links.len() != links {
            out.links.clear();
            out.links.extend((0..links).map(LinkDistance::none));
        }
        let buf = &self.buf;
        let w = buf.width as usize;
        let window = (self.params.normal_fraction * (buf.width as f64) * (buf.height as f64)).round() as usize;
        let base_from_cam = frame.camera_pose;
        let (alpha, vmax) = (self.params.velocity_smoothing, self.params.max_obstacle_speed);
        out.stamp = frame.stamp;
        out.closest = None;
        let mut closest = f64::INFINITY;
        for l in 0..links {
            let b = buf.link_best[l];
            let track = &mut self.tracks[l];
            if !b.is_some() {
                out.links[l] = LinkDistance::none(l);
                track.valid = false;
                continue;
            }
            let rp = b.robot_pixel as usize;
            let dr = buf.virtual_depth[rp];
            let r = Vector3::new(buf.ray_x[rp % w] * dr, buf.ray_y[rp / w] * dr, dr);
            let op = b.object_pixel as usize;
            let d_o = buf.filtered[op].max(dr);
            let o = Vector3::new(buf.ray_x[op % w] * d_o, buf.ray_y[op / w] * d_o, d_o);
            let n_cam = obstacle_normal(buf, b.object_pixel, window.max(9), self.params.normal_sigma as f32, &r)
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
            *track = Track {
                valid: true,
                stamp: frame.stamp,
                point: obstacle_point,
                velocity,
            };
            let distance = f64::from(b.dist2).sqrt();
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
            robot_lattice: buf.robot_lattice.len(),
            object_lattice: buf.obj_depth.len(),
        };
    }
}

/// `f32` camera model from intrinsics, rejecting unusable ones.
pub(crate) fn cam_of(k: &Intrinsics) -> Result<Cam> {
    if k.width == 0 || k.height == 0 {
        return Err(Error::BadIntrinsics {
            reason: "the image has no pixels",
        });
    }
    if !(k.fx.is_finite() && k.fy.is_finite() && k.fx > 0.0 && k.fy > 0.0) {
        return Err(Error::BadIntrinsics {
            reason: "focal lengths must be finite and > 0 px",
        });
    }
    if !(k.cx.is_finite() && k.cy.is_finite()) {
        return Err(Error::BadIntrinsics {
            reason: "principal point must be finite",
        });
    }
    if (k.width as u64) * (k.height as u64) >= 1 << 24 {
        return Err(Error::BadIntrinsics {
            reason: "images of 2^24 pixels or more are not supported",
        });
    }
    Ok(Cam {
        width: k.width,
        height: k.height,
        fx: k.fx as f32,
        fy: k.fy as f32,
        cx: k.cx as f32,
        cy: k.cy as f32,
    })
}

/// Range of items `0..n` that part `part` of `parts` handles.
pub(crate) fn part_range(n: usize, parts: usize, part: usize) -> std::ops::Range<usize> {
    (n * part / parts)..(n * (part + 1) / parts)
}

/// Calls `work(i, &mut slots[i])` for every slot, on the pool's threads when there is a pool
/// (recursive `rayon::join`, which needs no heap allocation), else in order on this thread.
pub(crate) fn run_parts(
    pool: Option<&rayon::ThreadPool>,
    slots: &mut [Vec<LinkBest>],
    work: &(dyn Fn(usize, &mut [LinkBest]) + Sync),
) {
    fn rec(slots: &mut [Vec<LinkBest>], first: usize, work: &(dyn Fn(usize, &mut [LinkBest]) + Sync)) {
        match slots.len() {
            0 => {}
            1 => work(first, &mut slots[0]),
            n => {
                let (a, b) = slots.split_at_mut(n / 2);
                rayon::join(|| rec(a, first, work), || rec(b, first + n / 2, work));
            }
        }
    }
    match pool {
        Some(pool) if slots.len() > 1 => pool.install(|| rec(slots, 0, work)),
        _ => {
            for (i, s) in slots.iter_mut().enumerate() {
                work(i, s);
            }
        }
    }
}

/// Splits `data` into chunks of `chunk` items and runs `f(offset, chunk)` on each in parallel.
fn split_run(data: &mut [f32], chunk: usize, offset: usize, f: &(dyn Fn(usize, &mut [f32]) + Sync)) {
    if data.len() <= chunk {
        f(offset, data);
        return;
    }
    let (a, b) = data.split_at_mut(chunk);
    rayon::join(|| f(offset, a), || split_run(b, chunk, offset + chunk, f));
}

/// Per link, the best of the workers' partial results.
pub(crate) fn merge(parts: &[Vec<LinkBest>], out: &mut [LinkBest]) {
    for (l, o) in out.iter_mut().enumerate() {
        *o = parts.iter().fold(LinkBest::NONE, |acc, p| acc.min(p[l]));
    }
}
