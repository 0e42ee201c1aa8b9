//! The simulation state and its fixed-step integration.

use cowork_robot::{
    DOF, Jacobian, JointVector, LinkPoses, RobotModel, damped_pseudo_inverse,
};
use nalgebra::{Isometry3, Point3, Vector3, Vector6};
use parry3d_f64::bounding_volume::BoundingVolume;
use parry3d_f64::query::{PointQuery, Ray, RayCast};
use parry3d_f64::shape::{ConvexPolyhedron, Shape as ParryShape};

use crate::error::{CommandError, Result, SimError};
use crate::params::SimParams;
use crate::scene::{Scene, Shape};


/// One edge of the frame tree ([`Simulator::frame_tree`]): `child`'s pose in `parent`'s frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameEdge<'a> {
    /// Parent frame (a link frame); `None` for the scene's root frame
    /// ([`Simulator::root_frame`]).
    pub parent: Option<&'a str>,
    /// Child frame: a link frame (`<arm>/<link>` for a named arm) or an object name.
    pub child: &'a str,
    /// `child` in `parent`'s frame (m, rad).
    pub pose: Isometry3<f64>,
}

/// A released object sunk at most this far into another one (m) is put on top of it.
const SUPPORT_TOLERANCE_M: f64 = 0.02;

/// An external wrench (base frame) applied at the origin of a link, as a person pushing the arm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wrench {
    /// Force, N, base frame.
    pub force: Vector3<f64>,
    /// Torque, N m, base frame.
    pub torque: Vector3<f64>,
}

/// The scene frame of a scene with named arms (`arms:`).
pub const WORLD_FRAME: &str = "world";

/// State of a gripper.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GripperState {
    Open,
    /// Closed, holding the object with this index in [`Simulator::objects`], if any.
    Closed { holding: Option<usize> },
}

/// A scene object as simulated.
pub struct ObjectState {
    /// Unique name (tf frame).
    pub name: String,
    /// Geometry as configured.
    pub shape: Shape,
    /// Pose of the shape centre, scene frame (the robot base frame of a single-arm scene).
    pub pose: Isometry3<f64>,
    /// Whether the gripper can pick it up.
    pub graspable: bool,
    collider: Box<dyn ParryShape>,
    collider_offset: Isometry3<f64>,
}

impl std::fmt::Debug for ObjectState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ObjectState")
            .field("name", &self.name)
            .field("shape", &self.shape)
            .field("pose", &self.pose)
            .field("graspable", &self.graspable)
            .finish_non_exhaustive()
    }
}

impl ObjectState {
    /// Distance from a point (scene frame) to the object's surface, m; 0 inside.
    pub fn distance_to(&self, point: &Point3<f64>) -> f64 {
        self.collider
            .distance_to_point(&(self.pose * self.collider_offset), point, true)
    }

    /// Axis-aligned bounding box of the object, scene frame.
    fn aabb(&self) -> parry3d_f64::bounding_volume::Aabb {
        self.collider.compute_aabb(&(self.pose * self.collider_offset))
    }
}

/// One arm as simulated: joints, command, external wrench, gripper and link poses.
#[derive(Debug)]
pub struct Arm {
    name: String,
    /// Base frame in the scene frame.
    base: Isometry3<f64>,
    /// tf frame of every link: the link name, prefixed `<name>/` for a named arm.
    frames: Vec<String>,
    q: JointVector,
    /// Joint velocity applied in the last step, rad/s.
    qd: JointVector,
    command: JointVector,
    command_time_ns: Option<i64>,
    /// Joint position target followed instead of the command while fresh (imitation teaching).
    target: JointVector,
    target_time_ns: Option<i64>,
    wrench: Option<(Wrench, usize, i64)>,
    gripper: GripperState,
    /// Pose of the held object in the tool frame.
    grasp_offset: Isometry3<f64>,
    /// Link poses in the arm's base frame.
    poses: LinkPoses,
    jacobian: Jacobian,
}

