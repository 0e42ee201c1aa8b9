//! Which obstacle points are known objects of the task's scene.
//!
//! fDED reports, per link, the closest obstacle point in the depth image — a person's hand, the
//! coffee jar beside the cup, anything. The link damper (`cowork_ds::safety`) is there for what
//! the task does not know (a person); the scene's objects are where the teacher worked, and the
//! pour brings the forearm within 12 cm of the coffee jar. So each link's obstacle point is
//! classified here, on the ROS side, before the distances go to the real-time loop: it is a
//! scene object when it lies inside an object's shape (from the scene file, by name) grown by
//! `margin_m`, at the pose of the newest `/lwr/world` report (cowork_msgs/WorldState: what the
//! simulator — in a real cell, perception — says is where).
//!
//! A marked link's obstacle velocity becomes the object's, from its reported poses (zero for
//! an object that stands still), not fDED's estimate: fDED differentiates the closest pixel of
//! a static box as it jumps between pixels (median 0.095 m/s, p90 0.21 m/s on the tea box in
//! a recorded pour), and through eq. 5.8's (I − M) ẋ_O term that phantom motion outweighed the
//! DS near its goal — `foa1(water)` hovered 2–3 cm off its goal until it timed out.
//!
//! **fDED's gray area.** Behind an object pixel fDED assumes the occluded space is occupied
//! (eq. 5.17): a robot point deeper than the pixel is measured to a point on the pixel's camera
//! ray at the robot point's depth, not on the object. So a wrist reaching down behind the coffee
//! jar (seen from the camera) gets obstacle points 4–10 cm beyond the jar's surface — in a
//! recorded coffee run they stalled the spoon's dip into the cup (`noa21(cup)`) for its whole
//! 120 s. A point is therefore also the object's when the segment from the camera to it passes
//! through the object's grown shape: it lies in that object's shadow. (A hand hidden in the
//! same shadow is invisible to the camera anyway; a hand in front of the object is its own,
//! nearer pixel and is damped in full.) [`SceneObjects::with_camera`]`(None)` makes only the
//! shape test.
//!
//! **The other arms.** In a scene with several arms (`config/scenes/pizza.yaml`) each arm's
//! fDED removes only its own arm from the depth image, so the other arm is an obstacle like any
//! other — and with the person distances (stop 10 cm, slow 30 cm) the arm pouring over the
//! pizza stalled beside the arm waiting at the central area's boundary ("approach limited:
//! lwr_link_4", `cowork experiment pizza` seeds 1 and 2, 2026-12-05). The other arm is not a
//! person: where it is comes from its own `/<arm>/joint_states` and the shared URDF, exactly.
//! So an obstacle point within `margin_m` of one of its link hulls (the link meshes' convex
//! hulls, `cowork_sim::ArmHulls`), or in the shadow of one seen from the camera, is marked as
//! known — the links keep the scene distances from it (stop 3 cm), never pass into it — and
//! its velocity is that link point's, from the last two joint states. Joint states further
//! than `max_age_s` from the distances' stamp: the other arm is unknown (the full distances).
//!
//! **The table top.** fDED removes the table plane from the depth image (the task works on
//! it), so no obstacle point ever lies on the table and nothing kept the links off it: in
//! `cowork experiment pizza --arms uni` seed 2 (2026-12-06) the wrist went 10 cm below the top
//! reaching for a bottle next to the shoulder. With `keep_off_table` each link's lowest hull
//! point over the table's footprint (at the joint state nearest the distances' stamp) becomes
//! its obstacle point, a known object (stop 3 cm), whenever the table is closer than what fDED
//! saw; the tool's own links near the tool stay free to grasp (the damper's `hand_radius`).
//!
//! Fail closed: no report, a report further than `max_age_s` from the distances' stamp, one in
//! another frame or with a non-finite pose, an object whose name has no shape: nothing is
//! known, every obstacle gets the damper's full (person) distances.

use std::collections::HashMap;
use std::path::Path;

use anyhow::{Context, Result};
use cowork_ds::Distances;
use cowork_msgs::msg::WorldState;
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use cowork_sim::{ArmHulls, Shape};
use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// The `scene_objects:` block of the ds_controller parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SceneObjectsParams {
    /// Scene file whose `objects:` give each object's shape by name (poses come from
    /// `/lwr/world`); empty: no object known, the damper treats every obstacle as a person.
    pub scene: String,
    /// An obstacle point within this distance of an object's shape belongs to it, m (depth
    /// noise, fDED's sampling and the object's motion between its report and the frame).
    pub margin_m: f64,
    /// A `/lwr/world` report is used only for distances stamped within this time of it, s.
    pub max_age_s: f64,
    /// Keep the links off the scene's table top (module docs): it becomes a link's obstacle
    /// where it is closer than fDED's.
    pub keep_off_table: bool,
}

