//! [`FdedNode`]: the node's state and its per-message handlers, with no I/O.

use std::collections::{HashMap, VecDeque};
use std::time::Instant;

use anyhow::Result;
use cowork_depth::{DepthImage, Intrinsics};
use cowork_fded::gpu::{BACKEND_ENV, BackendRequest, FdedEngine};
use cowork_fded::baseline::{Flacco, FlaccoHit, FlaccoParams};
use cowork_fded::{Fded, FdedOutput, Frame};
use cowork_msgs::geometry_msgs::{Point, TransformStamped, Vector3};
use cowork_msgs::msg::{LinkDistance, LinkDistances};
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState};
use cowork_msgs::std_msgs::Header;
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_msgs::visualization_msgs::MarkerArray;
use cowork_robot::{DOF, RobotModel};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};

use crate::manipulated::{ManipulatedObjects, Refusal, Removal};
use crate::markers::fill_markers;
use crate::params::Params;
use crate::{TOPIC_CAMERA_INFO, TOPIC_DEPTH, TOPIC_JOINT_STATES, TOPIC_TF_STATIC};
use cowork_msgs::msg::ObjectStream;

/// Joint states remembered for matching frames by stamp (2 s of a 1 kHz publisher).
const JOINT_HISTORY: usize = 2048;
/// Camera poses remembered from `/tf_static` (distinct child frames): a peer publishing new
/// frame names cannot grow the node without bound.
pub const MAX_CAMERA_FRAMES: usize = 64;

/// Why a frame (or a message) was not used: a [`cowork_ros::Warning`] whose text names the
/// topic and the reason and whose `kind` is the key of the rate limiter.
pub type Skip = cowork_ros::Warning;

fn skip(kind: &'static str, message: String) -> Skip {
    Skip::new(kind, message)
}

/// The node's state: camera intrinsics and the fDED engine (built when the first camera info
/// arrives, rebuilt when it changes), recent joint states, camera poses from `/tf_static`, and
/// the reused output buffers and messages.
#[derive(Debug)]
pub struct FdedNode {
    params: Params,
    request: BackendRequest,
    model: RobotModel,
    base_frame: String,
    link_names: Vec<String>,
    engine: Option<(Intrinsics, FdedEngine)>,
    out: Option<FdedOutput>,
    /// `method: flacco`: the sphere method, the CPU pipeline whose robot removal it uses, and
    /// its per-link result (built with the engine).
    flacco: Option<(Flacco, Box<Fded>, Vec<Option<FlaccoHit>>)>,
    depth: DepthImage,
    /// (stamp s, joint positions rad), stamps non-decreasing.
    joints: VecDeque<(f64, [f64; DOF])>,
    camera_from_tf: HashMap<String, Isometry3<f64>>,
    /// Every `/tf_static` edge seen: child frame → (parent frame, child in parent), at most
    /// [`MAX_CAMERA_FRAMES`]; a camera beside the base under one parent (`world` → arm base,
    /// `world` → camera, as lwr_sim's scenes with named arms) is found through it.
    static_edges: HashMap<String, (String, Isometry3<f64>)>,
    camera_default: Isometry3<f64>,
    msg: LinkDistances,
    markers: MarkerArray,
    notice: Option<Skip>,
    /// The manipulated objects (`None`: `manipulated.enabled` false).
    manipulated: Option<ManipulatedObjects>,
    /// What was removed from the last frame.
    removal: Removal,
    refusals: Vec<Refusal>,
    /// Processing times (s) since the last report.
    times: Vec<f64>,
    frames: u64,
}

