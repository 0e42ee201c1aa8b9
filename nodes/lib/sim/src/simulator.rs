//! The simulation state and its fixed-step integration.

use cowork_robot::{
    DOF, Jacobian, JointVector, LinkPoses, RobotModel, damped_pseudo_inverse,
};
use nalgebra::{Isometry3, Point3, Vector3, Vector6};
use parry3d_f64::shape::Shape as ParryShape;

use crate::error::{CommandError, Result, SimError};
use crate::params::SimParams;
use crate::scene::{Scene, Shape};


/// One edge of the frame tree ([`Simulator::frame_tree`]): `child`'s pose in `parent`'s frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameEdge<'a> {
    /// Parent frame (a link name); `None` for the robot base frame.
    pub parent: Option<&'a str>,
    /// Child frame: a link or an object name.
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

/// State of the gripper.
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
    /// Pose of the shape centre, base frame.
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
    /// Distance from a point (base frame) to the object's surface, m; 0 inside.
    pub fn distance_to(&self, point: &Point3<f64>) -> f64 {
        self.collider
            .distance_to_point(&(self.pose * self.collider_offset), point, true)
    }

    /// Axis-aligned bounding box of the object, base frame.
    fn aabb(&self) -> parry3d_f64::bounding_volume::Aabb {
        self.collider.compute_aabb(&(self.pose * self.collider_offset))
    }
}

/// Kinematic simulator. See the crate documentation.
#[derive(Debug)]
pub struct Simulator {
    model: RobotModel,
    params: SimParams,
    scene: Scene,
    objects: Vec<ObjectState>,
    step_ns: i64,
    time_ns: i64,
    q: JointVector,
    /// Joint velocity applied in the last step, rad/s.
    qd: JointVector,
    command: JointVector,
    command_time_ns: Option<i64>,
    wrench: Option<(Wrench, usize, i64)>,
    gripper: GripperState,
    /// Pose of the held object in the tool frame.
    grasp_offset: Isometry3<f64>,
    poses: LinkPoses,
    jacobian: Jacobian,
}