impl Default for SceneObjectsParams {
    fn default() -> Self {
        Self { scene: String::new(), margin_m: 0.04, max_age_s: 0.2, keep_off_table: false }
    }
}

impl SceneObjectsParams {
    /// Rejects NaN and out-of-range values (`place` names the file).
    pub fn validate(&self, place: &str) -> Result<()> {
        if !(self.margin_m.is_finite() && (0.0..=0.2).contains(&self.margin_m)) {
            anyhow::bail!("{place}: `scene_objects.margin_m` = {} must be in [0, 0.2] m", self.margin_m);
        }
        if !(self.max_age_s.is_finite() && self.max_age_s > 0.0 && self.max_age_s <= 5.0) {
            anyhow::bail!("{place}: `scene_objects.max_age_s` = {} must be in (0, 5] s", self.max_age_s);
        }
        Ok(())
    }
}

/// The known objects and their newest reported poses.
#[derive(Debug, Clone)]
pub struct SceneObjects {
    shapes: HashMap<String, Shape>,
    margin_m: f64,
    max_age_s: f64,
    base_frame: String,
    /// Camera position (optical frame origin), base frame: obstacle points in an object's
    /// shadow seen from here are that object's (module docs). `None`: shape test only.
    camera: Option<Point3<f64>>,
    /// (stamp s, [(name, shape, pose in the base frame, velocity m/s)]) of the newest usable
    /// report.
    world: Option<(f64, Vec<Known>)>,
    /// The scene's other arms (none in a single-arm scene).
    others: Option<OtherArms>,
    /// The table top this arm's links keep off (`keep_off_table`).
    table: Option<TableTop>,
}

/// The scene's table top and this arm, for keeping its links off it.
#[derive(Debug, Clone)]
struct TableTop {
    /// World ← this arm's base.
    world_from_base: Isometry3<f64>,
    /// Height of the top (world z, m) and its footprint (world x and y ranges, m).
    top_z: f64,
    x: (f64, f64),
    y: (f64, f64),
    model: RobotModel,
    hulls: ArmHulls,
}

/// Links before this one stand on their mount (the base and the first link): never the table's.
const FIRST_TABLE_LINK: usize = 2;

/// The hand's lowest point is held off the table top from this height, m ([`SceneObjects::mark_table`]):
/// below the 2.9 cm its grasps came to, above the top.
pub const HAND_FLOOR_M: f64 = 0.015;

/// The other arms of the scene and their newest joint states.
#[derive(Debug, Clone)]
struct OtherArms {
    model: RobotModel,
    hulls: ArmHulls,
    arms: Vec<OtherArm>,
}

/// One other arm.
#[derive(Debug, Clone)]
struct OtherArm {
    name: String,
    /// Its base frame in this arm's base frame.
    base: Isometry3<f64>,
    /// (stamp s, joint positions rad) of its newest and previous joint states. Kept as joints:
    /// they come at 1 kHz, the distances that need link poses at 30 Hz.
    newest: Option<(f64, JointVector)>,
    previous: Option<(f64, JointVector)>,
}

/// One known object in the newest report.
#[derive(Debug, Clone)]
struct Known {
    name: String,
    shape: Shape,
    pose: Isometry3<f64>,
    /// Velocity of its centre from the previous report (m/s, base frame; zero when there is
    /// none within 0.5 s).
    velocity: Vector3<f64>,
}

impl OtherArm {
    /// Velocity (m/s, this arm's base frame) of the point of link `link` now at `p`, from the
    /// last two joint states (zero without two within 0.5 s); `now` is the newest one's link
    /// poses.
    fn point_velocity(&self, model: &RobotModel, now: &LinkPoses, link: usize, p: &Point3<f64>) -> Vector3<f64> {
        let (Some((t, _)), Some((t0, q0))) = (&self.newest, &self.previous) else { return Vector3::zeros() };
        let dt = t - t0;
        if !(dt > 0.0 && dt <= 0.5) {
            return Vector3::zeros();
        }
        let local = (self.base * now.get(link)).inverse_transform_point(p);
        (p - self.base * model.link_pose(q0, link) * local) / dt
    }
}

