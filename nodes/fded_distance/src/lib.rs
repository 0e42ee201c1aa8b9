//! The `fded_distance` node: a thin ROS 2 adapter around fDED (thesis Sec. 5.1.2,
//! [`cowork_fded`]), on the wgpu path when a Vulkan adapter exists and the CPU otherwise.
//!
//! Inputs: `/camera/depth/image_raw` (sensor_msgs/Image, `32FC1` m or `16UC1` mm; sensor-data
//! QoS), `/camera/depth/camera_info` (sensor_msgs/CameraInfo), `/joint_states`
//! (sensor_msgs/JointState, matched by joint name), `/tf_static` (tf2_msgs/TFMessage: the
//! transform from the robot base to the image's `frame_id`; until one arrives the configured
//! `camera_pose` is used). Only a direct base → camera transform is read; chains are not
//! composed.
//!
//! Output: `/fded/distances` (cowork_msgs/LinkDistances) for every processed frame, stamped
//! with the image's stamp, in the base frame, with `processing_time` (s, the fDED call) and
//! `backend` (`"wgpu"` or `"cpu"`). No markers: cowork_msgs has no MarkerArray type yet.
//!
//! Frames are never queued: each loop takes the newest image and drops older ones. A frame that
//! cannot be processed (unknown encoding, size different from the camera info, no camera info
//! or joint state yet, bad values) is skipped with a warning, repeated warnings at most once
//! per `warning_period_s`; the node keeps running.
//!
//! [`FdedNode`] does no I/O, so tests drive it message by message; [`run`] wires it to DDS.

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use cowork_depth::{DepthImage, Intrinsics};
use cowork_fded::gpu::{BackendRequest, FdedEngine};
use cowork_fded::{FdedOutput, FdedParams, Frame};
use cowork_msgs::geometry_msgs::{Point, TransformStamped, Vector3};
use cowork_msgs::msg::{LinkDistance, LinkDistances};
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState};
use cowork_msgs::std_msgs::Header;
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_robot::{DOF, RobotModel};
use cowork_ros::{RosNode, qos};
use cowork_sim::Pose;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

/// The `fded_distance: ros__parameters:` block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Robot description (URDF with per-link meshes).
    pub urdf: String,
    /// `auto`, `cpu` or `gpu` (`COWORK_FDED_BACKEND` overrides it).
    pub backend: String,
    /// Take time from `/clock` (only the log and the stale checks use time; stamps are copied).
    pub use_sim_time: bool,
    /// Camera optical frame pose in the base frame, used until `/tf_static` gives one.
    pub camera_pose: Pose,
    /// A joint state older than the frame by more than this is used with a warning, s.
    pub max_joint_state_age_s: f64,
    /// Period of the processing-time log line, s (wall clock).
    pub report_period_s: f64,
    /// Identical warnings are logged at most once per this period, s (wall clock).
    pub warning_period_s: f64,
    /// fDED parameters (thesis Table 5.1 defaults).
    pub fded: FdedParams,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            urdf: "config/robot/lwr4plus.urdf".into(),
            backend: "auto".into(),
            use_sim_time: false,
            camera_pose: Pose {
                position: [1.9, 0.0, 0.9],
                look_at: Some([0.45, 0.0, 0.2]),
                ..Pose::default()
            },
            max_joint_state_age_s: 0.1,
            report_period_s: 5.0,
            warning_period_s: 5.0,
            fded: FdedParams::default(),
        }
    }
}

impl Params {
    /// Rejects NaN and out-of-range values; `place` names the parameter file.
    pub fn validate(&self, place: &str) -> Result<()> {
        self.backend_request(place)?;
        for (name, v) in [
            ("max_joint_state_age_s", self.max_joint_state_age_s),
            ("report_period_s", self.report_period_s),
            ("warning_period_s", self.warning_period_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                bail!("{place}: `{name}` = {v} must be a positive number of seconds");
            }
        }
        let p = &self.camera_pose;
        let finite = p.position.iter().chain(p.rpy.iter().flatten()).chain(p.quaternion_xyzw.iter().flatten())
            .chain(p.look_at.iter().flatten())
            .all(|v| v.is_finite());
        if !finite {
            bail!("{place}: `camera_pose` has a non-finite value");
        }
        if let Err(e) = self.fded.validate() {
            bail!("{place}: `fded`: {e}");
        }
        Ok(())
    }