impl Simulator {
    /// Builds a simulator; the scene's initial joints must match the model's joints and limits.
    pub fn new(model: RobotModel, scene: Scene, params: SimParams) -> Result<Self> {
        params.validate("simulator parameters")?;
        scene.validate("scene")?;
        if scene.robot.initial_joints_deg.len() != DOF {
            return Err(SimError::BadValue {
                place: "scene".into(),
                field: "robot.initial_joints_deg".into(),
                value: format!("{} values", scene.robot.initial_joints_deg.len()),
                reason: format!("the robot has {DOF} joints"),
            });
        }
        let mut q = JointVector::zeros();
        for (i, deg) in scene.robot.initial_joints_deg.iter().enumerate() {
            let rad = deg.to_radians();
            let lim = &model.joint_limits()[i];
            if rad < lim.lower || rad > lim.upper {
                return Err(SimError::BadValue {
                    place: "scene".into(),
                    field: format!("robot.initial_joints_deg[{i}]"),
                    value: deg.to_string(),
                    reason: format!(
                        "outside the joint limits [{:.1}, {:.1}] deg",
                        lim.lower.to_degrees(),
                        lim.upper.to_degrees()
                    ),
                });
            }
            q[i] = rad;
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
        let step_ns = (params.step_s * 1e9).round() as i64;
        let mut sim = Self {
            model,
            params,
            scene,
            objects,
            step_ns,
            time_ns: 0,
            q,
            qd: JointVector::zeros(),
            command: JointVector::zeros(),
            command_time_ns: None,
            wrench: None,
            gripper: GripperState::Open,
            grasp_offset: Isometry3::identity(),
            poses: LinkPoses::default(),
            jacobian: Jacobian::zeros(),
        };
        sim.model.forward_kinematics(&sim.q, &mut sim.poses);
        Ok(sim)
    }

    /// Sets the joint velocity command, rad/s. A rejected command stops the robot (it is held)
    /// and the error says why.
    pub fn set_velocity_command(&mut self, qd: &[f64]) -> Result<(), CommandError> {
        if qd.len() != DOF {
            self.hold();
            return Err(CommandError::WrongLength { got: qd.len(), expected: DOF });
        }
        if let Some((index, value)) = qd.iter().copied().enumerate().find(|(_, v)| !v.is_finite()) {
            self.hold();
            return Err(CommandError::NotFinite { what: "joint velocity command", index, value });
        }
        self.command = JointVector::from_column_slice(qd);
        self.command_time_ns = Some(self.time_ns);
        Ok(())
    }

    /// Stops commanded motion until the next command.
    pub fn hold(&mut self) {
        self.command = JointVector::zeros();
        self.command_time_ns = None;
    }

    /// Applies an external wrench at the origin of `link` (the tool link when `None`).
    pub fn set_wrench(&mut self, wrench: Wrench, link: Option<&str>) -> Result<(), CommandError> {
        let values = wrench.force.iter().chain(wrench.torque.iter()).copied();
        if let Some((index, value)) = values.enumerate().find(|(_, v)| !v.is_finite()) {
            self.wrench = None;
            return Err(CommandError::NotFinite { what: "wrench", index, value });
        }
        let link = match link {
            None | Some("") => self.model.tip_link(),
            Some(name) => self
                .model
                .link_index(name)
                .ok_or_else(|| CommandError::UnknownLink { link: name.to_owned() })?,
        };
        self.wrench = Some((wrench, link, self.time_ns));
        Ok(())
    }

    /// Closes or opens the gripper. Closing grasps the nearest graspable object within
    /// `grasp_reach_m` of the tool point; returns the name of the object grasped, if any.
    pub fn command_gripper(&mut self, close: bool) -> Option<&str> {
        if !close {
            if let GripperState::Closed { holding: Some(i) } = self.gripper {
                self.release(i);
            }
            self.gripper = GripperState::Open;
            return None;
        }
        if let GripperState::Closed { holding } = self.gripper {
            return holding.map(|i| self.objects[i].name.as_str());
        }
        let tool = self.tool_pose();
        let tool_point = Point3::from(tool.translation.vector);
        let nearest = self
            .objects
            .iter()
            .enumerate()
            .filter(|(_, o)| o.graspable)
            .map(|(i, o)| (i, o.distance_to(&tool_point)))
            .filter(|(_, d)| *d <= self.params.grasp_reach_m)
            .min_by(|a, b| a.1.total_cmp(&b.1));
        self.gripper = GripperState::Closed { holding: nearest.map(|(i, _)| i) };
        let i = nearest?.0;
        self.grasp_offset = tool.inverse() * self.objects[i].pose;
        Some(self.objects[i].name.as_str())
    }

    /// A person moves object `name` to `pose` (base frame): picked up, carried, poured, put
    /// down. The simulator does not model the person's grasp; the object is where the person's
    /// hand puts it, with no settling (put it down at its table height). Refused for an unknown
    /// object, the object the gripper holds, or a non-finite pose.
    pub fn place_object(&mut self, name: &str, pose: Isometry3<f64>) -> Result<(), CommandError> {
        let Some(i) = self.objects.iter().position(|o| o.name == name) else {
            return Err(CommandError::UnknownObject { name: name.to_owned() });
        };
        if self.gripper == (GripperState::Closed { holding: Some(i) }) {
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
        let dt = self.step_ns as f64 * 1e-9;
        let timeout_ns = (self.params.command_timeout_s * 1e9) as i64;
        let mut qd = match self.command_time_ns {
            Some(t) if self.time_ns - t <= timeout_ns => self.command,
            _ => JointVector::zeros(),
        };
        let wrench_timeout_ns = (self.params.wrench_timeout_s * 1e9) as i64;
        if let Some((w, link, t)) = self.wrench {
            if self.time_ns - t <= wrench_timeout_ns {
                qd += self.admittance_velocity(&w, link);
            } else {
                self.wrench = None;
            }
        }
        // Scale the whole vector so every joint respects its speed limit: the Cartesian
        // direction of the motion is kept, only its speed drops.
        let limits = self.model.joint_limits();
        let mut worst: f64 = 1.0;
        for i in 0..DOF {
            worst = worst.max(qd[i].abs() / limits[i].velocity);
        }
        qd /= worst;
        for i in 0..DOF {
            let next = (self.q[i] + qd[i] * dt).clamp(limits[i].lower, limits[i].upper);
            self.qd[i] = (next - self.q[i]) / dt;
            self.q[i] = next;
        }
        self.time_ns += self.step_ns;
        self.model.forward_kinematics(&self.q, &mut self.poses);
        if let GripperState::Closed { holding: Some(i) } = self.gripper {
            self.objects[i].pose = self.tool_pose() * self.grasp_offset;
        }
    }

    /// Eq. 4.6: `ẋ = c f`, `ω = c_r τ`, mapped to joints through the damped pseudo-inverse
    /// `Jᵀ (J Jᵀ + λ² I)⁻¹` of the Jacobian at the contact point (the origin of the contact
    /// link, as the thesis assumes contact at the end of the touched link).
    fn admittance_velocity(&mut self, w: &Wrench, link: usize) -> JointVector {
        self.model
            .jacobian(&self.poses, link, &Point3::origin(), &mut self.jacobian);
        let v = Vector6::new(
            self.params.admittance_gain * w.force.x,
            self.params.admittance_gain * w.force.y,
            self.params.admittance_gain * w.force.z,
            self.params.admittance_rotational_gain * w.torque.x,
            self.params.admittance_rotational_gain * w.torque.y,
            self.params.admittance_rotational_gain * w.torque.z,
        );
        damped_pseudo_inverse(&self.jacobian, self.params.admittance_damping) * v
    }

    /// Simulated time since start, ns.
    pub fn time_ns(&self) -> i64 {
        self.time_ns
    }

    /// Joint positions, rad.
    pub fn joint_positions(&self) -> &JointVector {
        &self.q
    }

    /// Joint velocities applied in the last step, rad/s.
    pub fn joint_velocities(&self) -> &JointVector {
        &self.qd
    }

    /// Poses of every link of the model, base frame.
    pub fn link_poses(&self) -> &LinkPoses {
        &self.poses
    }

    /// Pose of the tool (tip) link, base frame.
    pub fn tool_pose(&self) -> Isometry3<f64> {
        *self.poses.get(self.model.tip_link())
    }

    /// The frame tree at the current state, as `robot_state_publisher` + object frames: every
    /// link but the base in its parent link's frame (serial chain, base first), then every
    /// object in the base frame. A `parent` of `None` is the base frame.
    pub fn frame_tree(&self) -> impl Iterator<Item = FrameEdge<'_>> {
        let names = self.model.link_names();
        let links = (1..self.poses.len()).map(move |i| FrameEdge {
            parent: (i > 1).then(|| names[i - 1].as_str()),
            child: names[i].as_str(),
            pose: self.poses.get(i - 1).inv_mul(self.poses.get(i)),
        });
        let objects = self.objects.iter().map(|o| FrameEdge { parent: None, child: o.name.as_str(), pose: o.pose });
        links.chain(objects)
    }

    /// Scene objects with their current poses.
    pub fn objects(&self) -> &[ObjectState] {
        &self.objects
    }

    /// Gripper state.
    pub fn gripper(&self) -> GripperState {
        self.gripper
    }

    /// Name of the held object, if any.
    pub fn held_object(&self) -> Option<&str> {
        match self.gripper {
            GripperState::Closed { holding: Some(i) } => Some(&self.objects[i].name),
            _ => None,
        }
    }

    /// The robot model.
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