impl SceneObjects {
    /// From the parameters: the scene file (empty: none known) relative to the working
    /// directory; reports must be in `base_frame`. The scene's other arms are `model`s.
    pub fn from_params(p: &SceneObjectsParams, base_frame: &str, model: &RobotModel) -> Result<Self> {
        let mut shapes = HashMap::new();
        let mut camera = None;
        let mut others = Vec::new();
        let mut table = None;
        if p.keep_off_table && p.scene.is_empty() {
            anyhow::bail!("ds_controller parameters: `scene_objects.keep_off_table` needs `scene_objects.scene` (where the table is)");
        }
        if !p.scene.is_empty() {
            let path = Path::new(&p.scene);
            let scene = cowork_sim::Scene::from_file(path)
                .with_context(|| format!("ds_controller parameters: `scene_objects.scene` {}", path.display()))?;
            // The camera in this arm's base frame (`left/lwr_base_link` is arm `left`'s).
            let prefix = base_frame.rfind('/').map_or("", |i| &base_frame[..=i]);
            let base = scene.arm_base_for_prefix(prefix).with_context(|| {
                format!(
                    "ds_controller parameters: `scene_objects.scene` {} has no arm for the frames {prefix:?} of this node's namespace",
                    path.display()
                )
            })?;
            camera = Some(Point3::from((base.inverse() * scene.camera.pose.isometry()).translation.vector));
            let own = prefix.strip_suffix('/').unwrap_or(prefix);
            for arm in scene.arm_setups().into_iter().filter(|a| a.name != own) {
                others.push((arm.name, base.inverse() * arm.base.isometry()));
            }
            if p.keep_off_table {
                let c = scene.table.pose.position;
                let size = scene.table.size;
                table = Some(TableTop {
                    world_from_base: base,
                    top_z: scene.table_top_z(),
                    x: (c[0] - size[0] / 2.0, c[0] + size[0] / 2.0),
                    y: (c[1] - size[1] / 2.0, c[1] + size[1] / 2.0),
                    model: model.clone(),
                    hulls: ArmHulls::new(model),
                });
            }
            shapes.extend(scene.objects.into_iter().map(|o| (o.name, o.shape)));
        }
        let mut known = Self::new(shapes, p.margin_m, p.max_age_s, base_frame).with_camera(camera);
        known.table = table;
        if !others.is_empty() {
            known = known.with_other_arms(model, others);
        }
        Ok(known)
    }

    /// The other arms of the scene, `(name, base pose in this arm's base frame)`, all of
    /// `model`: obstacle points on them are known (module docs) once their joint states come
    /// ([`SceneObjects::on_other_arm`]).
    pub fn with_other_arms(mut self, model: &RobotModel, arms: Vec<(String, Isometry3<f64>)>) -> Self {
        let arms = arms.into_iter().map(|(name, base)| OtherArm { name, base, newest: None, previous: None }).collect();
        self.others = Some(OtherArms { model: model.clone(), hulls: ArmHulls::new(model), arms });
        self
    }

    /// Names of the other arms, in the order [`SceneObjects::on_other_arm`] numbers them.
    pub fn other_arms(&self) -> Vec<String> {
        self.others.iter().flat_map(|o| o.arms.iter().map(|a| a.name.clone())).collect()
    }

    /// Joint positions `q` (rad, validated by the caller) of other arm `arm` measured at
    /// `stamp` (s). A stamp not after the newest one is ignored (a late or repeated message).
    pub fn on_other_arm(&mut self, arm: usize, q: &JointVector, stamp: f64) {
        let Some(others) = self.others.as_mut() else { return };
        let Some(other) = others.arms.get_mut(arm) else { return };
        if !stamp.is_finite() || other.newest.as_ref().is_some_and(|(t, _)| stamp <= *t) {
            return;
        }
        other.previous = other.newest.replace((stamp, *q));
    }

    /// Obstacle points in an object's shadow seen from `camera` (base frame) are that object's.
    pub fn with_camera(mut self, camera: Option<Point3<f64>>) -> Self {
        self.camera = camera.filter(|c| c.iter().all(|v| v.is_finite()));
        self
    }

    /// With `shapes` by object name.
    pub fn new(shapes: HashMap<String, Shape>, margin_m: f64, max_age_s: f64, base_frame: &str) -> Self {
        Self { shapes, margin_m, max_age_s, base_frame: base_frame.to_owned(), camera: None, world: None, others: None, table: None }
    }

    /// Number of objects with a known shape.
    pub fn known(&self) -> usize {
        self.shapes.len()
    }

    /// Whether anything can be known: an object shape or another arm.
    pub fn any(&self) -> bool {
        !self.shapes.is_empty() || self.others.is_some()
    }

    /// Whether the links keep off the table top ([`SceneObjects::mark_table`]).
    pub fn keeps_off_table(&self) -> bool {
        self.table.is_some()
    }