    /// `backend` as a request.
    pub fn backend_request(&self, place: &str) -> Result<BackendRequest> {
        match BackendRequest::parse(&self.backend) {
            Ok(r) => Ok(r),
            Err(_) => bail!("{place}: `backend` = {:?} must be auto, cpu or gpu", self.backend),
        }
    }
}

/// Why a frame was not processed. The text is the warning logged (rate-limited per kind).
#[derive(Debug, Clone, PartialEq)]
pub struct Skip {
    /// Short kind, the key of the rate limiter.
    pub kind: &'static str,
    /// The message.
    pub message: String,
}

fn skip(kind: &'static str, message: String) -> Skip {
    Skip { kind, message }
}

/// Logs each kind of warning at most once per period, counting the ones it held back.
#[derive(Debug)]
pub struct RateLimitedWarnings {
    period: Duration,
    last: HashMap<&'static str, (Instant, u64)>,
}

impl RateLimitedWarnings {
    /// A limiter with `period_s` seconds between two warnings of the same kind.
    pub fn new(period_s: f64) -> Self {
        Self { period: Duration::from_secs_f64(period_s), last: HashMap::new() }
    }

    /// Logs `skip` unless one of its kind was logged within the period; returns whether it
    /// was logged.
    pub fn warn(&mut self, skip: &Skip) -> bool {
        let now = Instant::now();
        match self.last.get_mut(skip.kind) {
            Some((at, held)) if now.duration_since(*at) < self.period => {
                *held += 1;
                false
            }
            Some((at, held)) => {
                tracing::warn!("frame skipped: {} ({} more like it since the last warning)", skip.message, held);
                *at = now;
                *held = 0;
                true
            }
            None => {
                tracing::warn!("frame skipped: {}", skip.message);
                self.last.insert(skip.kind, (now, 0));
                true
            }
        }
    }
}

/// The node's state: latest camera info, joint state and camera pose, the fDED engine (built
/// when the first camera info arrives, rebuilt when it changes) and the output buffers.
#[derive(Debug)]
pub struct FdedNode {
    params: Params,
    request: BackendRequest,
    model: RobotModel,
    base_frame: String,
    link_names: Vec<String>,
    engine: Option<(Intrinsics, FdedEngine)>,
    out: Option<FdedOutput>,
    depth: DepthImage,
    joints: Option<([f64; DOF], f64)>,
    camera_from_tf: HashMap<String, Isometry3<f64>>,
    camera_default: Isometry3<f64>,
    msg: LinkDistances,
    /// Processing times (s) since the last report.
    times: Vec<f64>,
    frames: u64,
}

impl FdedNode {
    /// The node for `model` with validated `params`.
    pub fn new(model: RobotModel, params: Params) -> Result<Self> {
        params.validate("fded_distance parameters")?;
        let request = params.backend_request("fded_distance parameters")?;
        let base_frame = model.link_names()[0].clone();
        let link_names = model.link_names().to_vec();
        let camera_default = params.camera_pose.isometry();
        Ok(Self {
            request,
            base_frame,
            msg: LinkDistances {
                links: link_names.iter().map(|n| LinkDistance { link_name: n.clone(), ..Default::default() }).collect(),
                ..Default::default()
            },
            link_names,
            model,
            engine: None,
            out: None,
            depth: DepthImage::default(),
            joints: None,
            camera_from_tf: HashMap::new(),
            camera_default,
            times: Vec::with_capacity(1024),
            frames: 0,
            params,
        })
    }