impl FdedNode {
    /// The node for `model` with `params` (validated here).
    pub fn new(model: RobotModel, params: Params) -> Result<Self> {
        params.validate("fded_distance parameters")?;
        let request = params.backend_request("fded_distance parameters")?;
        let link_names = model.link_names().to_vec();
        let Some(base_frame) = link_names.first().cloned() else {
            anyhow::bail!("the robot model has no links");
        };
        let camera_default = params.camera_pose.isometry();
        let manipulated = if params.manipulated.enabled {
            let mut shapes = HashMap::new();
            if !params.manipulated.scene.is_empty() {
                let path = std::path::Path::new(&params.manipulated.scene);
                let scene = cowork_sim::Scene::from_file(path).map_err(|e| {
                    anyhow::anyhow!("fded_distance parameters: `manipulated.scene` {}: {e}", path.display())
                })?;
                shapes.extend(scene.objects.into_iter().map(|o| (o.name, o.shape)));
            }
            Some(ManipulatedObjects::new(shapes, params.manipulated.margin_m, params.manipulated.max_age_s, &base_frame))
        } else {
            None
        };
        Ok(Self {
            manipulated,
            removal: Removal::default(),
            refusals: Vec::new(),
            request,
            base_frame,
            msg: LinkDistances {
                links: link_names.iter().map(|n| LinkDistance { link_name: n.clone(), ..Default::default() }).collect(),
                min_index: -1,
                ..Default::default()
            },
            markers: MarkerArray::default(),
            link_names,
            model,
            engine: None,
            out: None,
            flacco: None,
            depth: DepthImage::default(),
            joints: VecDeque::with_capacity(JOINT_HISTORY),
            camera_from_tf: HashMap::new(),
            static_edges: HashMap::new(),
            camera_default,
            notice: None,
            times: Vec::with_capacity(1024),
            frames: 0,
            params,
        })
    }

    /// The parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// The backend request the engine is built with.
    pub fn request(&self) -> BackendRequest {
        self.request
    }