    /// Makes the table top the obstacle of every link (from the second moving link on) whose
    /// lowest hull point over the table's footprint is closer to the top than its obstacle in
    /// `d` (or that has none): the obstacle point is straight below on the top, the normal
    /// up, the velocity zero, and the link marked as on a known object. `q` (rad) are this
    /// arm's joints when `d` was measured. Returns how many links; 0 without `keep_off_table`.
    ///
    /// The hand — a lowest point within `hand_radius_m` of the tool point, which the damper
    /// leaves free to grasp — below [`HAND_FLOOR_M`] gets the table as its obstacle whatever
    /// fDED saw (exempt from the damper anyway), marked [`Distances::floor`]: the damper holds
    /// it off the top too (`cowork experiment pizza
    /// --arms uni` seed 2: reaching for the cheese beside the shoulder, the hand went 4 mm
    /// below the top while keep_off_table kept every other link 3 cm above it; in the other
    /// 19 trials of that table the hand's lowest point stayed 2.9 cm or more above the top).
    pub fn mark_table(&self, d: &mut Distances, q: &JointVector, hand_radius_m: f64) -> usize {
        let Some(t) = &self.table else { return 0 };
        let mut poses = LinkPoses::new();
        t.model.forward_kinematics(q, &mut poses);
        let base_from_world = t.world_from_base.inverse();
        let up = base_from_world.rotation * Vector3::z();
        let tool = t.world_from_base * Point3::from(poses.get(t.model.tip_link()).translation.vector);
        let over = |p: &Point3<f64>| (t.x.0..=t.x.1).contains(&p.x) && (t.y.0..=t.y.1).contains(&p.y);
        let mut n = 0;
        let count = d.count.min(d.links.len());
        for l in FIRST_TABLE_LINK..count {
            let Some(low) = t.hulls.lowest_point(&t.world_from_base, &poses, l, over) else { continue };
            let height = low.z - t.top_z;
            let floor = height < HAND_FLOOR_M && (low - tool).norm() < hand_radius_m;
            let link = &mut d.links[l];
            if !floor && link.valid && link.distance <= height {
                continue;
            }
            d.floor[l] = floor;
            link.valid = true;
            link.distance = height.max(0.0);
            link.robot_point = base_from_world * low;
            link.obstacle_point = base_from_world * Point3::new(low.x, low.y, t.top_z);
            link.normal = up;
            link.obstacle_velocity = Vector3::zeros();
            d.scene_object[l] = true;
            n += 1;
        }
        n
    }

    /// A `/lwr/world` report. One in another frame, with a non-finite stamp or pose is
    /// refused (`Err` says why) and forgets the last one, so nothing is known until a good
    /// report arrives. Objects without a known shape are skipped.
    pub fn on_world(&mut self, msg: &WorldState) -> std::result::Result<(), String> {
        let frame = msg.header.frame_id.trim_start_matches('/');
        let stamp = msg.header.stamp.to_secs_f64();
        let why = if !frame.is_empty() && frame != self.base_frame {
            Some(format!("frame {:?} is not the base frame {:?}", cowork_ros::text_prefix(frame, 80), self.base_frame))
        } else if !stamp.is_finite() {
            Some("header.stamp is not finite".into())
        } else {
            None
        };
        if let Some(why) = why {
            self.world = None;
            return Err(why);
        }
        let mut objects: Vec<Known> = Vec::with_capacity(msg.objects.len().min(self.shapes.len()));
        let previous = self.world.take();
        for o in &msg.objects {
            let Some(shape) = self.shapes.get(&o.name) else { continue };
            let (p, q) = (&o.pose.position, &o.pose.orientation);
            let quat = Quaternion::new(q.w, q.x, q.y, q.z);
            if ![p.x, p.y, p.z, q.x, q.y, q.z, q.w].iter().all(|v| v.is_finite()) || quat.norm() < 1e-6 {
                self.world = None;
                return Err(format!("object {:?}: pose not finite", cowork_ros::text_prefix(&o.name, 80)));
            }
            let pose = Isometry3::from_parts(Translation3::new(p.x, p.y, p.z), UnitQuaternion::from_quaternion(quat));
            let velocity = previous
                .as_ref()
                .filter(|(t, _)| stamp > *t && stamp - *t <= 0.5)
                .and_then(|(t, known)| {
                    let before = known.iter().find(|k| k.name == o.name)?;
                    Some((pose.translation.vector - before.pose.translation.vector) / (stamp - t))
                })
                .unwrap_or_else(Vector3::zeros);
            objects.push(Known { name: o.name.clone(), shape: *shape, pose, velocity });
        }
        self.world = Some((stamp, objects));
        Ok(())
    }