    /// The backend in use (`"wgpu"`, `"cpu"`), `None` before the first camera info.
    pub fn backend(&self) -> Option<&'static str> {
        self.engine.as_ref().map(|(_, e)| e.backend_name())
    }

    /// Camera info: (re)builds the engine when the intrinsics change.
    pub fn on_camera_info(&mut self, msg: &CameraInfo) -> Result<(), Skip> {
        let k = Intrinsics::from_camera_info(msg)
            .map_err(|e| skip("camera_info", format!("/camera/depth/camera_info rejected: {e}")))?;
        if self.engine.as_ref().is_some_and(|(old, _)| *old == k) {
            return Ok(());
        }
        let engine = FdedEngine::new(&self.model, &k, self.params.fded.clone(), self.request)
            .map_err(|e| skip("engine", format!("cannot build fDED for {}x{} camera: {e}", k.width, k.height)))?;
        tracing::info!(
            "fDED ready: {}x{} px, backend {}{}",
            k.width,
            k.height,
            engine.backend_name(),
            engine.adapter_name().map(|a| format!(" ({a})")).unwrap_or_default()
        );
        self.out = Some(engine.new_output());
        self.engine = Some((k, engine));
        Ok(())
    }

    /// Joint state: the positions of the model's joints, by name. Incomplete or non-finite
    /// states are rejected (the previous one stays in use).
    pub fn on_joint_state(&mut self, msg: &JointState) -> Result<(), Skip> {
        if msg.name.len() != msg.position.len() {
            return Err(skip(
                "joint_state",
                format!("/joint_states has {} names but {} positions", msg.name.len(), msg.position.len()),
            ));
        }
        let mut q = [f64::NAN; DOF];
        for (name, &p) in msg.name.iter().zip(&msg.position) {
            if let Some(i) = self.model.joint_index(name) {
                q[i] = p;
            }
        }
        if let Some(i) = q.iter().position(|v| !v.is_finite()) {
            return Err(skip(
                "joint_state",
                format!("/joint_states: joint {} missing or not finite", self.model.joint_names()[i]),
            ));
        }
        self.joints = Some((q, msg.header.stamp.to_secs_f64()));
        Ok(())
    }

    /// `/tf_static`: remembers every transform from the base frame (camera poses by child frame).
    pub fn on_tf_static(&mut self, msg: &TFMessage) {
        for t in &msg.transforms {
            if t.header.frame_id.trim_start_matches('/') != self.base_frame {
                continue;
            }
            match isometry(t) {
                Some(pose) => {
                    self.camera_from_tf.insert(t.child_frame_id.trim_start_matches('/').to_owned(), pose);
                }
                None => tracing::warn!("/tf_static: transform to {} is not a finite rigid transform", t.child_frame_id),
            }
        }
    }

    /// Processes one depth image; `Ok(msg)` is the message to publish.
    pub fn on_depth(&mut self, image: &Image) -> Result<&LinkDistances, Skip> {
        let Some((k, engine)) = self.engine.as_mut() else {
            return Err(skip("no_camera_info", "no valid /camera/depth/camera_info yet".into()));
        };
        if image.width != k.width || image.height != k.height {
            return Err(skip(
                "size",
                format!("depth image is {}x{} but the camera info says {}x{}", image.width, image.height, k.width, k.height),
            ));
        }
        self.depth
            .read_image_msg(image)
            .map_err(|e| skip("image", format!("/camera/depth/image_raw rejected: {e}")))?;
        let Some((q, joint_stamp)) = self.joints.as_ref() else {
            return Err(skip("no_joint_state", "no valid /joint_states yet".into()));
        };
        let stamp = image.header.stamp.to_secs_f64();
        if stamp - joint_stamp > self.params.max_joint_state_age_s {
            tracing::debug!("joint state {:.3} s older than the depth frame", stamp - joint_stamp);
        }
        let frame_id = image.header.frame_id.trim_start_matches('/');
        let camera = self.camera_from_tf.get(frame_id).unwrap_or(&self.camera_default);
        let out = self.out.get_or_insert_with(|| engine.new_output());
        let frame = Frame { stamp, depth: &self.depth, camera_pose: camera, joints: Some(q) };
        let t0 = Instant::now();
        engine
            .process(&frame, out)
            .map_err(|e| skip("fded", format!("fDED rejected the frame: {e}")))?;
        let dt = t0.elapsed().as_secs_f64();
        self.times.push(dt);
        self.frames += 1;
        let msg = &mut self.msg;
        msg.header = Header { stamp: image.header.stamp, frame_id: self.base_frame.clone() };
        msg.processing_time = dt;
        if msg.backend != engine.backend_name() {
            msg.backend = engine.backend_name().to_owned();
        }
        msg.links.resize_with(out.links.len(), LinkDistance::default);
        for (m, l) in msg.links.iter_mut().zip(&out.links) {
            if m.link_name.is_empty() {
                m.link_name = self.link_names.get(l.link).cloned().unwrap_or_default();
            }
            m.valid = l.valid;
            if l.valid {
                m.distance = l.distance;
                m.robot_point = point(&l.robot_point.coords);
                m.obstacle_point = point(&l.obstacle_point.coords);
                m.normal = vector(&l.normal);
                m.obstacle_velocity = vector(&l.obstacle_velocity);
            } else {
                m.distance = f64::INFINITY;
                m.robot_point = Point::default();
                m.obstacle_point = Point::default();
                m.normal = Vector3::default();
                m.obstacle_velocity = Vector3::default();
            }
        }
        msg.min_index = out.closest.map_or(-1, |i| i as i32);
        Ok(&self.msg)
    }

    /// Median and maximum processing time (s) since the last call, and the frame count; clears.
    pub fn take_timing(&mut self) -> Option<(f64, f64, usize)> {
        if self.times.is_empty() {
            return None;
        }
        self.times.sort_by(f64::total_cmp);
        let n = self.times.len();
        let r = (self.times[n / 2], self.times[n - 1], n);
        self.times.clear();
        Some(r)
    }

    /// Frames processed so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }
}

