//! The per-frame pipeline: [`Fded`] owns the buffers and runs the stages in order.

use std::time::Instant;

use crate::cam::Cam;
use crate::error::{Error, Result};
use crate::layout::{Buffers, LinkBest};
use crate::params::{Backend, FdedParams};
use crate::raster::{Removal, RobotMeshes, RobotPointSet, render_virtual_depth, transform_points, transform_vertices, view_chunks};
use crate::stages::{
    Classify, Objects, TablePlane, classify_full, classify_window, dist2, gray_depth, lattice_minimum, normal_cut2,
    SlotPoints, gather_slot, group_slots, object_lattice, obstacle_normal, refine_obstacle, refine_slot,
    remove_robot_at_lattice, robot_lattice, window_around,
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
    /// Forward kinematics, mesh vertices and robot points to the camera frame, projection.
    pub virtual_depth_us: f64,
    /// Robot removal at the object lattice samples.
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
    /// Fills the back half of a frame from the instants `[minimum starts, refinement starts,
    /// output starts, end]` (stages 1–4 are timed by `front`).
    pub(crate) fn set_back(&mut self, t: [Instant; 4]) {
        let us = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e6;
        self.minimum_us = us(t[0], t[1]);
        self.refine_us = us(t[1], t[2]);
        self.output_us = us(t[2], t[3]);
        self.total_us += us(t[0], t[3]);
    }

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
    /// The link's closest distance, m.
    distance: f64,
    /// The link's pose (base frame) at that frame.
    link_pose: Isometry3<f64>,
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
    points: RobotPointSet,
    intrinsics: Intrinsics,
    cam: Cam,
    params: FdedParams,
    buf: Buffers,
    poses: LinkPoses,
    tracks: Vec<Track>,
    pool: Option<rayon::ThreadPool>,
    classify: Classify,
    removal: Removal,
    /// Per link this frame: (object pixel, unoriented normal) already fitted.
    normals: Vec<(u32, Option<Vector3<f32>>)>,
    /// The frame whose z = `table_z` is the table plane, ← robot base (identity: the base's).
    table_from_base: Isometry3<f64>,
}

/// Half sizes of the windows: obstacle-side refinement (±(S − 1)) and normal fit (L points).
fn window_halves(params: &FdedParams, width: u32, height: u32) -> ((u32, u32), u32) {
    let l = (params.normal_fraction * f64::from(width) * f64::from(height)).round().max(9.0);
    let half = (l.sqrt() / 2.0).ceil() as u32;
    ((params.step_x - 1, params.step_y - 1), half)
}

impl Fded {
    /// Validates everything once and sizes every buffer.
    ///
    /// Errors: bad parameters or intrinsics, a model without meshes or with more than
    /// [`MAX_LINKS`] links, [`Backend::Gpu`] (the GPU path lives in `gpu/`), or no threads.
    pub fn new(model: &RobotModel, intrinsics: &Intrinsics, params: FdedParams) -> Result<Self> {
        if params.backend != Backend::Cpu {
            return Err(Error::BackendUnavailable {
                backend: params.backend,
                reason: "this type is the CPU pipeline; build the GPU pipeline from the gpu module",
            });
        }
        Self::host(model, intrinsics, params)
    }

