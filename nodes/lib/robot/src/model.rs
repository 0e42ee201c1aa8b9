//! The kinematic model of a 7-DoF serial chain: forward kinematics and geometric Jacobians.
//!
//! All per-call functions work on fixed-size nalgebra types and never allocate.

use crate::error::Result;
use crate::mesh::TriMesh;
use nalgebra::{Isometry3, Point3, SMatrix, SVector, Translation3, Unit, UnitQuaternion, Vector3};
use std::path::{Path, PathBuf};

/// Number of actuated joints of the chains this crate models.
pub const DOF: usize = 7;

/// Most links a chain may have (base, actuated and fixed tool links together).
pub const MAX_LINKS: usize = 16;

/// Joint positions (rad) or velocities (rad/s), base to tip.
pub type JointVector = SVector<f64, DOF>;

/// Geometric Jacobian in the base frame: rows 0..3 map joint rates to the linear velocity of a
/// point (m/s per rad/s), rows 3..6 to the angular velocity of its link (rad/s per rad/s).
pub type Jacobian = SMatrix<f64, 6, DOF>;

/// The linear-velocity rows of a [`Jacobian`] (base frame, m/s per rad/s).
pub type PositionJacobian = SMatrix<f64, 3, DOF>;

/// (Damped) pseudo-inverse of a [`Jacobian`] (7×6).
pub type JacobianPinv = SMatrix<f64, DOF, 6>;

/// (Damped) pseudo-inverse of a [`PositionJacobian`] (7×3).
pub type PositionJacobianPinv = SMatrix<f64, DOF, 3>;

/// A joint-space matrix (7×7), e.g. a null-space projector.
pub type JointMatrix = SMatrix<f64, DOF, DOF>;

/// Limits of one actuated joint. Continuous joints have infinite position limits.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct JointLimit {
    /// Lowest position (rad).
    pub lower: f64,
    /// Highest position (rad).
    pub upper: f64,
    /// Largest speed in either direction (rad/s).
    pub velocity: f64,
}

impl JointLimit {
    /// `true` when `q` (rad) lies within `[lower, upper]`.
    pub fn contains(&self, q: f64) -> bool {
        q >= self.lower && q <= self.upper
    }
}

/// One link of the chain, as the kinematics needs it.
#[derive(Debug, Clone)]
pub(crate) struct ChainLink {
    pub name: String,
    /// Pose of this link's frame in its parent link's frame at zero joint position: the
    /// product of the `<origin>`s of every joint between them (fixed joints folded in).
    pub origin: Isometry3<f64>,
    /// The actuated joint that moves this link relative to its parent, if any.
    pub joint: Option<usize>,
    /// Rotation axis of that joint in this link's frame (unit).
    pub axis: Unit<Vector3<f64>>,
    /// Collision (else visual) geometry in this link's frame.
    pub mesh: Option<TriMesh>,
}

/// One actuated joint of the chain.
#[derive(Debug, Clone)]
pub(crate) struct ChainJoint {
    pub name: String,
    pub limit: JointLimit,
}

/// What the URDF module hands over: a validated serial chain, base first.
#[derive(Debug, Clone)]
pub(crate) struct ChainParts {
    pub name: String,
    pub source: PathBuf,
    pub links: Vec<ChainLink>,
    pub joints: [ChainJoint; DOF],
}

/// Poses of every link of a chain in the base frame, filled by
/// [`RobotModel::forward_kinematics`]. Fixed capacity ([`MAX_LINKS`]); `Copy` and
/// allocation-free.
#[derive(Debug, Clone, Copy)]
pub struct LinkPoses {
    poses: [Isometry3<f64>; MAX_LINKS],
    len: usize,
}

impl Default for LinkPoses {
    fn default() -> Self {
        Self::new()
    }
}

impl LinkPoses {
    /// An empty set (no link yet).
    pub fn new() -> Self {
        Self {
            poses: [Isometry3::identity(); MAX_LINKS],
            len: 0,
        }
    }

    /// Number of links (0 before the first forward kinematics).
    pub fn len(&self) -> usize {
        self.len
    }

    /// `true` before the first forward kinematics.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Pose of link `link` (index as in [`RobotModel::link_names`]) in the base frame.
    ///
    /// # Panics
    /// If `link` is not below [`len`](Self::len).
    pub fn get(&self, link: usize) -> &Isometry3<f64> {
        &self.as_slice()[link]
    }

    /// All poses, base first.
    pub fn as_slice(&self) -> &[Isometry3<f64>] {
        &self.poses[..self.len]
    }
}