    /// The backend in use (`"wgpu"`, `"cpu"`), `None` before the first camera info.
    pub fn backend(&self) -> Option<&'static str> {
        self.engine.as_ref().map(|(_, e)| e.backend_name())
    }

    /// The robot base frame, in which results are expressed.
    pub fn base_frame(&self) -> &str {
        &self.base_frame
    }

    /// Names the robot's frames with `prefix` (`left/` for a node in namespace `/left`: the
    /// arm's tf frames are `left/lwr_base_link`, ...): the base frame of the results, of the
    /// camera transform looked up on `/tf_static` and of the manipulated-object lists.
    pub fn set_frame_prefix(&mut self, prefix: &str) {
        let base = format!("{prefix}{}", self.link_names[0]);
        if let Some(m) = self.manipulated.as_mut() {
            m.set_base_frame(&base);
        }
        self.base_frame = base;
        self.camera_from_tf.clear();
    }

    /// Cameras that share the base's parent on `/tf_static` (and have no direct base → camera
    /// edge): base ← camera = (parent ← base)⁻¹ (parent ← camera).
    fn cameras_beside_the_base(&mut self) {
        let Some((parent, base)) = self.static_edges.get(&self.base_frame) else { return };
        for (child, (p, pose)) in &self.static_edges {
            if p == parent && *child != self.base_frame && self.camera_from_tf.len() < MAX_CAMERA_FRAMES {
                self.camera_from_tf.entry(child.clone()).or_insert_with(|| base.inv_mul(pose));
            }
        }
    }

    /// Camera info: (re)builds the engine when the intrinsics change.
    pub fn on_camera_info(&mut self, msg: &CameraInfo) -> Result<(), Skip> {
        let k = Intrinsics::from_camera_info(msg)
            .map_err(|e| skip("camera_info", format!("{TOPIC_CAMERA_INFO}: message ignored: {e}")))?;
        if self.engine.as_ref().is_some_and(|(old, _)| *old == k) {
            return Ok(());
        }
        let build = |request| {
            FdedEngine::new(&self.model, &k, self.params.fded.clone(), request).map_err(|e| {
                skip("engine", format!("{TOPIC_CAMERA_INFO}: cannot build fDED for a {}x{} camera: {e}", k.width, k.height))
            })
        };
        let mut engine = build(self.request)?;
        // `auto` on a software adapter (Mesa's lavapipe): measured beside lwr_sim it is ~25x
        // slower than the CPU path (22 ms vs 0.8 ms median per 640x480 frame), so the node
        // keeps the CPU there; `gpu` still forces the adapter.
        if let FdedEngine::Gpu(g) = &engine
            && g.context().adapter_info().device_type == wgpu::DeviceType::Cpu
            && self.effective_request() == BackendRequest::Auto
        {
            tracing::info!("fDED: {} is a software adapter; using the CPU path (backend: gpu forces the adapter)", g.context().adapter_name());
            engine = build(BackendRequest::Cpu)?;
        }
        tracing::info!(
            "fDED ready: {}x{} px, backend {}{}",
            k.width,
            k.height,
            engine.backend_name(),
            engine.adapter_name().map(|a| format!(" ({a})")).unwrap_or_default()
        );
        self.out = Some(engine.new_output());
        if self.params.method == "flacco" {
            let cpu = Fded::new(&self.model, &k, self.params.fded.clone()).map_err(|e| {
                skip("engine", format!("{TOPIC_CAMERA_INFO}: cannot build the Flacco baseline for a {}x{} camera: {e}", k.width, k.height))
            })?;
            tracing::info!("method flacco: Flacco et al.'s spheres (CPU) compute the distances");
            let window = self.params.flacco;
            let params = FlaccoParams { min_depth: window.min_depth, max_depth: window.max_depth, ..FlaccoParams::default() };
            tracing::info!("method flacco: depth window {:.2}-{:.2} m", window.min_depth, window.max_depth);
            self.flacco = Some((Flacco::new(&self.model, params), Box::new(cpu), Vec::new()));
        }
        self.engine = Some((k, engine));
        Ok(())
    }

    /// The request after `COWORK_FDED_BACKEND` (which overrides the parameter when set and valid).
    fn effective_request(&self) -> BackendRequest {
        match std::env::var_os(BACKEND_ENV) {
            Some(_) => BackendRequest::from_env().unwrap_or(self.request),
            None => self.request,
        }
    }

    /// Joint state: the positions of the model's joints, by name, remembered with the stamp.
    /// Incomplete or non-finite states are rejected (the earlier ones stay in use).
    pub fn on_joint_state(&mut self, msg: &JointState) -> Result<(), Skip> {
        if msg.name.len() != msg.position.len() {
            return Err(skip(
                "joint_state",
                format!("{TOPIC_JOINT_STATES}: message ignored: {} names but {} positions", msg.name.len(), msg.position.len()),
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
                format!("{TOPIC_JOINT_STATES}: message ignored: joint {} missing or not finite", self.model.joint_names()[i]),
            ));
        }
        let stamp = msg.header.stamp.to_secs_f64();
        // Time went back (a bag looped, a simulator restarted): the history no longer applies.
        if self.joints.back().is_some_and(|(s, _)| stamp < *s) {
            self.joints.clear();
        }
        if self.joints.len() == JOINT_HISTORY {
            self.joints.pop_front();
        }
        self.joints.push_back((stamp, q));
        Ok(())
    }

    /// `/tf_static`: remembers every transform from the base frame (camera poses by child frame).
    pub fn on_tf_static(&mut self, msg: &TFMessage) -> Result<(), Skip> {
        let mut bad = None;
        let mut full = None;
        for t in &msg.transforms {
            let child = t.child_frame_id.trim_start_matches('/');
            if let Some(pose) = isometry(t) {
                let parent = t.header.frame_id.trim_start_matches('/');
                if self.static_edges.contains_key(child) || self.static_edges.len() < MAX_CAMERA_FRAMES {
                    self.static_edges.insert(child.to_owned(), (parent.to_owned(), pose));
                }
            }
            if t.header.frame_id.trim_start_matches('/') != self.base_frame {
                continue;
            }
            match isometry(t) {
                Some(pose) => {
                    if let Some(p) = self.camera_from_tf.get_mut(child) {
                        *p = pose;
                    } else if self.camera_from_tf.len() < MAX_CAMERA_FRAMES {
                        self.camera_from_tf.insert(child.to_owned(), pose);
                    } else {
                        full = Some(child);
                    }
                }
                None => bad = Some(child),
            }
        }
        self.cameras_beside_the_base();
        match (bad, full) {
            (Some(child), _) => Err(skip(
                "tf_static",
                format!(
                    "{TOPIC_TF_STATIC}: transform {} -> {} ignored: not a finite rigid transform",
                    self.base_frame,
                    cowork_ros::text_prefix(child, 80)
                ),
            )),
            (None, Some(child)) => Err(skip(
                "tf_static",
                format!(
                    "{TOPIC_TF_STATIC}: transform {} -> {} ignored: already {MAX_CAMERA_FRAMES} frames known",
                    self.base_frame,
                    cowork_ros::text_prefix(child, 80)
                ),
            )),
            (None, None) => Ok(()),
        }
    }

    /// `/manipulated_objects` (robot_manager): the objects whose pixels are not obstacles. A
    /// refused list clears what was known (every object is an obstacle until a good one).
    pub fn on_manipulated(&mut self, msg: &ObjectStream) -> Result<(), Skip> {
        let Some(m) = self.manipulated.as_mut() else { return Ok(()) };
        m.on_list(msg).map_err(|r| match r {
            Refusal::Message(t) | Refusal::Stale(t) | Refusal::Object(t) => skip("manipulated", t),
        })
    }

    /// What was removed from the last processed frame as manipulated objects.
    pub fn removed(&self) -> &Removal {
        &self.removal
    }

    /// The joint state for a frame at `stamp` (s): the one closest in time; when that is
    /// further than `max_joint_state_age_s`, the newest, with a notice.
    fn joints_for(&mut self, stamp: f64) -> Option<[f64; DOF]> {
        let newest = *self.joints.back()?;
        let after = self.joints.partition_point(|(s, _)| *s <= stamp);
        let candidates = [after.checked_sub(1), Some(after)];
        let closest = candidates
            .into_iter()
            .flatten()
            .filter_map(|i| self.joints.get(i))
            .min_by(|a, b| (a.0 - stamp).abs().total_cmp(&(b.0 - stamp).abs()))
            .copied()
            .unwrap_or(newest);
        let gap = (closest.0 - stamp).abs();
        if gap <= self.params.max_joint_state_age_s {
            return Some(closest.1);
        }
        self.notice = Some(skip(
            "joint_state_age",
            format!(
                "{TOPIC_JOINT_STATES}: no joint state within {:.3} s of the depth frame at {stamp:.3} s (closest {gap:.3} s away); using the newest",
                self.params.max_joint_state_age_s
            ),
        ));
        Some(newest.1)
    }

    /// Processes one depth image; `Ok(msg)` is the message to publish (the markers for it are
    /// in [`markers`](Self::markers)). A frame that cannot be used is skipped with the reason.
    pub fn on_depth(&mut self, image: &Image) -> Result<&LinkDistances, Skip> {
        let Some((k, _)) = self.engine.as_ref() else {
            return Err(skip("no_camera_info", format!("{TOPIC_DEPTH}: frame skipped: no valid {TOPIC_CAMERA_INFO} yet")));
        };
        if image.width != k.width || image.height != k.height {
            return Err(skip(
                "size",
                format!(
                    "{TOPIC_DEPTH}: frame skipped: image is {}x{} but {TOPIC_CAMERA_INFO} says {}x{}",
                    image.width, image.height, k.width, k.height
                ),
            ));
        }
        let valid = self
            .depth
            .read_image_msg(image)
            .map_err(|e| skip("image", format!("{TOPIC_DEPTH}: frame skipped: {e}")))?;
        let total = self.depth.data.len();
        if (valid as f64) < self.params.min_valid_fraction * total as f64 {
            return Err(skip(
                "blind",
                format!(
                    "{TOPIC_DEPTH}: blind camera: {valid} of {total} pixels have a depth return (min_valid_fraction {}); no distances published, so the robot is held",
                    self.params.min_valid_fraction
                ),
            ));
        }
        let stamp = image.header.stamp.to_secs_f64();
        let Some(q) = self.joints_for(stamp) else {
            return Err(skip("no_joint_state", format!("{TOPIC_DEPTH}: frame skipped: no valid {TOPIC_JOINT_STATES} yet")));
        };
        let frame_id = image.header.frame_id.trim_start_matches('/');
        let camera = self.camera_from_tf.get(frame_id).unwrap_or(&self.camera_default);
        self.removal = Removal::default();
        if let (Some(m), Some((k, _))) = (&self.manipulated, &self.engine) {
            self.refusals.clear();
            self.removal = m.remove(stamp, camera, k, &mut self.depth, &mut self.refusals);
            if let Some(r) = self.refusals.first() {
                let (kind, t) = match r {
                    Refusal::Stale(t) => ("manipulated_stale", t),
                    Refusal::Object(t) | Refusal::Message(t) => ("manipulated_object", t),
                };
                self.notice = Some(skip(kind, t.clone()));
            }
        }
        let Some((_, engine)) = self.engine.as_mut() else {
            unreachable!("checked above");
        };
        // The table plane is level in the frame the base hangs from on /tf_static (the world of
        // arms on a torso), else in the base frame.
        let table_from_base = self.static_edges.get(&self.base_frame).map_or_else(Isometry3::identity, |(_, pose)| *pose);
        engine.set_table_frame(table_from_base);
        if let Some((_, cpu, _)) = self.flacco.as_mut() {
            cpu.set_table_frame(table_from_base);
        }
        let frame = Frame { stamp, depth: &self.depth, camera_pose: camera, joints: Some(&q) };
        if let Some((flacco, cpu, hits)) = self.flacco.as_mut() {
            let t0 = Instant::now();
            flacco
                .closest(cpu, &frame, hits)
                .map_err(|e| skip("fded", format!("{TOPIC_DEPTH}: frame skipped: the Flacco baseline rejected it: {e}")))?;
            let dt = t0.elapsed().as_secs_f64();
            let msg = timed(&mut self.msg, &mut self.times, &mut self.frames, image, &self.base_frame, dt);
            "spheres".clone_into(&mut msg.backend);
            msg.links.resize_with(hits.len(), LinkDistance::default);
            let mut best: Option<(usize, f64)> = None;
            for (i, (m, h)) in msg.links.iter_mut().zip(hits.iter()).enumerate() {
                if m.link_name.is_empty() {
                    m.link_name = self.link_names.get(i).cloned().unwrap_or_default();
                }
                m.obstacle_velocity = Vector3::default();
                match h {
                    Some(h) => {
                        m.valid = true;
                        m.distance = h.distance;
                        m.robot_point = point(&h.robot_point.coords);
                        m.obstacle_point = point(&h.obstacle_point.coords);
                        m.normal = vector(&h.normal);
                        if best.is_none_or(|(_, d)| h.distance < d) {
                            best = Some((i, h.distance));
                        }
                    }
                    None => {
                        m.valid = false;
                        m.distance = f64::INFINITY;
                        m.robot_point = Point::default();
                        m.obstacle_point = Point::default();
                        m.normal = Vector3::default();
                    }
                }
            }
            msg.min_index = best.and_then(|(i, _)| i32::try_from(i).ok()).unwrap_or(-1);
            return Ok(&self.msg);
        }
        let out = self.out.get_or_insert_with(|| engine.new_output());
        let t0 = Instant::now();
        engine
            .process(&frame, out)
            .map_err(|e| skip("fded", format!("{TOPIC_DEPTH}: frame skipped: fDED rejected it: {e}")))?;
        let dt = t0.elapsed().as_secs_f64();
        let msg = timed(&mut self.msg, &mut self.times, &mut self.frames, image, &self.base_frame, dt);
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
        msg.min_index = out.closest.and_then(|i| i32::try_from(i).ok()).unwrap_or(-1);
        if self.params.publish_markers {
            fill_markers(&mut self.markers, &msg.header, out, self.params.normal_arrow_length_m);
        }
        Ok(&self.msg)
    }

    /// The markers of the last processed frame (empty when `publish_markers` is off).
    pub fn markers(&self) -> &MarkerArray {
        &self.markers
    }

    /// A warning about the last frame that did not stop it (e.g. an old joint state).
    pub fn take_notice(&mut self) -> Option<Skip> {
        self.notice.take()
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

/// Counts a processed frame that took `dt` s and stamps `msg` with the frame's stamp.
fn timed<'a>(
    msg: &'a mut LinkDistances,
    times: &mut Vec<f64>,
    frames: &mut u64,
    image: &Image,
    base_frame: &str,
    dt: f64,
) -> &'a mut LinkDistances {
    times.push(dt);
    *frames += 1;
    msg.header = Header { stamp: image.header.stamp, frame_id: base_frame.to_owned() };
    msg.processing_time = dt;
    msg
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