    /// [`new`](Self::new) for any backend: the host-side stages the GPU path shares.
    pub(crate) fn host(model: &RobotModel, intrinsics: &Intrinsics, params: FdedParams) -> Result<Self> {
        params.validate()?;
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
        let points = RobotPointSet::from_meshes(&meshes, params.robot_point_spacing);
        let (refine_half, normal_half) = window_halves(&params, cam.width, cam.height);
        let side = |h: u32, n: u32| (2 * h + 1).min(n) as usize;
        // Room for the union of a few overlapping normal windows (see `fit_normals`).
        let window = (side(refine_half.0, cam.width) * side(refine_half.1, cam.height))
            .max(4 * side(normal_half, cam.width) * side(normal_half, cam.height))
            .min(cam.width as usize * cam.height as usize);
        let mut buf = Buffers::new(
            cam.width,
            cam.height,
            links,
            meshes.vertices.len(),
            meshes.chunks.len(),
            points.len(),
            params.threads,
            params.tile_size,
            (params.step_x, params.step_y),
            window,
        );
        crate::stages::rays(&cam, &mut buf.ray_x, &mut buf.ray_y, intrinsics);
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
        let classify = Classify {
            min_depth: params.min_depth as f32,
            max_depth: params.max_depth as f32,
            table: None,
        };
        let removal = Removal {
            delta: params.robot_delta as f32,
            margin: params.robot_margin as f32,
        };
        Ok(Self {
            model: model.clone(),
            meshes,
            points,
            intrinsics: *intrinsics,
            cam,
            params,
            buf,
            poses: LinkPoses::new(),
            tracks: vec![Track::default(); links],
            pool,
            classify,
            removal,
            normals: Vec::with_capacity(links),
            table_from_base: Isometry3::identity(),
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

    /// The working buffers as the last frame left them (robot points, lattices, per-link
    /// pairs; the full-resolution virtual and filtered depth after [`prepare`](Self::prepare)).
    pub fn buffers(&self) -> &Buffers {
        &self.buf
    }

    pub(crate) fn buffers_mut(&mut self) -> &mut Buffers {
        &mut self.buf
    }

    /// The robot's flattened meshes.
    pub fn meshes(&self) -> &RobotMeshes {
        &self.meshes
    }

    /// The robot point set (link frames).
    pub fn robot_points(&self) -> &RobotPointSet {
        &self.points
    }

    /// The depth classification of the last frame (range, table plane).
    pub fn classification(&self) -> &Classify {
        &self.classify
    }

    /// Forgets the previous frame (obstacle velocities restart at zero).
    pub fn reset_tracks(&mut self) {
        self.tracks.fill(Track::default());
    }

    /// The full-resolution front end for the baselines and tests (not the per-frame path):
    /// [`classify_full`](Self::classify_full), then the z-buffered virtual depth with link
    /// labels ([`Buffers::virtual_depth`], [`Buffers::labels`], [`Buffers::robot_box`]).
    pub fn prepare(&mut self, frame: &Frame<'_>) -> Result<()> {
        self.classify_full(frame)?;
        render_virtual_depth(&self.meshes, &self.cam, self.params.near_clip as f32, &mut self.buf);
        Ok(())
    }

    /// Stage 1 and every pixel of `frame` classified into [`Buffers::filtered`] (robot
    /// removal, table, range) — the classification the lattice samples get, at full
    /// resolution, for methods that read every pixel (brute force, Flacco et al.).
    pub fn classify_full(&mut self, frame: &Frame<'_>) -> Result<()> {
        self.check(frame)?;
        self.transform(frame);
        classify_full(&self.meshes, &frame.depth.data, &self.classify, &self.removal, &mut self.buf);
        Ok(())
    }

    /// Stage 1 (after [`check`](Self::check)): forward kinematics, mesh vertices and robot
    /// points to the camera frame and projected; the table plane of this camera pose.
    fn transform(&mut self, frame: &Frame<'_>) {
        let cam_from_base = frame.camera_pose.inverse();
        let mut q = JointVector::zeros();
        if let Some(j) = frame.joints {
            q.copy_from_slice(j);
        }
        self.model.forward_kinematics(&q, &mut self.poses);
        let near = self.params.near_clip as f32;
        transform_vertices(&self.meshes, &self.poses, &cam_from_base, &self.cam, near, &mut self.buf);
        transform_points(&self.points, &self.poses, &cam_from_base, &self.cam, near, &mut self.buf);
        view_chunks(&self.meshes, &self.poses, &cam_from_base, &self.cam, near, self.removal.margin, &mut self.buf);
        let table_camera = self.table_from_base * frame.camera_pose;
        self.classify.table = self.params.table_z.map(|z| {
            let m = table_camera.rotation.to_rotation_matrix();
            let m = m.matrix();
            TablePlane {
                r2: [m[(2, 0)] as f32, m[(2, 1)] as f32, m[(2, 2)] as f32],
                tz: table_camera.translation.vector.z as f32,
                z_limit: (z + self.params.table_margin) as f32,
                z_top: z as f32,
            }
        });
    }

    pub(crate) fn check(&self, frame: &Frame<'_>) -> Result<()> {
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

    /// Runs the whole pipeline on one frame and fills `out` (sized by
    /// [`new_output`](Self::new_output); other sizes are resized).
    ///
    /// Errors (the frame is not processed, the previous output is left as it was): image size
    /// differs from the intrinsics, missing or wrong-length joint state, NaN joints or camera
    /// pose. Invalid depth pixels (0, NaN, out of range) are simply not obstacles.
    /// Where the table plane is: `table_z` is a height in the frame `table_from_base` maps the
    /// robot base into (the world of an arm mounted on a torso: its base's z is not up), m.
    /// Identity by default: the table plane is z = `table_z` of the base frame.
    pub fn set_table_frame(&mut self, table_from_base: Isometry3<f64>) {
        self.table_from_base = table_from_base;
    }

    /// The frame of the table plane ← robot base ([`set_table_frame`](Self::set_table_frame)).
    pub fn table_frame(&self) -> &Isometry3<f64> {
        &self.table_from_base
    }

    pub fn process(&mut self, frame: &Frame<'_>, out: &mut FdedOutput) -> Result<()> {
        let mut times = self.front(frame)?;
        let t2 = Instant::now();
        self.minimum();
        let t3 = Instant::now();
        self.refine_slots();
        self.refine_obstacles(frame);
        let t4 = Instant::now();
        self.finish(frame, out);
        times.set_back([t2, t3, t4, Instant::now()]);
        out.times = times;
        Ok(())
    }

    /// Stages 1–4 (shared with the GPU path): checks, robot points, robot removal at the
    /// lattice samples, robot and object lattices. Returns their times.
    pub(crate) fn front(&mut self, frame: &Frame<'_>) -> Result<StageTimes> {
        let t0 = Instant::now();
        self.check(frame)?;
        self.transform(frame);
        let t1 = Instant::now();
        let depth = &frame.depth.data[..];
        let step = (self.params.step_x, self.params.step_y);
        remove_robot_at_lattice(&self.meshes, depth, step, &self.classify, &self.removal, &mut self.buf);
        let t1b = Instant::now();
        robot_lattice(&mut self.buf);
        object_lattice(&mut self.buf, step, &self.classify);
        let t2 = Instant::now();
        let us = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e6;
        Ok(StageTimes {
            virtual_depth_us: us(t0, t1),
            filter_us: us(t1, t1b),
            lattices_us: us(t1b, t2),
            total_us: us(t0, t2),
            ..StageTimes::default()
        })
    }

    /// Stage 5: per-link minimum over the robot × object lattices, split over the object
    /// lattice between the workers.
    fn minimum(&mut self) {
        let buf = &mut self.buf;
        let n = buf.obj_depth.len();
        for part in buf.partial_best.iter_mut() {
            part.fill(LinkBest::NONE);
        }
        let parts = buf.partial_best.len();
        {
            let (robot, info) = (&buf.robot_lattice[..], &buf.robot_lattice_info[..]);
            let (ox, oy, od, oc, opix) =
                (&buf.obj_ray_x[..], &buf.obj_ray_y[..], &buf.obj_depth[..], &buf.obj_cap[..], &buf.obj_pixel[..]);
            let work = |part: usize, best: &mut [LinkBest]| {
                let r = part_range(n, parts, part);
                let obj = Objects {
                    ray_x: &ox[r.clone()],
                    ray_y: &oy[r.clone()],
                    depth: &od[r.clone()],
                    cap: &oc[r.clone()],
                };
                lattice_minimum(robot, info, 0, obj, &opix[r], best);
            };
            let pairs = buf.robot_lattice.len() * n;
            run_parts(self.pool.as_ref().filter(|_| pairs >= PARALLEL_MIN_PAIRS), &mut buf.partial_best, &work);
        }
        merge(&buf.partial_best, &mut buf.link_best);
    }

    /// Stage 6: refinement over every robot point of each link's winning slot (split over the
    /// object lattice between the workers).
    fn refine_slots(&mut self) {
        for l in 0..self.buf.link_best.len() {
            let lb = self.buf.link_best[l];
            if lb.is_some() {
                gather_slot(&mut self.buf, lb.lattice as usize, self.points.link_points[l].clone());
            }
        }
        let buf = &mut self.buf;
        let n = buf.obj_depth.len();
        // Out of `buf` while the workers read the rest of it (moving a Vec does not allocate).
        let mut partial = std::mem::take(&mut buf.partial_best);
        let parts = partial.len();
        for part in partial.iter_mut() {
            part.copy_from_slice(&buf.link_best);
        }
        {
            let (ox, oy, od, oc, opix) =
                (&buf.obj_ray_x[..], &buf.obj_ray_y[..], &buf.obj_depth[..], &buf.obj_cap[..], &buf.obj_pixel[..]);
            let (link_best, shared) = (&buf.link_best[..], &*buf);
            let work = |part: usize, best: &mut [LinkBest]| {
                let r = part_range(n, parts, part);
                let obj = Objects {
                    ray_x: &ox[r.clone()],
                    ray_y: &oy[r.clone()],
                    depth: &od[r.clone()],
                    cap: &oc[r.clone()],
                };
                for (l, lb) in link_best.iter().enumerate() {
                    if lb.is_some() {
                        let e = lb.lattice;
                        let pts = SlotPoints::of(shared, e as usize);
                        refine_slot(&pts, e, obj, &opix[r.clone()], &mut best[l]);
                    }
                }
            };
            let points: usize = link_best.iter().filter(|b| b.is_some()).map(|b| shared.robot_lattice_info[b.lattice as usize][3] as usize).sum();
            run_parts(self.pool.as_ref().filter(|_| points * n >= PARALLEL_MIN_PAIRS), &mut partial, &work);
        }
        merge(&partial, &mut buf.link_best);
        buf.partial_best = partial;
    }

    /// Lists the points of every robot lattice slot in [`Buffers::slot_points`] (the CPU
    /// pipeline lists only the winning slots of stage 6; the GPU path uploads all).
    pub fn group_slots(&mut self) {
        group_slots(&mut self.buf);
    }

    /// The optional obstacle-side refinement (`refine_obstacle`): per link, the obstacle pixels
    /// within ±(S − 1) px of its object point that are closer to its robot point than the
    /// pair found, classified on demand.
    pub(crate) fn refine_obstacles(&mut self, frame: &Frame<'_>) {
        if !self.params.refine_obstacle || (self.params.step_x == 1 && self.params.step_y == 1) {
            return;
        }
        let (half, _) = window_halves(&self.params, self.cam.width, self.cam.height);
        let depth = &frame.depth.data[..];
        let links = self.buf.link_best.len();
        let k = self.classify;
        let mut done = [false; MAX_LINKS];
        for l in 0..links {
            let pixel = self.buf.link_best[l].object_pixel;
            if done[l] || !self.buf.link_best[l].is_some() {
                continue;
            }
            // The links whose object point is this pixel share its window: one classification
            // keeps the pixels closer to any of their robot points than its pair; each link's
            // own scan then only takes the pixels closer to its own.
            let mut group = [(0usize, [0.0f32; 3], 0.0f32); MAX_LINKS];
            let mut n = 0;
            for (m, b) in self.buf.link_best.iter().enumerate().skip(l) {
                if b.is_some() && b.object_pixel == pixel {
                    let rp = self.buf.cam_points[b.robot_point as usize];
                    group[n] = (m, [rp[0], rp[1], rp[2]], b.dist2);
                    n += 1;
                    done[m] = true;
                }
            }
            let group = &group[..n];
            let win = window_around(pixel, half, self.cam.width, self.cam.height);
            let keep = |d, rx, ry| {
                k.candidate(d, rx, ry) && {
                    let cap = k.gray_cap(d, rx, ry);
                    group.iter().any(|g| dist2(&g.1, rx, ry, d, cap) < g.2)
                }
            };
            classify_window(&self.meshes, depth, &self.removal, win, keep, None, &mut self.buf);
            for g in group {
                let mut b = self.buf.link_best[g.0];
                refine_obstacle(&self.buf, depth, &self.classify, win, &mut b);
                self.buf.link_best[g.0] = b;
            }
        }
    }

    /// Stage 7: the normal of the obstacle surface at every link's (distinct) obstacle pixel,
    /// into `self.normals`. Each fit takes the window of L pixels around its pixel, keeping the
    /// candidates within the fit's cut-off ball of its point; robot removal there needs only
    /// the triangles that can reach that ball. Windows that overlap (links sharing an obstacle
    /// region) are classified together, once, when their union is no larger than they are
    /// apart: the union keeps the pixels in any of the balls, and each fit's own cut-off drops
    /// the others, so every fit sees exactly its own pixels.
    fn fit_normals(&mut self, depth: &[f32]) {
        self.normals.clear();
        let (_, half) = window_halves(&self.params, self.cam.width, self.cam.height);
        let (w, sigma) = (self.cam.width as usize, self.params.normal_sigma as f32);
        let (cut2, k) = (normal_cut2(sigma), self.classify);
        // Distinct obstacle pixels, their camera-frame points (measured depth) and windows.
        let mut fits = [(0u32, [0.0f32; 3], (0u32, 0u32, 0u32, 0u32)); MAX_LINKS];
        let mut n = 0;
        for b in &self.buf.link_best {
            if b.is_some() && !fits[..n].iter().any(|f| f.0 == b.object_pixel) {
                let op = b.object_pixel as usize;
                let d0 = depth[op];
                let o = [self.buf.ray_x[op % w] * d0, self.buf.ray_y[op / w] * d0, d0];
                fits[n] = (b.object_pixel, o, window_around(b.object_pixel, (half, half), self.cam.width, self.cam.height));
                n += 1;
            }
        }
        let fits = &fits[..n];
        if fits.is_empty() {
            return;
        }
        // A triangle removes a pixel within δ of its depth and (growth included) about
        // 1.5 · margin px of it, i.e. 1.5 · margin · z / f m at depth z ≤ d_o + cut.
        let reach = cut2.sqrt();
        let slack = |o: &[f32; 3]| self.removal.delta + 1.5 * self.removal.margin * (o[2] + reach) / self.cam.fx.min(self.cam.fy) + 1e-3;
        let area = |r: &(u32, u32, u32, u32)| r.2 as usize * r.3 as usize;
        let union = fits.iter().fold((u32::MAX, u32::MAX, 0, 0), |u, f| {
            let r = f.2;
            (u.0.min(r.0), u.1.min(r.1), u.2.max(r.0 + r.2), u.3.max(r.1 + r.3))
        });
        let union = (union.0, union.1, union.2 - union.0, union.3 - union.1);
        let apart: usize = fits.iter().map(|f| area(&f.2)).sum();
        if fits.len() > 1 && area(&union) <= apart && area(&union) <= self.buf.window.len() {
            let centre = fits.iter().fold([0.0f32; 3], |c, f| [c[0] + f.1[0], c[1] + f.1[1], c[2] + f.1[2]]).map(|c| c / fits.len() as f32);
            let radius = fits
                .iter()
                .map(|f| ((f.1[0] - centre[0]).powi(2) + (f.1[1] - centre[1]).powi(2) + (f.1[2] - centre[2]).powi(2)).sqrt() + reach + slack(&f.1))
                .fold(0.0f32, f32::max);
            let keep = |d: f32, rx: f32, ry: f32| {
                k.candidate(d, rx, ry)
                    && fits.iter().any(|f| {
                        let q = [rx * d - f.1[0], ry * d - f.1[1], d - f.1[2]];
                        q[0] * q[0] + q[1] * q[1] + q[2] * q[2] <= cut2
                    })
            };
            classify_window(&self.meshes, depth, &self.removal, union, keep, Some([centre[0], centre[1], centre[2], radius]), &mut self.buf);
            for f in fits {
                let first = (f.2.1 - union.1) as usize * union.2 as usize + (f.2.0 - union.0) as usize;
                let n = obstacle_normal(&self.buf, (union.2 as usize, first), f.2, f.1, sigma);
                self.normals.push((f.0, n));
            }
        } else {
            for f in fits {
                let o = f.1;
                let keep = |d: f32, rx: f32, ry: f32| {
                    let q = [rx * d - o[0], ry * d - o[1], d - o[2]];
                    k.candidate(d, rx, ry) && q[0] * q[0] + q[1] * q[1] + q[2] * q[2] <= cut2
                };
                let focus = [o[0], o[1], o[2], reach + slack(&o)];
                classify_window(&self.meshes, depth, &self.removal, f.2, keep, Some(focus), &mut self.buf);
                let n = obstacle_normal(&self.buf, (f.2.2 as usize, 0), f.2, o, sigma);
                self.normals.push((f.0, n));
            }
        }
    }

    /// Stage 7 and the output: normals, velocities, base-frame points, global minimum.
    pub(crate) fn finish(&mut self, frame: &Frame<'_>, out: &mut FdedOutput) {
        let links = self.model.link_count();
        if out.links.len() != links {
            out.links.clear();
            out.links.extend((0..links).map(LinkDistance::none));
        }
        let base_from_cam = frame.camera_pose;
        let (alpha, vmax) = (self.params.velocity_smoothing, self.params.max_obstacle_speed);
        let depth = &frame.depth.data[..];
        let w = self.cam.width as usize;
        out.stamp = frame.stamp;
        out.closest = None;
        self.fit_normals(depth);
        let mut closest = f64::INFINITY;
        for l in 0..links {
            let b = self.buf.link_best[l];
            if !b.is_some() {
                out.links[l] = LinkDistance::none(l);
                self.tracks[l].valid = false;
                continue;
            }
            let rp = self.buf.cam_points[b.robot_point as usize];
            let r = Vector3::new(rp[0], rp[1], rp[2]);
            let op = b.object_pixel as usize;
            let (rx, ry) = (self.buf.ray_x[op % w], self.buf.ray_y[op / w]);
            let od = depth[op];
            let d_o = gray_depth(rp[2], od, self.classify.gray_cap(od, rx, ry));
            let o = Vector3::new(rx * d_o, ry * d_o, d_o);
            let fitted = self.normals.iter().find(|(p, _)| *p == b.object_pixel).and_then(|&(_, n)| n);
            let n_cam = fitted
                .map(|n| if n.dot(&(r - o)) < 0.0 { -n } else { n })
                .or_else(|| (r - o).try_normalize(1e-9))
                .unwrap_or_else(Vector3::zeros);
            let robot_point = base_from_cam * Point3::from(r.cast::<f64>());
            let obstacle_point = base_from_cam * Point3::from(o.cast::<f64>());
            let normal = base_from_cam.rotation * n_cam.cast::<f64>();
            let distance = f64::from(b.dist2).sqrt();
            let link_pose = *self.poses.get(l);
            let track = &mut self.tracks[l];
            let dt = frame.stamp - track.stamp;
            // The obstacle's speed towards the link, from the distance: u·ȯ = u·ṙ − ḋ, u the
            // unit vector obstacle → robot point, ṙ the motion of that point of the link since
            // the last frame. Not from the closest obstacle point's motion: that point jumps
            // (rim → side of a bottle) as the arm creeps, a "velocity" of 0.6 m/s towards a
            // still arm from a still bottle; the distance itself is continuous.
            let velocity = match (robot_point - obstacle_point).try_normalize(1e-9) {
                Some(u) if track.valid && dt > 0.0 => {
                    let before = track.link_pose * link_pose.inverse_transform_point(&robot_point);
                    let towards = u.dot(&(robot_point - before)) / dt - (distance - track.distance) / dt;
                    if towards.abs() <= vmax {
                        u * (towards * alpha) + track.velocity * (1.0 - alpha)
                    } else {
                        Vector3::zeros()
                    }
                }
                _ => Vector3::zeros(),
            };
            *track = Track {
                valid: true,
                stamp: frame.stamp,
                distance,
                link_pose,
                velocity,
            };
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
            robot_lattice: self.buf.robot_lattice.len(),
            object_lattice: self.buf.obj_depth.len(),
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

/// Stages 5 and 6 go to the worker threads only from this many robot × object pairs: below it
/// (the thesis set on the static scene has ≈ 4 000) handing them over costs more than it saves.
const PARALLEL_MIN_PAIRS: usize = 100_000;

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

/// Per link, the best of the workers' partial results.
pub(crate) fn merge(parts: &[Vec<LinkBest>], out: &mut [LinkBest]) {
    for (l, o) in out.iter_mut().enumerate() {
        *o = parts.iter().fold(LinkBest::NONE, |acc, p| acc.min(p[l]));
    }
}