/// A 7-DoF serial chain loaded from a URDF: names, limits, link meshes and kinematics.
///
/// Build it once with [`RobotModel::from_urdf_file`]; the kinematic queries are then
/// allocation-free and never fail. Frames: the base frame is the frame of the URDF root link;
/// each link frame is the URDF link frame (the child frame of its joint).
#[derive(Debug, Clone)]
pub struct RobotModel {
    name: String,
    source: PathBuf,
    link_names: Vec<String>,
    links: Vec<ChainLink>,
    joint_names: [String; DOF],
    joint_limits: [JointLimit; DOF],
    /// Index of the link each joint moves (its child link).
    joint_links: [usize; DOF],
}

impl RobotModel {
    /// Loads the serial chain from the URDF root link to its deepest link.
    ///
    /// Mesh files are resolved relative to the URDF's directory (see the crate docs for
    /// `package://` URIs). Fails with an [`Error`](crate::Error) naming the file and the element
    /// at fault.
    pub fn from_urdf_file(path: impl AsRef<Path>) -> Result<Self> {
        crate::urdf::load_file(path.as_ref(), None).map(Self::from_parts)
    }

    /// Like [`from_urdf_file`](Self::from_urdf_file), but the chain ends at link `tip`.
    pub fn from_urdf_file_with_tip(path: impl AsRef<Path>, tip: &str) -> Result<Self> {
        crate::urdf::load_file(path.as_ref(), Some(tip)).map(Self::from_parts)
    }

    /// Loads a URDF given as text; relative mesh paths resolve against `base_dir`. Errors name
    /// the file as `<base_dir>/<inline URDF>`.
    pub fn from_urdf_str(text: &str, base_dir: impl AsRef<Path>) -> Result<Self> {
        crate::urdf::load_str(text, base_dir.as_ref(), None).map(Self::from_parts)
    }

    /// Like [`from_urdf_str`](Self::from_urdf_str), but the chain ends at link `tip`.
    pub fn from_urdf_str_with_tip(
        text: &str,
        base_dir: impl AsRef<Path>,
        tip: &str,
    ) -> Result<Self> {
        crate::urdf::load_str(text, base_dir.as_ref(), Some(tip)).map(Self::from_parts)
    }

    fn from_parts(parts: ChainParts) -> Self {
        // The URDF module guarantees exactly DOF joints, each moving one link, in chain order.
        let mut joint_links = [0; DOF];
        for (i, link) in parts.links.iter().enumerate() {
            if let Some(j) = link.joint {
                joint_links[j] = i;
            }
        }
        RobotModel {
            name: parts.name,
            source: parts.source,
            link_names: parts.links.iter().map(|l| l.name.clone()).collect(),
            joint_limits: parts.joints.each_ref().map(|j| j.limit),
            joint_names: parts.joints.map(|j| j.name),
            joint_links,
            links: parts.links,
        }
    }

    /// The `<robot name>` of the URDF.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The URDF file the model was loaded from.
    pub fn source(&self) -> &Path {
        &self.source
    }

    /// Names of the actuated joints, base to tip.
    pub fn joint_names(&self) -> &[String; DOF] {
        &self.joint_names
    }

    /// Limits of the actuated joints (rad, rad/s), base to tip.
    pub fn joint_limits(&self) -> &[JointLimit; DOF] {
        &self.joint_limits
    }