impl Arm {
    /// The arm's name: empty for the one arm of a single-arm scene.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Pose of the arm's base frame in the scene frame.
    pub fn base(&self) -> &Isometry3<f64> {
        &self.base
    }

    /// tf frame names of the links, model order (`left/lwr_link_3` for arm `left`).
    pub fn frames(&self) -> &[String] {
        &self.frames
    }

    /// Joint positions, rad.
    pub fn joint_positions(&self) -> &JointVector {
        &self.q
    }

    /// Joint velocities applied in the last step, rad/s.
    pub fn joint_velocities(&self) -> &JointVector {
        &self.qd
    }

    /// Poses of every link, the arm's base frame.
    pub fn link_poses(&self) -> &LinkPoses {
        &self.poses
    }

    /// Gripper state; an object index refers to [`Simulator::objects`].
    pub fn gripper(&self) -> GripperState {
        self.gripper
    }

    fn holding(&self) -> Option<usize> {
        match self.gripper {
            GripperState::Closed { holding } => holding,
            GripperState::Open => None,
        }
    }
}

/// The closest pair of links of two different arms ([`Simulator::arm_clearance`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmClearance {
    /// Distance between the two links' convex hulls, m; 0 when they touch or intersect.
    pub distance_m: f64,
    /// The two arms (indices into [`Simulator::arms`]) and their links (model link indices).
    pub arms: [usize; 2],
    pub links: [usize; 2],
}

/// The convex hull of each link mesh of a model, for the clearance between arms of that model.
#[derive(Debug, Clone)]
pub struct ArmHulls {
    /// Link frame; `None` for a link without a mesh.
    hulls: Vec<Option<ConvexPolyhedron>>,
}

impl ArmHulls {
    /// The hulls of `model`'s link meshes.
    pub fn new(model: &RobotModel) -> Self {
        let hulls = (0..model.link_count())
            .map(|l| model.link_mesh(l).and_then(|m| ConvexPolyhedron::from_convex_hull(&m.vertices)))
            .collect();
        Self { hulls }
    }

    /// Distance (m) from `point` to the nearest link hull of one arm at base pose `base` (the
    /// point's frame) with link poses `poses` (its base frame); 0 inside a hull.
    pub fn distance_to_point(&self, base: &Isometry3<f64>, poses: &LinkPoses, point: &Point3<f64>) -> f64 {
        self.nearest_link(base, poses, point).map_or(f64::INFINITY, |(d, _)| d)
    }