    /// Marks in `d.scene_object` the links whose valid obstacle point lies on a known object,
    /// and gives them the object's reported velocity. Returns how many; `None` (and nothing
    /// marked or changed) when no report is within `max_age_s` of `d.stamp`.
    pub fn mark(&self, d: &mut Distances) -> Option<usize> {
        d.scene_object = [false; cowork_robot::MAX_LINKS];
        let on_arms = self.mark_other_arms(d);
        let (t, objects) = self.world.as_ref()?;
        let age = (t - d.stamp).abs();
        if age.is_nan() || age > self.max_age_s {
            return None;
        }
        let mut n = on_arms;
        for (link, mark) in d.links.iter_mut().zip(d.scene_object.iter_mut()).take(d.count) {
            if *mark || !link.valid || !link.obstacle_point.iter().all(|v| v.is_finite()) {
                continue;
            }
            let p = Point3::from(link.obstacle_point);
            let on = objects.iter().find(|k| self.on_or_behind(k, &p));
            if let Some(k) = on {
                *mark = true;
                link.obstacle_velocity = k.velocity;
                n += 1;
            }
        }
        Some(n)
    }

    /// Marks the links whose valid obstacle point lies on another arm (within the margin of a
    /// link hull, or in its shadow seen from the camera) with joint states within `max_age_s`
    /// of `d.stamp`, and gives them that link point's velocity. Returns how many.
    fn mark_other_arms(&self, d: &mut Distances) -> usize {
        let Some(others) = self.others.as_ref() else { return 0 };
        // Link poses of each arm whose newest joint state is within `max_age_s` of the distances.
        let poses: Vec<Option<LinkPoses>> = others
            .arms
            .iter()
            .map(|arm| {
                let (t, q) = arm.newest.as_ref()?;
                let age = (t - d.stamp).abs();
                (age <= self.max_age_s).then(|| {
                    let mut poses = LinkPoses::new();
                    others.model.forward_kinematics(q, &mut poses);
                    poses
                })
            })
            .collect();
        let mut n = 0;
        for (link, mark) in d.links.iter_mut().zip(d.scene_object.iter_mut()).take(d.count) {
            if !link.valid || !link.obstacle_point.iter().all(|v| v.is_finite()) {
                continue;
            }
            let p = Point3::from(link.obstacle_point);
            for (arm, poses) in others.arms.iter().zip(&poses) {
                let Some(poses) = poses else { continue };
                let on = match others.hulls.nearest_link(&arm.base, poses, &p) {
                    Some((distance, l)) if distance <= self.margin_m => Some(l),
                    _ => self.camera.and_then(|c| others.hulls.link_on_segment(&arm.base, poses, &p, &c)),
                };
                let Some(l) = on else { continue };
                *mark = true;
                link.obstacle_velocity = arm.point_velocity(&others.model, poses, l, &p);
                n += 1;
                break;
            }
        }
        n
    }

    /// `p` (base frame) lies in `k`'s shape grown by the margin, or in its shadow: the segment
    /// from the camera to `p` passes through that grown shape. Sampled from `p` towards the
    /// camera in steps no longer than the margin (at most 2 m of it: fDED's gray area ends at
    /// the table), so a grown shape is never stepped over.
    fn on_or_behind(&self, k: &Known, p: &Point3<f64>) -> bool {
        let local = |x: &Point3<f64>| k.pose.inverse_transform_point(x);
        if k.shape.contains_grown(&local(p), self.margin_m) {
            return true;
        }
        let Some(c) = self.camera else { return false };
        let to_camera = c - p;
        let length = to_camera.norm();
        if length.is_nan() || length <= 1e-9 {
            return false;
        }
        let step = self.margin_m.clamp(0.005, 0.02);
        let steps = (length.min(2.0) / step).ceil() as usize;
        (1..=steps).any(|i| {
            let x = p + to_camera * ((i as f64 * step).min(length) / length);
            k.shape.contains_grown(&local(&x), self.margin_m)
        })
    }
}

#[cfg(test)]
mod tests {
    use cowork_ds::LinkDistance;
    use cowork_msgs::builtin_interfaces::Time;
    use cowork_msgs::msg::WorldObject;
    use nalgebra::{Point3, Vector3};

    use super::*;

    fn world(t: f64, frame: &str, jar_z: f64) -> WorldState {
        let mut w = WorldState::default();
        w.header.stamp = Time::from_secs_f64(t);
        w.header.frame_id = frame.into();
        let mut o = WorldObject { name: "coffee".into(), ..Default::default() };
        o.pose.position.x = 0.45;
        o.pose.position.y = -0.35;
        o.pose.position.z = jar_z;
        o.pose.orientation.w = 1.0;
        w.objects.push(o);
        let mut p = WorldObject { name: "unknown".into(), ..Default::default() };
        p.pose.orientation.w = 1.0;
        w.objects.push(p);
        w
    }