fn point(v: &nalgebra::Vector3<f64>) -> Point {
    Point { x: v.x, y: v.y, z: v.z }
}

fn vector(v: &nalgebra::Vector3<f64>) -> Vector3 {
    Vector3 { x: v.x, y: v.y, z: v.z }
}

/// A `TransformStamped` as an isometry, `None` when not finite or the quaternion is ~0.
pub fn isometry(t: &TransformStamped) -> Option<Isometry3<f64>> {
    let (p, r) = (&t.transform.translation, &t.transform.rotation);
    let all = [p.x, p.y, p.z, r.x, r.y, r.z, r.w];
    if !all.iter().all(|v| v.is_finite()) {
        return None;
    }
    let q = Quaternion::new(r.w, r.x, r.y, r.z);
    if q.norm() < 1e-6 {
        return None;
    }
    Some(Isometry3::from_parts(Translation3::new(p.x, p.y, p.z), UnitQuaternion::from_quaternion(q)))
}

/// Options of [`run`].
#[derive(Debug, Default, Clone)]
pub struct RunOptions {
    /// Stop after this many wall-clock seconds.
    pub duration_s: Option<f64>,
    /// Stop when this flag is raised (besides Ctrl-C / SIGTERM).
    pub stop: Option<Arc<AtomicBool>>,
}

/// Runs the node until Ctrl-C, `options.stop` or `options.duration_s`.
pub fn run(mut node: RosNode, mut fded: FdedNode, options: &RunOptions) -> Result<()> {
    let images = node.subscription::<Image>("/camera/depth/image_raw", &qos::sensor_data())?;
    let infos = node.subscription::<CameraInfo>("/camera/depth/camera_info", &qos::sensor_data())?;
    let joints = node.subscription::<JointState>("/joint_states", &qos::reliable())?;
    let tf_static = node.subscription::<TFMessage>("/tf_static", &qos::latched())?;
    let distances = node.publisher::<LinkDistances>("/fded/distances", &qos::reliable())?;
    let mut warnings = RateLimitedWarnings::new(fded.params.warning_period_s);
    let report = Duration::from_secs_f64(fded.params.report_period_s);
    let started = Instant::now();
    let mut last_report = Instant::now();
    let mut dropped: u64 = 0;
    tracing::info!("fded_distance running: backend request {:?}, waiting for camera info and depth", fded.request);
    let stop_requested = || {
        cowork_ros::shutdown::requested()
            || options.stop.as_ref().is_some_and(|s| s.load(Ordering::SeqCst))
            || options.duration_s.is_some_and(|d| started.elapsed().as_secs_f64() >= d)
    };
    while !stop_requested() {
        while let Some(m) = tf_static.take() {
            fded.on_tf_static(&m);
        }
        if let Some(m) = infos.take_latest()
            && let Err(s) = fded.on_camera_info(&m)
        {
            warnings.warn(&s);
        }
        if let Some(m) = joints.take_latest()
            && let Err(s) = fded.on_joint_state(&m)
        {
            warnings.warn(&s);
        }
        // Newest frame only: anything older that queued up while we worked is dropped.
        let mut newest = None;
        while let Some(m) = images.take() {
            if newest.replace(m).is_some() {
                dropped += 1;
            }
        }
        match newest {
            Some(image) => match fded.on_depth(&image) {
                Ok(msg) => distances.publish(msg.clone())?,
                Err(s) => {
                    warnings.warn(&s);
                }
            },
            None => std::thread::sleep(Duration::from_millis(1)),
        }
        if last_report.elapsed() >= report {
            last_report = Instant::now();
            if let Some((median, max, n)) = fded.take_timing() {
                tracing::info!(
                    "fDED ({}): {n} frames, processing median {:.2} ms, max {:.2} ms; {dropped} stale frames dropped",
                    fded.backend().unwrap_or("-"),
                    median * 1e3,
                    max * 1e3
                );
            }
        }
    }
    tracing::info!("fded_distance stopped after {} frames ({dropped} stale frames dropped)", fded.frames());
    Ok(())
}