    /// The link whose hull is nearest to `point` and its distance (m; 0 inside), as
    /// [`ArmHulls::distance_to_point`]; `None` for a model without meshes. Allocation-free.
    pub fn nearest_link(&self, base: &Isometry3<f64>, poses: &LinkPoses, point: &Point3<f64>) -> Option<(f64, usize)> {
        self.hulls
            .iter()
            .enumerate()
            .filter_map(|(l, h)| Some((h.as_ref()?.distance_to_point(&(base * poses.get(l)), point, true), l)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// The first link of the arm (as in [`ArmHulls::distance_to_point`]) whose hull the segment
    /// from `from` to `to` (the points' frame) passes through, if any: `from` lies in that
    /// link's shadow seen from `to`. Allocation-free.
    pub fn link_on_segment(&self, base: &Isometry3<f64>, poses: &LinkPoses, from: &Point3<f64>, to: &Point3<f64>) -> Option<usize> {
        let along = to - from;
        let length = along.norm();
        if !(length > 1e-9) {
            return None;
        }
        let ray = Ray::new(*from, along / length);
        self.hulls.iter().enumerate().find_map(|(l, h)| {
            h.as_ref()?.intersects_ray(&(base * poses.get(l)), &ray, length).then_some(l)
        })
    }

    /// The lowest point (z in the base pose's frame, m) among the hull vertices for which
    /// `over` holds (e.g. above the table's footprint) of links `from_link` onwards of one arm
    /// at base pose `base` with link poses `poses` (its base frame), and the link it belongs
    /// to; `None` when no such vertex exists. With `from_link` = 2 the base and the first link,
    /// which stand on their mount, are left out: an arm–table contact is a lower link below the
    /// table top over the table.
    pub fn lowest_z(&self, base: &Isometry3<f64>, poses: &LinkPoses, from_link: usize, over: impl Fn(&Point3<f64>) -> bool) -> Option<(f64, usize)> {
        (from_link..self.hulls.len())
            .filter_map(|l| Some((self.lowest_point(base, poses, l, &over)?.z, l)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// The lowest hull vertex of link `link` (in the base pose's frame, m) among those for which
    /// `over` holds, of an arm at base pose `base` with link poses `poses` (its base frame);
    /// `None` for a link without a mesh or with no such vertex.
    pub fn lowest_point(&self, base: &Isometry3<f64>, poses: &LinkPoses, link: usize, over: impl Fn(&Point3<f64>) -> bool) -> Option<Point3<f64>> {
        let hull = self.hulls.get(link)?.as_ref()?;
        let pose = base * poses.get(link);
        hull.points().iter().map(|p| pose * p).filter(|p| over(p)).min_by(|a, b| a.z.total_cmp(&b.z))
    }

    /// The closest pair of links of two different arms, each arm given by its base pose (a
    /// common frame) and its link poses (its base frame); `None` with fewer than two arms.
    /// Link pairs whose bounding boxes are farther apart than the closest pair found so far
    /// are skipped.
    pub fn clearance<'a>(&self, arms: impl IntoIterator<Item = (Isometry3<f64>, &'a LinkPoses)>) -> Option<ArmClearance> {
        let arms: Vec<_> = arms.into_iter().collect();
        let mut best: Option<ArmClearance> = None;
        for a in 0..arms.len() {
            for b in a + 1..arms.len() {
                for (la, ha) in self.hulls.iter().enumerate() {
                    let Some(ha) = ha else { continue };
                    let pa = arms[a].0 * arms[a].1.get(la);
                    let box_a = ha.compute_aabb(&pa);
                    for (lb, hb) in self.hulls.iter().enumerate() {
                        let Some(hb) = hb else { continue };
                        let pb = arms[b].0 * arms[b].1.get(lb);
                        let bound = best.map_or(f64::INFINITY, |c| c.distance_m);
                        if aabb_gap(&box_a, &hb.compute_aabb(&pb)) >= bound {
                            continue;
                        }
                        let Ok(d) = parry3d_f64::query::distance(&pa, ha, &pb, hb) else { continue };
                        if d < bound {
                            best = Some(ArmClearance { distance_m: d, arms: [a, b], links: [la, lb] });
                        }
                    }
                }
            }
        }
        best
    }
}

/// Kinematic simulator of one or more arms of the same model. See the crate documentation.
#[derive(Debug)]
pub struct Simulator {
    model: RobotModel,
    params: SimParams,
    scene: Scene,
    objects: Vec<ObjectState>,
    step_ns: i64,
    time_ns: i64,
    arms: Vec<Arm>,
    /// The links' hulls for arm–arm clearance (two or more arms).
    hulls: Option<ArmHulls>,
}

impl Simulator {
    /// Builds a simulator; every arm's initial joints must match the model's joints and
    /// limits, and no two arms may touch at their initial joints.
    pub fn new(model: RobotModel, scene: Scene, params: SimParams) -> Result<Self> {
        params.validate("simulator parameters")?;
        scene.validate("scene")?;
        let named = scene.has_named_arms();
        let mut arms = Vec::new();
        for setup in scene.arm_setups() {
            let field = if named { format!("arms[{}].initial_joints_deg", arms.len()) } else { "robot.initial_joints_deg".into() };
            let q = initial_joints(&model, &setup.initial_joints_deg, &field)?;
            let frames = model
                .link_names()
                .iter()
                .map(|l| if named { format!("{}/{l}", setup.name) } else { l.clone() })
                .collect();
            let mut arm = Arm {
                name: setup.name,
                base: setup.base.isometry(),
                frames,
                q,
                qd: JointVector::zeros(),
                command: JointVector::zeros(),
                command_time_ns: None,
                target: JointVector::zeros(),
                target_time_ns: None,
                wrench: None,
                gripper: GripperState::Open,
                grasp_offset: Isometry3::identity(),
                poses: LinkPoses::default(),
                jacobian: Jacobian::zeros(),
            };
            model.forward_kinematics(&arm.q, &mut arm.poses);
            arms.push(arm);
        }
        let objects = scene
            .objects
            .iter()
            .map(|o| {
                let (collider, collider_offset) = o.shape.parry();
                ObjectState {
                    name: o.name.clone(),
                    shape: o.shape,
                    pose: o.pose.isometry(),
                    graspable: o.graspable,
                    collider,
                    collider_offset,
                }
            })
            .collect();
        let hulls = (arms.len() > 1).then(|| ArmHulls::new(&model));
        let step_ns = (params.step_s * 1e9).round() as i64;
        let sim = Self { model, params, scene, objects, step_ns, time_ns: 0, arms, hulls };
        if let Some(c) = sim.arm_clearance()
            && c.distance_m <= 0.0
        {
            let (a, b) = (&sim.arms[c.arms[0]], &sim.arms[c.arms[1]]);
            return Err(SimError::BadValue {
                place: "scene".into(),
                field: format!("arms ({} and {})", a.name, b.name),
                value: format!("{} touches {}", a.frames[c.links[0]], b.frames[c.links[1]]),
                reason: "the arms intersect at their initial joints: move their bases apart or change initial_joints_deg".into(),
            });
        }
        Ok(sim)
    }

    /// Sets the joint velocity command of the first arm ([`Self::set_arm_velocity_command`]).
    pub fn set_velocity_command(&mut self, qd: &[f64]) -> Result<(), CommandError> {
        self.set_arm_velocity_command(0, qd)
    }

    /// Sets the joint velocity command of arm `arm`, rad/s. A rejected command stops that arm
    /// (it is held) and the error says why.
    ///
    /// # Panics
    /// If `arm` is not an arm index.
    pub fn set_arm_velocity_command(&mut self, arm: usize, qd: &[f64]) -> Result<(), CommandError> {
        self.check_joint_vector(arm, qd, "joint velocity command")?;
        let a = &mut self.arms[arm];
        a.command = JointVector::from_column_slice(qd);
        a.command_time_ns = Some(self.time_ns);
        Ok(())
    }

    /// Arm `arm` follows the joint position target `q` (rad) — a person's arm retargeted onto it
    /// during imitation teaching — with joint velocity `follow_gain` × (target − position)
    /// within the speed limits, for `command_timeout_s` after this call (refresh it at the
    /// demonstrator's rate). While a target is fresh it overrides the velocity command and any
    /// external wrench. A target of the wrong length, not finite or outside the joint limits is
    /// refused and the arm held.
    pub fn set_arm_joint_target(&mut self, arm: usize, q: &[f64]) -> Result<(), CommandError> {
        self.check_joint_vector(arm, q, "joint target")?;
        let limits = self.model.joint_limits();
        if let Some((index, value)) = q.iter().copied().enumerate().find(|&(i, v)| v < limits[i].lower || v > limits[i].upper) {
            let (lower, upper) = (limits[index].lower, limits[index].upper);
            self.hold_arm(arm);
            return Err(CommandError::OutsideLimits { index, value, lower, upper });
        }
        let a = &mut self.arms[arm];
        a.target = JointVector::from_column_slice(q);
        a.target_time_ns = Some(self.time_ns);
        Ok(())
    }

    /// One value per joint, all finite; otherwise arm `arm` is held and the error says why.
    fn check_joint_vector(&mut self, arm: usize, v: &[f64], what: &'static str) -> Result<(), CommandError> {
        let bad = if v.len() != DOF {
            Some(CommandError::WrongLength { got: v.len(), expected: DOF })
        } else {
            v.iter().copied().enumerate().find(|(_, x)| !x.is_finite()).map(|(index, value)| CommandError::NotFinite { what, index, value })
        };
        match bad {
            Some(e) => {
                self.hold_arm(arm);
                Err(e)
            }
            None => Ok(()),
        }
    }

    /// Whether arm `arm` is following a joint target now ([`Self::set_arm_joint_target`]).
    pub fn arm_follows_target(&self, arm: usize) -> bool {
        let timeout_ns = (self.params.command_timeout_s * 1e9) as i64;
        self.arms[arm].target_time_ns.is_some_and(|t| self.time_ns - t <= timeout_ns)
    }

    /// Stops the commanded motion of every arm until its next command.
    pub fn hold(&mut self) {
        for arm in 0..self.arms.len() {
            self.hold_arm(arm);
        }
    }

    /// Stops the commanded motion of arm `arm` until its next command.
    pub fn hold_arm(&mut self, arm: usize) {
        let a = &mut self.arms[arm];
        a.command = JointVector::zeros();
        a.command_time_ns = None;
        a.target_time_ns = None;
    }

    /// Applies an external wrench to the first arm ([`Self::set_arm_wrench`]).
    pub fn set_wrench(&mut self, wrench: Wrench, link: Option<&str>) -> Result<(), CommandError> {
        self.set_arm_wrench(0, wrench, link)
    }

    /// Applies an external wrench (the arm's base frame) at the origin of `link` of arm `arm`
    /// (the tool link when `None`; the link's model name, unprefixed).
    pub fn set_arm_wrench(&mut self, arm: usize, wrench: Wrench, link: Option<&str>) -> Result<(), CommandError> {
        self.check_wrench(arm, &wrench)?;
        let link = match link {
            None | Some("") => self.model.tip_link(),
            Some(name) => self
                .model
                .link_index(name)
                .ok_or_else(|| CommandError::UnknownLink { link: name.to_owned() })?,
        };
        self.arms[arm].wrench = Some((wrench, link, self.time_ns));
        Ok(())
    }

    /// [`set_arm_wrench`](Self::set_arm_wrench) at the origin of link index `link` (model
    /// order): no name lookup, nothing allocated.
    pub fn set_arm_wrench_on_link(&mut self, arm: usize, wrench: Wrench, link: usize) -> Result<(), CommandError> {
        self.check_wrench(arm, &wrench)?;
        if link >= self.model.link_count() {
            return Err(CommandError::UnknownLink { link: format!("#{link}") });
        }
        self.arms[arm].wrench = Some((wrench, link, self.time_ns));
        Ok(())
    }

    /// A non-finite wrench is refused and ends the one acting on arm `arm`.
    fn check_wrench(&mut self, arm: usize, wrench: &Wrench) -> Result<(), CommandError> {
        let values = wrench.force.iter().chain(wrench.torque.iter()).copied();
        if let Some((index, value)) = values.enumerate().find(|(_, v)| !v.is_finite()) {
            self.arms[arm].wrench = None;
            return Err(CommandError::NotFinite { what: "wrench", index, value });
        }
        Ok(())
    }

    /// Closes or opens the first arm's gripper ([`Self::command_arm_gripper`]).
    pub fn command_gripper(&mut self, close: bool) -> Option<&str> {
        self.command_arm_gripper(0, close)
    }

    /// Closes or opens the gripper of arm `arm`. Closing grasps the nearest graspable object
    /// no other gripper holds within `grasp_reach_m` of the tool point; returns the name of the
    /// object grasped, if any.
    pub fn command_arm_gripper(&mut self, arm: usize, close: bool) -> Option<&str> {
        if !close {
            if let Some(i) = self.arms[arm].holding() {
                self.release(i);
            }
            self.arms[arm].gripper = GripperState::Open;
            return None;
        }
        if let GripperState::Closed { holding } = self.arms[arm].gripper {
            return holding.map(|i| self.objects[i].name.as_str());
        }
        let tool = self.world_tool_pose(arm);
        let tool_point = Point3::from(tool.translation.vector);
        let nearest = self
            .objects
            .iter()
            .enumerate()
            .filter(|(i, o)| o.graspable && self.holder(*i).is_none())
            .map(|(i, o)| (i, o.distance_to(&tool_point)))
            .filter(|(_, d)| *d <= self.params.grasp_reach_m)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let a = &mut self.arms[arm];
        a.gripper = GripperState::Closed { holding: nearest.map(|(i, _)| i) };
        let i = nearest?.0;
        a.grasp_offset = tool.inverse() * self.objects[i].pose;
        Some(self.objects[i].name.as_str())
    }

    /// The arm whose gripper holds object `object`, if any.
    pub fn holder(&self, object: usize) -> Option<usize> {
        self.arms.iter().position(|a| a.holding() == Some(object))
    }

    /// A person moves object `name` to `pose` (scene frame): picked up, carried, poured, put
    /// down. The simulator does not model the person's grasp; the object is where the person's
    /// hand puts it, with no settling (put it down at its table height). Refused for an unknown
    /// object, an object a gripper holds, or a non-finite pose.
    pub fn place_object(&mut self, name: &str, pose: Isometry3<f64>) -> Result<(), CommandError> {
        let Some(i) = self.objects.iter().position(|o| o.name == name) else {
            return Err(CommandError::UnknownObject { name: name.to_owned() });
        };
        if self.holder(i).is_some() {
            return Err(CommandError::HeldByGripper { name: name.to_owned() });
        }
        let finite = pose.translation.vector.iter().chain(pose.rotation.coords.iter()).all(|v| v.is_finite());
        if !finite || (pose.rotation.coords.norm() - 1.0).abs() > 1e-6 {
            return Err(CommandError::BadPose { name: name.to_owned() });
        }
        self.objects[i].pose = pose;
        Ok(())
    }

    fn release(&mut self, i: usize) {
        if !self.params.drop_released_objects {
            return;
        }
        let top = self.scene.table_top_z();
        let t = self.scene.table.pose.isometry();
        let local = t.inverse() * Point3::from(self.objects[i].pose.translation.vector);
        let half = &self.scene.table.size;
        let over_table = local.x.abs() <= 0.5 * half[0] && local.y.abs() <= 0.5 * half[1];
        if !over_table {
            return;
        }
        // It lands on the highest support below its footprint: the table or the top of
        // another object it overlaps in x-y (blocks stack).
        let this = self.objects[i].aabb();
        let bottom = this.mins.z;
        let support = self
            .objects
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, o)| o.aabb())
            .filter(|b| {
                b.mins.x < this.maxs.x
                    && b.maxs.x > this.mins.x
                    && b.mins.y < this.maxs.y
                    && b.maxs.y > this.mins.y
                    && b.maxs.z <= bottom + SUPPORT_TOLERANCE_M
            })
            .map(|b| b.maxs.z)
            .fold(top, f64::max);
        // Above its support it drops; sunk a little into a block below it, it rests on top.
        let gap = bottom - support;
        if gap > 0.0 || (gap < 0.0 && support > top) {
            self.objects[i].pose.translation.vector.z -= gap;
        }
    }

    /// Advances the simulation by one step (`step_s`). Allocation-free.
    pub fn step(&mut self) {
        for arm in &mut self.arms {
            step_arm(arm, &self.model, &self.params, self.time_ns, self.step_ns);
        }
        self.time_ns += self.step_ns;
        for a in 0..self.arms.len() {
            if let Some(i) = self.arms[a].holding() {
                self.objects[i].pose = self.world_tool_pose(a) * self.arms[a].grasp_offset;
            }
        }
    }

    /// Simulated time since start, ns.
    pub fn time_ns(&self) -> i64 {
        self.time_ns
    }

    /// The arms, scene order (one for a single-arm scene).
    pub fn arms(&self) -> &[Arm] {
        &self.arms
    }

    /// Arm `arm`.
    ///
    /// # Panics
    /// If `arm` is not an arm index.
    pub fn arm(&self, arm: usize) -> &Arm {
        &self.arms[arm]
    }

    /// Index of the arm named `name`.
    pub fn arm_index(&self, name: &str) -> Option<usize> {
        self.arms.iter().position(|a| a.name == name)
    }

    /// Joint positions of the first arm, rad.
    pub fn joint_positions(&self) -> &JointVector {
        &self.arms[0].q
    }

    /// Joint velocities of the first arm applied in the last step, rad/s.
    pub fn joint_velocities(&self) -> &JointVector {
        &self.arms[0].qd
    }

    /// Poses of every link of the first arm, its base frame.
    pub fn link_poses(&self) -> &LinkPoses {
        &self.arms[0].poses
    }

    /// Pose of the first arm's tool (tip) link, its base frame.
    pub fn tool_pose(&self) -> Isometry3<f64> {
        self.arm_tool_pose(0)
    }

    /// Pose of arm `arm`'s tool (tip) link, its base frame.
    pub fn arm_tool_pose(&self, arm: usize) -> Isometry3<f64> {
        *self.arms[arm].poses.get(self.model.tip_link())
    }

    /// Pose of arm `arm`'s tool (tip) link, scene frame.
    pub fn world_tool_pose(&self, arm: usize) -> Isometry3<f64> {
        self.arms[arm].base * self.arm_tool_pose(arm)
    }

    /// The scene's root frame: the first link of the model (the robot base) for a single-arm
    /// scene, [`WORLD_FRAME`] for a scene with named arms.
    pub fn root_frame(&self) -> &str {
        if self.scene.has_named_arms() { WORLD_FRAME } else { &self.arms[0].frames[0] }
    }

    /// The frame tree at the current state, as `robot_state_publisher` + object frames: every
    /// link of every arm in its parent link's frame (serial chain, base first; the base of a
    /// named arm in the root frame), then every object in the root frame. A `parent` of `None`
    /// is [`Self::root_frame`].
    pub fn frame_tree(&self) -> impl Iterator<Item = FrameEdge<'_>> {
        let named = self.scene.has_named_arms();
        let links = self.arms.iter().flat_map(move |arm| {
            let first = if named { 0 } else { 1 };
            (first..arm.poses.len()).map(move |i| FrameEdge {
                parent: (i > 0 && (named || i > 1)).then(|| arm.frames[i - 1].as_str()),
                child: arm.frames[i].as_str(),
                pose: if i == 0 { arm.base * *arm.poses.get(0) } else { arm.poses.get(i - 1).inv_mul(arm.poses.get(i)) },
            })
        });
        let objects = self.objects.iter().map(|o| FrameEdge { parent: None, child: o.name.as_str(), pose: o.pose });
        links.chain(objects)
    }

    /// The closest pair of links of two different arms at the current joints (link meshes'
    /// convex hulls, [`ArmHulls`]), `None` with fewer than two arms.
    pub fn arm_clearance(&self) -> Option<ArmClearance> {
        let hulls = self.hulls.as_ref()?;
        hulls.clearance(self.arms.iter().map(|a| (a.base, &a.poses)))
    }

    /// Scene objects with their current poses.
    pub fn objects(&self) -> &[ObjectState] {
        &self.objects
    }

    /// The first arm's gripper state.
    pub fn gripper(&self) -> GripperState {
        self.arms[0].gripper
    }

    /// Name of the object the first arm holds, if any.
    pub fn held_object(&self) -> Option<&str> {
        self.arm_held_object(0)
    }

    /// Name of the object arm `arm` holds, if any.
    pub fn arm_held_object(&self, arm: usize) -> Option<&str> {
        self.arms[arm].holding().map(|i| self.objects[i].name.as_str())
    }

    /// The robot model (every arm's).
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// The scene as configured.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Simulation parameters.
    pub fn params(&self) -> &SimParams {
        &self.params
    }
}

/// Start joints (rad) from `deg`, checked against the model; `field` names them in errors.
fn initial_joints(model: &RobotModel, deg: &[f64], field: &str) -> Result<JointVector> {
    if deg.len() != DOF {
        return Err(SimError::BadValue {
            place: "scene".into(),
            field: field.to_owned(),
            value: format!("{} values", deg.len()),
            reason: format!("the robot has {DOF} joints"),
        });
    }
    let mut q = JointVector::zeros();
    for (i, d) in deg.iter().enumerate() {
        let rad = d.to_radians();
        let lim = &model.joint_limits()[i];
        if rad < lim.lower || rad > lim.upper {
            return Err(SimError::BadValue {
                place: "scene".into(),
                field: format!("{field}[{i}]"),
                value: d.to_string(),
                reason: format!(
                    "outside the joint limits [{:.1}, {:.1}] deg",
                    lim.lower.to_degrees(),
                    lim.upper.to_degrees()
                ),
            });
        }
        q[i] = rad;
    }
    Ok(q)
}

/// Gap between two boxes, m (0 when they overlap).
fn aabb_gap(a: &parry3d_f64::bounding_volume::Aabb, b: &parry3d_f64::bounding_volume::Aabb) -> f64 {
    if a.intersects(b) {
        return 0.0;
    }
    let d = Vector3::from_fn(|i, _| (a.mins[i] - b.maxs[i]).max(b.mins[i] - a.maxs[i]).max(0.0));
    d.norm()
}

/// One integration step of one arm. Allocation-free.
fn step_arm(arm: &mut Arm, model: &RobotModel, params: &SimParams, time_ns: i64, step_ns: i64) {
    let dt = step_ns as f64 * 1e-9;
    let timeout_ns = (params.command_timeout_s * 1e9) as i64;
    let following = arm.target_time_ns.is_some_and(|t| time_ns - t <= timeout_ns);
    let mut qd = match arm.command_time_ns {
        _ if following => params.follow_gain * (arm.target - arm.q),
        Some(t) if time_ns - t <= timeout_ns => arm.command,
        _ => JointVector::zeros(),
    };
    let wrench_timeout_ns = (params.wrench_timeout_s * 1e9) as i64;
    if let Some((w, link, t)) = arm.wrench {
        if following {
            // The demonstrator moves the arm: a push does not add to it.
        } else if time_ns - t <= wrench_timeout_ns {
            qd += admittance_velocity(arm, model, params, &w, link);
        } else {
            arm.wrench = None;
        }
    }
    // Scale the whole vector so every joint respects its speed limit: the Cartesian
    // direction of the motion is kept, only its speed drops.
    let limits = model.joint_limits();
    let mut worst: f64 = 1.0;
    for i in 0..DOF {
        worst = worst.max(qd[i].abs() / limits[i].velocity);
    }
    qd /= worst;
    for i in 0..DOF {
        let next = (arm.q[i] + qd[i] * dt).clamp(limits[i].lower, limits[i].upper);
        arm.qd[i] = (next - arm.q[i]) / dt;
        arm.q[i] = next;
    }
    model.forward_kinematics(&arm.q, &mut arm.poses);
}

/// Eq. 4.6: `ẋ = c f`, `ω = c_r τ`, mapped to joints through the damped pseudo-inverse
/// `Jᵀ (J Jᵀ + λ² I)⁻¹` of the Jacobian at the contact point (the origin of the contact
/// link, as the thesis assumes contact at the end of the touched link).
fn admittance_velocity(arm: &mut Arm, model: &RobotModel, params: &SimParams, w: &Wrench, link: usize) -> JointVector {
    model.jacobian(&arm.poses, link, &Point3::origin(), &mut arm.jacobian);
    let v = Vector6::new(
        params.admittance_gain * w.force.x,
        params.admittance_gain * w.force.y,
        params.admittance_gain * w.force.z,
        params.admittance_rotational_gain * w.torque.x,
        params.admittance_rotational_gain * w.torque.y,
        params.admittance_rotational_gain * w.torque.z,
    );
    damped_pseudo_inverse(&arm.jacobian, params.admittance_damping) * v
}