    fn distances(t: f64, points: &[[f64; 3]]) -> Distances {
        let mut d = Distances::clear(t);
        d.count = points.len();
        for (l, p) in d.links.iter_mut().zip(points) {
            *l = LinkDistance { valid: true, distance: 0.1, obstacle_point: Point3::from(*p), ..LinkDistance::NONE };
        }
        d
    }

    #[test]
    fn a_point_on_a_known_object_is_marked_and_nothing_else() {
        let shapes = HashMap::from([("coffee".to_owned(), Shape::Cylinder { radius: 0.045, height: 0.12 })]);
        let mut s = SceneObjects::new(shapes, 0.04, 0.2, "lwr_base_link");
        // Top of the jar (inside the margin), 10 cm beside it (a hand), the table far away.
        let pts = [[0.47, -0.33, 0.13], [0.45, -0.18, 0.10], [0.0, 0.5, 0.0]];
        let mut d = distances(1.0, &pts);
        assert_eq!(s.mark(&mut d), None, "no report yet: nothing known");
        assert!(d.scene_object.iter().all(|m| !m));
        s.on_world(&world(1.05, "lwr_base_link", 0.06)).expect("good report");
        d.links[0].obstacle_velocity = Vector3::new(0.1, -0.2, 0.05);
        d.links[1].obstacle_velocity = Vector3::new(0.0, 1.0, 0.0);
        assert_eq!(s.mark(&mut d), Some(1));
        assert_eq!(&d.scene_object[..3], &[true, false, false]);
        // fDED's pixel-jump velocity of a standing jar is replaced by the jar's (zero); a hand's is kept.
        assert_eq!(d.links[0].obstacle_velocity, Vector3::zeros());
        assert_eq!(d.links[1].obstacle_velocity, Vector3::new(0.0, 1.0, 0.0));
        // A jar that moves 1 cm in 0.05 s between reports: 0.2 m/s.
        s.on_world(&world(1.10, "lwr_base_link", 0.07)).expect("good report");
        let mut d2 = distances(1.1, &[[0.47, -0.33, 0.14]]);
        assert_eq!(s.mark(&mut d2), Some(1));
        assert!((d2.links[0].obstacle_velocity - Vector3::new(0.0, 0.0, 0.2)).norm() < 1e-9, "{}", d2.links[0].obstacle_velocity);
        // The jar moved (carried away): its old place is free.
        s.on_world(&world(1.15, "lwr_base_link", 0.5)).expect("good report");
        assert_eq!(s.mark(&mut d), Some(0));
        // Stale: the distances are 0.5 s older than the report.
        let mut old = distances(0.6, &pts);
        s.on_world(&world(1.1, "", 0.06)).expect("empty frame is the base frame");
        assert_eq!(s.mark(&mut old), None);
        // Refused reports forget what was known.
        assert!(s.on_world(&world(1.2, "camera", 0.06)).is_err_and(|e| e.contains("camera")));
        assert_eq!(s.mark(&mut d), None);
        s.on_world(&world(1.0, "lwr_base_link", 0.06)).expect("good report");
        let mut bad = world(1.0, "lwr_base_link", f64::NAN);
        bad.objects.swap(0, 1);
        assert!(s.on_world(&bad).is_err_and(|e| e.contains("coffee")));
        assert_eq!(s.mark(&mut d), None);
        // Invalid entries are never marked.
        s.on_world(&world(1.0, "lwr_base_link", 0.06)).expect("good report");
        d.links[0].valid = false;
        assert_eq!(s.mark(&mut d), Some(0));
    }

    #[test]
    fn a_point_in_a_known_objects_shadow_is_the_object() {
        // fDED's gray area: behind the jar (seen from the camera) the obstacle point lies on a
        // jar pixel's ray at the robot point's depth, 5–10 cm beyond the jar's surface.
        let shapes = HashMap::from([("coffee".to_owned(), Shape::Cylinder { radius: 0.045, height: 0.12 })]);
        let camera = Point3::new(1.9, 0.9, 1.2);
        let jar = Point3::new(0.45, -0.35, 0.06);
        let away = (jar - camera).normalize();
        let behind = jar + away * 0.10;
        let in_front = jar - away * 0.15;
        let beside = [0.45, -0.18, 0.10];
        let pts = [[behind.x, behind.y, behind.z], [in_front.x, in_front.y, in_front.z], beside];
        let mut plain = SceneObjects::new(shapes.clone(), 0.04, 0.2, "lwr_base_link");
        plain.on_world(&world(1.0, "lwr_base_link", 0.06)).expect("good report");
        let mut d = distances(1.0, &pts);
        assert_eq!(plain.mark(&mut d), Some(0), "without a camera only the shape counts");
        let mut s = SceneObjects::new(shapes, 0.04, 0.2, "lwr_base_link").with_camera(Some(camera));
        s.on_world(&world(1.0, "lwr_base_link", 0.06)).expect("good report");
        let mut d = distances(1.0, &pts);
        assert_eq!(s.mark(&mut d), Some(1));
        assert_eq!(&d.scene_object[..3], &[true, false, false], "in the shadow only; in front of and beside the jar stay unknown");
        // A non-finite camera is ignored (shape test only).
        let shapes = HashMap::from([("coffee".to_owned(), Shape::Cylinder { radius: 0.045, height: 0.12 })]);
        let mut nan = SceneObjects::new(shapes, 0.04, 0.2, "lwr_base_link").with_camera(Some(Point3::new(f64::NAN, 0.0, 0.0)));
        nan.on_world(&world(1.0, "lwr_base_link", 0.06)).expect("good report");
        let mut d = distances(1.0, &pts);
        assert_eq!(nan.mark(&mut d), Some(0));
    }