    /// Index of the joint called `name`.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joint_names.iter().position(|n| n == name)
    }

    /// Names of all links of the chain, base first, including fixed tool links.
    pub fn link_names(&self) -> &[String] {
        &self.link_names
    }

    /// Number of links of the chain.
    pub fn link_count(&self) -> usize {
        self.links.len()
    }

    /// Index of the link called `name`.
    pub fn link_index(&self, name: &str) -> Option<usize> {
        self.link_names.iter().position(|n| n == name)
    }

    /// Index of the tip link (the last link of the chain).
    pub fn tip_link(&self) -> usize {
        self.links.len() - 1
    }

    /// Index of the link that joint `joint` moves (the joint's child link). Links after it up
    /// to the next joint's link move rigidly with it.
    ///
    /// # Panics
    /// If `joint >= DOF`.
    pub fn joint_link(&self, joint: usize) -> usize {
        self.joint_links[joint]
    }

    /// Number of joints that move link `link` (0 for the base; joints `0..n` affect it).
    pub fn joints_moving_link(&self, link: usize) -> usize {
        self.joint_links.iter().take_while(|&&l| l <= link).count()
    }

    /// The mesh of link `link` (collision geometry, else visual) in the link frame, m.
    pub fn link_mesh(&self, link: usize) -> Option<&TriMesh> {
        self.links.get(link).and_then(|l| l.mesh.as_ref())
    }

    /// Total number of mesh vertices over all links of the chain.
    pub fn mesh_vertex_count(&self) -> usize {
        self.links
            .iter()
            .filter_map(|l| l.mesh.as_ref())
            .map(|m| m.vertices.len())
            .sum()
    }

    /// `q` clamped into the joint position limits.
    pub fn clamp_to_limits(&self, q: &JointVector) -> JointVector {
        JointVector::from_fn(|i, _| {
            q[i].clamp(self.joint_limits[i].lower, self.joint_limits[i].upper)
        })
    }

    /// Poses of all links in the base frame at joint positions `q` (rad).
    ///
    /// Cost: one isometry product per link and one axis-angle rotation per joint. A NaN in `q`
    /// propagates into the poses of the links it moves; callers validate commands.
    pub fn forward_kinematics(&self, q: &JointVector, poses: &mut LinkPoses) {
        let mut parent = Isometry3::identity();
        for (i, link) in self.links.iter().enumerate() {
            let mut pose = parent * link.origin;
            if let Some(j) = link.joint {
                pose.rotation *= UnitQuaternion::from_axis_angle(&link.axis, q[j]);
            }
            poses.poses[i] = pose;
            parent = pose;
        }
        poses.len = self.links.len();
    }

    /// Pose of link `link` in the base frame at `q` (rad). Runs the chain up to that link.
    ///
    /// # Panics
    /// If `link >= link_count()`.
    pub fn link_pose(&self, q: &JointVector, link: usize) -> Isometry3<f64> {
        let mut pose = Isometry3::identity();
        for l in &self.links[..=link] {
            pose *= l.origin;
            if let Some(j) = l.joint {
                pose.rotation *= UnitQuaternion::from_axis_angle(&l.axis, q[j]);
            }
        }
        pose
    }

    /// Geometric Jacobian (base frame) of the point `point_in_link` (m, link frame) rigidly
    /// attached to link `link`, from poses computed by [`forward_kinematics`](Self::forward_kinematics).
    ///
    /// Column `j` is `[z_j × (p − o_j); z_j]` for the joints that move the link (z_j the joint
    /// axis and o_j the joint origin in the base frame, p the point); columns of joints after
    /// the link are zero.
    ///
    /// # Panics
    /// If `link` is not a link of `poses`.
    pub fn jacobian(
        &self,
        poses: &LinkPoses,
        link: usize,
        point_in_link: &Point3<f64>,
        jac: &mut Jacobian,
    ) {
        jac.fill(0.0);
        self.for_each_joint_column(poses, link, point_in_link, |j, v, z| {
            jac.fixed_view_mut::<3, 1>(0, j).copy_from(&v);
            jac.fixed_view_mut::<3, 1>(3, j).copy_from(&z);
        });
    }

    /// The linear-velocity rows of [`jacobian`](Self::jacobian): the 3×7 position Jacobian of a
    /// point on a link (base frame), as link-point avoidance tasks need.
    ///
    /// # Panics
    /// If `link` is not a link of `poses`.
    pub fn position_jacobian(
        &self,
        poses: &LinkPoses,
        link: usize,
        point_in_link: &Point3<f64>,
        jac: &mut PositionJacobian,
    ) {
        jac.fill(0.0);
        self.for_each_joint_column(poses, link, point_in_link, |j, v, _z| jac.set_column(j, &v));
    }

    /// Calls `column(j, z_j × (p − o_j), z_j)` for every joint `j` that moves `link` (base frame).
    fn for_each_joint_column(
        &self,
        poses: &LinkPoses,
        link: usize,
        point_in_link: &Point3<f64>,
        mut column: impl FnMut(usize, Vector3<f64>, Vector3<f64>),
    ) {
        let p = poses.get(link) * point_in_link;
        for (j, &l) in self.joint_links.iter().enumerate() {
            if l > link {
                break;
            }
            let frame = &poses.poses[l];
            let z = frame.rotation * self.links[l].axis.into_inner();
            column(j, z.cross(&(p.coords - frame.translation.vector)), z);
        }
    }
}

/// Isometry from a URDF `<origin xyz rpy>` (m, rad; rpy = fixed-axis roll about x, then pitch
/// about y, then yaw about z).
pub(crate) fn origin_to_isometry(xyz: [f64; 3], rpy: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}