    #[test]
    fn params_are_validated() {
        assert!(SceneObjectsParams::default().validate("p").is_ok());
        for bad in [SceneObjectsParams { margin_m: f64::NAN, ..Default::default() }, SceneObjectsParams { max_age_s: 0.0, ..Default::default() }] {
            assert!(bad.validate("p.yaml").is_err_and(|e| e.to_string().contains("scene_objects")));
        }
        let missing = SceneObjectsParams { scene: "/nonexistent/scene.yaml".into(), ..Default::default() };
        assert!(SceneObjects::from_params(&missing, "b", &lwr()).is_err_and(|e| format!("{e:#}").contains("scene_objects.scene")));
    }

    fn lwr() -> RobotModel {
        RobotModel::from_urdf_file(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/robot/lwr4plus.urdf")).expect("URDF")
    }

    fn scene_params(scene: &str) -> SceneObjectsParams {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/scenes").join(scene);
        SceneObjectsParams { scene: path.display().to_string(), ..Default::default() }
    }

    #[test]
    fn a_point_on_the_other_arm_is_known_with_that_links_velocity() {
        let model = lwr();
        let mut s = SceneObjects::from_params(&scene_params("pizza.yaml"), "left/lwr_base_link", &model).expect("pizza scene");
        assert_eq!(s.other_arms(), ["right"]);
        let single = SceneObjects::from_params(&scene_params("kitchen.yaml"), "lwr_base_link", &model).expect("kitchen scene");
        assert!(single.other_arms().is_empty(), "a single-arm scene has no other arm");

        // The right arm at its start joints, in the left arm's base frame.
        let scene = cowork_sim::Scene::from_file(Path::new(&scene_params("pizza.yaml").scene)).expect("scene");
        let (left, right) = (scene.arms[0].base.isometry(), scene.arms[1].base.isometry());
        let q0 = JointVector::from_iterator(scene.arms[1].initial_joints_deg.iter().map(|d| d.to_radians()));
        // The centre of link 5's mesh (inside its hull).
        let mesh = &model.link_mesh(5).expect("link 5 mesh").vertices;
        let centre = mesh.iter().fold(Vector3::zeros(), |c, v| c + v.coords) / mesh.len() as f64;
        let on_wrist = left.inverse() * right * model.link_pose(&q0, 5) * Point3::from(centre);
        let free = Point3::new(0.3, 0.3, 0.3);
        let pts = [[on_wrist.x, on_wrist.y, on_wrist.z], [free.x, free.y, free.z]];

        let mut d = distances(1.0, &pts);
        assert_eq!(s.mark(&mut d), None, "no joint states and no world report yet");
        assert_eq!(&d.scene_object[..2], &[false, false], "an arm not heard from is unknown");
        s.on_other_arm(0, &q0, 1.0);
        let mut d = distances(1.0, &pts);
        s.mark(&mut d);
        assert_eq!(&d.scene_object[..2], &[true, false], "on the wrist: known; 30 cm away: unknown");
        assert_eq!(d.links[0].obstacle_velocity, Vector3::zeros(), "one joint state: standing");

        // Joint 1 turning at 1 rad/s: the wrist point moves at ω × r about joint 1's axis.
        let mut q1 = q0;
        q1[0] += 0.01;
        s.on_other_arm(0, &q1, 1.01);
        s.on_other_arm(0, &q0, 1.005); // late: ignored
        let moved = left.inverse() * right * model.link_pose(&q1, 5) * Point3::from(centre);
        let mut d = distances(1.01, &[[moved.x, moved.y, moved.z]]);
        s.mark(&mut d);
        assert!(d.scene_object[0]);
        let expected = (moved - on_wrist) / 0.01;
        assert!((d.links[0].obstacle_velocity - expected).norm() < 0.02 * expected.norm(), "{} vs {expected}", d.links[0].obstacle_velocity);

        // Joint states 0.3 s from the distances: unknown again (fail closed).
        let mut late = distances(1.31, &[[moved.x, moved.y, moved.z]]);
        s.mark(&mut late);
        assert!(!late.scene_object[0]);
    }

    #[test]
    fn the_links_keep_off_the_table_top_where_it_is_closer_than_fded_saw() {
        let model = lwr();
        let off = SceneObjects::from_params(&scene_params("pizza.yaml"), "left/lwr_base_link", &model).expect("pizza scene");
        assert!(!off.keeps_off_table(), "off by default");
        let on_params = SceneObjectsParams { keep_off_table: true, ..scene_params("pizza.yaml") };
        let on = SceneObjects::from_params(&on_params, "left/lwr_base_link", &model).expect("pizza scene");
        assert!(on.keeps_off_table());
        let no_scene = SceneObjectsParams { keep_off_table: true, ..Default::default() };
        assert!(SceneObjects::from_params(&no_scene, "b", &model).is_err_and(|e| format!("{e:#}").contains("keep_off_table")));

        let scene = cowork_sim::Scene::from_file(Path::new(&on_params.scene)).expect("scene");
        let base = scene.arms[0].base.isometry();
        let n = model.link_count();
        // `uni` seed 2, 2026-12-06, 48 s: reaching for the cheese at (0.255, 0.528) next to the
        // shoulder, the wrist 4 cm below the table top.
        let q = JointVector::from_row_slice(&[0.6559, 1.7409, -0.8627, -1.0146, -2.0174, -2.0919, 0.2808]);
        let mut d = Distances::clear(1.0);
        d.count = n;
        let far = LinkDistance { valid: true, distance: 0.1, normal: Vector3::x(), ..LinkDistance::NONE };
        d.links[..n].fill(far);
        d.links[3] = LinkDistance { distance: 0.01, ..far };
        let hand_radius = cowork_ds::safety::SafetyConfig::default().hand_radius;
        // fDED saw the cheese at the hand (the last link), nearer than the table.
        d.links[n - 1] = LinkDistance { distance: 0.002, ..far };
        let marked = on.mark_table(&mut d, &q, hand_radius);
        let mut poses = LinkPoses::new();
        model.forward_kinematics(&q, &mut poses);
        let hulls = ArmHulls::new(&model);
        let below: Vec<usize> = (2..n)
            .filter(|&l| hulls.lowest_point(&base, &poses, l, |_| true).is_some_and(|p| p.z < 0.0))
            .collect();
        assert!(!below.is_empty(), "the recorded reach has links below the top");
        assert!(marked >= below.len(), "{marked} marked, {below:?} below the top");
        let up = base.inverse().rotation * Vector3::z();
        let tool = base * Point3::from(poses.get(model.tip_link()).translation.vector);
        let hand: Vec<usize> = below
            .iter()
            .copied()
            .filter(|&l| hulls.lowest_point(&base, &poses, l, |_| true).is_some_and(|p| (p - tool).norm() < hand_radius))
            .collect();
        assert!(hand.contains(&(n - 1)), "the hand is below the top too: {hand:?} of {below:?}");
        for &l in &below {
            let o = &d.links[l];
            assert!(o.valid && d.scene_object[l] && o.distance == 0.0, "link {l}: {o:?}");
            assert_eq!(d.floor[l], hand.contains(&l), "link {l}: the hand's table entry is held even within hand_radius");
            assert!((o.normal - up).norm() < 1e-9, "the table pushes up (the world's z in the arm's base frame)");
            let (robot, table) = (base * o.robot_point, base * o.obstacle_point);
            assert!(robot.z < 0.0 && table.z.abs() < 1e-9 && (robot.xy() - table.xy()).norm() < 1e-9, "{robot} over {table}");
        }
        assert_eq!(d.links[3].distance, 0.01, "fDED's nearer obstacle kept");
        assert!(!d.scene_object[0] && !d.scene_object[1] && d.links[0].distance == 0.1, "the base and the first link stand on their mount");

        // At the start joints every link is well above the table: fDED's 10 cm stay.
        let q0 = JointVector::from_iterator(scene.arms[0].initial_joints_deg.iter().map(|d| d.to_radians()));
        let mut d0 = Distances::clear(1.0);
        d0.count = n;
        d0.links[..n].fill(far);
        assert_eq!(on.mark_table(&mut d0, &q0, hand_radius), 0);
        assert_eq!(off.mark_table(&mut d, &q, hand_radius), 0, "off: nothing");
    }
}
