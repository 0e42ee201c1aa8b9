//! The 1 kHz DS controller: ẋ = α_h M(x) f(x − g) (+ moving obstacles, escape), multi-priority
//! IK with null-space link avoidance, saturation, and the stale-input watchdog.

use crate::error::{Error, Fault, Result, Stream};
use crate::goal::{Reach, adapted_velocity};
use crate::ik::{Ik, IkConfig, IkReport, LinkTask, PointTask, Saturation, Twist, limit_avoidance, orientation_error, saturate};
use crate::modulation::{
    EPSILON, Escape, EscapeConfig, influence_weight, modulate, orthonormal_basis,
    weighted_eigenvalues, weighted_modulation_matrix_in_basis,
};
use crate::primitive::{JointMove, LearnedField, Primitive};
use crate::safety::{LinkSafety, SafetyConfig, SafetyReport};
use crate::scaling::{HumanState, ScalingConfig};
use crate::ttc::{Contact, Ttc, TtcConfig, TtcReport, contact_point_at_link_end};
use cowork_robot::{DOF, JointVector, LinkPoses, MAX_LINKS, RobotModel};
use nalgebra::{Point3, Unit, UnitQuaternion, Vector3};

/// Parameters of DS modulation (eq. 5.6).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModulationConfig {
    /// ε of eq. 5.6, in (0, 1).
    pub epsilon: f64,
    /// Up to this obstacle distance eq. 5.6 applies unchanged (m).
    pub full_distance: f64,
    /// Beyond this distance an obstacle is ignored; in between M fades to I smoothly (m, must
    /// exceed `full_distance`; `.inf` keeps eq. 5.6 at every distance, as the thesis states
    /// it). See [`influence_weight`](crate::modulation::influence_weight).
    pub influence_distance: f64,
    /// Modulate the end-effector DS with its closest obstacle.
    pub end_effector: bool,
    /// Null-space avoidance of the closest non end-effector link point.
    pub links: bool,
}

impl Default for ModulationConfig {
    fn default() -> Self {
        Self {
            epsilon: EPSILON,
            full_distance: 0.5,
            influence_distance: 1.0,
            end_effector: true,
            links: true,
        }
    }
}

/// Configuration of [`DsController`]; defaults are the thesis values (Sec. 5.1.1, 5.1.3).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ControllerConfig {
    /// Control period dt (s): 1 ms (1 kHz).
    pub period_s: f64,
    /// Distance or human data older than this slow the motion: α_h is scaled by
    /// `(stale_after_s − age)/(stale_after_s − slow_after_s)`, reaching 0 at `stale_after_s`
    /// (s, in (0, `stale_after_s`]; equal: no slow zone). Ages come from the data's stamps.
    pub slow_after_s: f64,
    /// Distance or human data older than this stop the robot (s): brake and hold.
    pub stale_after_s: f64,
    /// Data stamped more than this in the controller's future stop the robot too (s): the
    /// clock went back, or the sender's clock is not the controller's.
    pub future_tolerance_s: f64,
    /// Joint deceleration while braking to a hold (rad/s²), > 0.
    pub brake_deceleration: f64,
    /// After a hold, the Cartesian command ramps from 0 to full over this time (s), ≥ 0.
    pub resume_time_s: f64,
    /// The motion counts as converged within this end-effector distance of the goal (m).
    pub goal_tolerance_m: f64,
    /// … and, for a driven orientation, within this angle of it (rad).
    pub orientation_tolerance_rad: f64,
    /// Reject goals beyond the arm's reach bound.
    pub check_reach: bool,
    /// Velocity scaling speeds (eq. 5.3).
    pub scaling: ScalingConfig,
    /// DS modulation (eq. 5.6).
    pub modulation: ModulationConfig,
    /// Escape from spurious attractors (Algorithm 5).
    pub escape: EscapeConfig,
    /// IK and saturation.
    pub ik: IkConfig,
    /// Link-distance damper above the end-effector task (ours; see [`crate::safety`]).
    pub safety: SafetyConfig,
    /// Task transition control of a person's push (thesis Sec. 4.1.2; see [`crate::ttc`]),
    /// off by default.
    pub ttc: TtcConfig,
}

impl Default for ControllerConfig {
    fn default() -> Self {
        Self {
            period_s: 0.001,
            slow_after_s: 0.1,
            stale_after_s: 0.3,
            future_tolerance_s: 0.02,
            brake_deceleration: 10.0,
            resume_time_s: 0.2,
            goal_tolerance_m: 0.005,
            orientation_tolerance_rad: 0.02,
            check_reach: true,
            scaling: ScalingConfig::default(),
            modulation: ModulationConfig::default(),
            escape: EscapeConfig::default(),
            ik: IkConfig::default(),
            safety: SafetyConfig::default(),
            ttc: TtcConfig::default(),
        }
    }
}

fn check(field: &'static str, value: f64, ok: bool, reason: &'static str) -> Result<()> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(Error::Config {
            field,
            value,
            reason,
        })
    }
}

impl ControllerConfig {
    /// Rejects NaN, infinite and out-of-range values, naming the field.
    pub fn validate(&self) -> Result<()> {
        let c = self;
        check(
            "period_s",
            c.period_s,
            c.period_s > 0.0 && c.period_s <= 0.1,
            "must be in (0, 0.1] s",
        )?;
        check(
            "stale_after_s",
            c.stale_after_s,
            c.stale_after_s > 0.0,
            "must be > 0 s",
        )?;
        check(
            "slow_after_s",
            c.slow_after_s,
            c.slow_after_s > 0.0 && c.slow_after_s <= c.stale_after_s,
            "must be in (0, stale_after_s] s",
        )?;
        check(
            "future_tolerance_s",
            c.future_tolerance_s,
            c.future_tolerance_s >= 0.0 && c.future_tolerance_s <= c.stale_after_s,
            "must be in [0, stale_after_s] s",
        )?;
        check(
            "brake_deceleration",
            c.brake_deceleration,
            c.brake_deceleration > 0.0,
            "must be > 0 rad/s²",
        )?;
        check(
            "resume_time_s",
            c.resume_time_s,
            c.resume_time_s >= 0.0,
            "must be ≥ 0 s",
        )?;
        check(
            "goal_tolerance_m",
            c.goal_tolerance_m,
            c.goal_tolerance_m > 0.0,
            "must be > 0 m",
        )?;
        check(
            "orientation_tolerance_rad",
            c.orientation_tolerance_rad,
            c.orientation_tolerance_rad > 0.0,
            "must be > 0 rad",
        )?;
        let s = &c.scaling;
        check(
            "scaling.far_speed",
            s.far_speed,
            s.far_speed > 0.0,
            "must be > 0 m/s",
        )?;
        check(
            "scaling.interaction_speed",
            s.interaction_speed,
            s.interaction_speed > 0.0 && s.interaction_speed <= s.far_speed,
            "must be in (0, far_speed] m/s",
        )?;
        let e = c.modulation.epsilon;
        check(
            "modulation.epsilon",
            e,
            e > 0.0 && e < 1.0,
            "must be in (0, 1)",
        )?;
        // NaN here used to pass and silently switch avoidance off.
        let m = &c.modulation;
        check(
            "modulation.full_distance",
            m.full_distance,
            m.full_distance >= 0.0,
            "must be ≥ 0 m",
        )?;
        if m.influence_distance.partial_cmp(&m.full_distance) != Some(std::cmp::Ordering::Greater) {
            return Err(Error::Config {
                field: "modulation.influence_distance",
                value: m.influence_distance,
                reason: "must exceed modulation.full_distance (m; .inf for no fading)",
            });
        }
        let x = &c.escape;
        check(
            "escape.speed_threshold",
            x.speed_threshold,
            x.speed_threshold > 0.0,
            "must be > 0 m/s",
        )?;
        check(
            "escape.contact_distance",
            x.contact_distance,
            x.contact_distance >= 0.0,
            "must be ≥ 0 m",
        )?;
        check(
            "escape.perturbation_speed",
            x.perturbation_speed,
            x.perturbation_speed > 0.0,
            "must be > 0 m/s",
        )?;
        let k = &c.ik;
        check("ik.damping", k.damping, k.damping >= 0.0, "must be ≥ 0")?;
        check(
            "ik.link_damping",
            k.link_damping,
            k.link_damping >= 0.0,
            "must be ≥ 0",
        )?;
        check(
            "ik.orientation_gain",
            k.orientation_gain,
            k.orientation_gain >= 0.0,
            "must be ≥ 0 1/s",
        )?;
        check(
            "ik.max_angular_speed",
            k.max_angular_speed,
            k.max_angular_speed > 0.0,
            "must be > 0 rad/s",
        )?;
        check(
            "ik.velocity_limit_fraction",
            k.velocity_limit_fraction,
            k.velocity_limit_fraction > 0.0 && k.velocity_limit_fraction <= 1.0,
            "must be in (0, 1]",
        )?;
        check(
            "ik.posture_gain",
            k.posture_gain,
            k.posture_gain >= 0.0,
            "must be ≥ 0 1/s",
        )?;
        if let Some(r) = &k.posture_reference {
            const FIELDS: [&str; DOF] = [
                "ik.posture_reference[0]",
                "ik.posture_reference[1]",
                "ik.posture_reference[2]",
                "ik.posture_reference[3]",
                "ik.posture_reference[4]",
                "ik.posture_reference[5]",
                "ik.posture_reference[6]",
            ];
            for (field, v) in FIELDS.iter().zip(r) {
                if let Some(v) = v {
                    check(field, *v, v.abs() <= 2.0 * std::f64::consts::PI, "must be an angle within ±2π rad or null")?;
                }
            }
        }
        check(
            "ik.posture_max_speed",
            k.posture_max_speed,
            k.posture_max_speed > 0.0,
            "must be > 0 rad/s",
        )?;
        check("ik.limit_zone", k.limit_zone, (0.0..=1.0).contains(&k.limit_zone), "must be in [0, 1] rad")?;
        check("ik.limit_gain", k.limit_gain, (0.0..=100.0).contains(&k.limit_gain), "must be in [0, 100] 1/s")?;
        check(
            "ik.position_margin",
            k.position_margin,
            k.position_margin >= 0.0,
            "must be ≥ 0 rad",
        )?;
        let f = &c.safety;
        check(
            "safety.stop_distance",
            f.stop_distance,
            f.stop_distance > 0.0,
            "must be > 0 m",
        )?;
        check(
            "safety.slow_distance",
            f.slow_distance,
            f.slow_distance > f.stop_distance,
            "must exceed safety.stop_distance (m)",
        )?;
        check(
            "safety.approach_speed",
            f.approach_speed,
            f.approach_speed > 0.0,
            "must be > 0 m/s",
        )?;
        check(
            "safety.retreat_gain",
            f.retreat_gain,
            f.retreat_gain >= 0.0,
            "must be ≥ 0 1/s",
        )?;
        check(
            "safety.max_obstacle_speed",
            f.max_obstacle_speed,
            f.max_obstacle_speed >= 0.0,
            "must be ≥ 0 m/s",
        )?;
        check(
            "safety.scene_stop_distance",
            f.scene_stop_distance,
            f.scene_stop_distance > 0.0 && f.scene_stop_distance <= f.stop_distance,
            "must be > 0 m and ≤ safety.stop_distance",
        )?;
        check(
            "safety.scene_slow_distance",
            f.scene_slow_distance,
            f.scene_slow_distance > f.scene_stop_distance && f.scene_slow_distance <= f.slow_distance,
            "must exceed safety.scene_stop_distance and be ≤ safety.slow_distance (m)",
        )?;
        check("safety.damping", f.damping, f.damping >= 0.0, "must be ≥ 0")?;
        c.ttc.validate()?;
        check(
            "safety.hand_radius",
            f.hand_radius,
            f.hand_radius >= 0.0,
            "must be ≥ 0 m",
        )?;
        check(
            "safety.null_space_max_speed",
            f.null_space_max_speed,
            f.null_space_max_speed > 0.0,
            "must be > 0 rad/s",
        )?;
        check(
            "safety.iterations",
            f64::from(f.iterations),
            (1..=20).contains(&f.iterations),
            "must be in 1..=20",
        )?;
        Ok(())
    }
}

/// Closest obstacle to one robot link (a `cowork_msgs/LinkDistance`), base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkDistance {
    /// An obstacle was found for this link; otherwise the other fields are ignored.
    pub valid: bool,
    /// Link–obstacle distance (m); ≤ 0 counts as contact.
    pub distance: f64,
    /// Closest point on the link (m).
    pub robot_point: Point3<f64>,
    /// Closest obstacle point (m).
    pub obstacle_point: Point3<f64>,
    /// Obstacle surface normal at `obstacle_point`, pointing away from the obstacle (need not
    /// be unit, must be non-zero).
    pub normal: Vector3<f64>,
    /// Velocity of the obstacle point (m/s).
    pub obstacle_velocity: Vector3<f64>,
}

impl LinkDistance {
    /// No obstacle.
    pub const NONE: Self = Self {
        valid: false,
        distance: f64::INFINITY,
        robot_point: Point3::new(0.0, 0.0, 0.0),
        obstacle_point: Point3::new(0.0, 0.0, 0.0),
        normal: Vector3::new(0.0, 0.0, 1.0),
        obstacle_velocity: Vector3::new(0.0, 0.0, 0.0),
    };
}

/// Per-link distances of one fDED frame; entry `i` is link `i` of the model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Distances {
    /// Time the distances were measured (s, same clock as [`ControlInput::time`]).
    pub stamp: f64,
    /// Number of meaningful entries in `links`.
    pub count: usize,
    /// Entries by link index.
    pub links: [LinkDistance; MAX_LINKS],
    /// `scene_object[i]`: link `i`'s closest obstacle point lies on a known object of the
    /// task's scene (inside its shape at the pose the world reports, grown by a margin), not on
    /// an unknown obstacle such as a person. The link damper keeps such links at its shorter
    /// scene distances ([`crate::safety::SafetyConfig::scene_stop_distance`]); the modulation
    /// and the null-space avoidance treat every obstacle alike. False when not known (fail
    /// closed: the full damper distances).
    pub scene_object: [bool; MAX_LINKS],
    /// `floor[i]`: link `i`'s obstacle is the surface the task stands on (the table top, a
    /// known scene object): the link damper holds even the hand off it — no `hand_radius`
    /// exemption ([`crate::safety::SafetyConfig::hand_radius`]).
    pub floor: [bool; MAX_LINKS],
}

impl Distances {
    /// No data yet (stamp −∞: stale until the first message).
    pub const NEVER: Self = Self {
        stamp: f64::NEG_INFINITY,
        count: 0,
        links: [LinkDistance::NONE; MAX_LINKS],
        scene_object: [false; MAX_LINKS],
        floor: [false; MAX_LINKS],
    };

    /// A fresh set with no obstacle near any link.
    pub fn clear(stamp: f64) -> Self {
        Self {
            stamp,
            ..Self::NEVER
        }
    }
}

/// Latest `/human/state` with its time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HumanInput {
    /// Time of the state (s).
    pub stamp: f64,
    /// The state.
    pub state: HumanState,
}

/// A person's push on the arm as the robot reports it (`lwr_sim`'s `/lwr/external_wrench` in
/// execute mode): the force f_e and the link it acts on. Task transition control takes the
/// contact at the end of that link (thesis Sec. 4.1.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExternalWrench {
    /// Time the wrench was measured (s, same clock as [`ControlInput::time`]).
    pub stamp: f64,
    /// The contact link (model index).
    pub link: usize,
    /// Force f_e (N, base frame).
    pub force: Vector3<f64>,
}

/// Why [`DsController::step_with_contact`] did not use a given wrench (the robot runs on as
/// without a touch).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WrenchIgnored {
    /// `ttc.enabled` is false.
    Disabled,
    /// Older than `ttc.max_wrench_age_s`, or stamped more than that in the future (s): the
    /// touch is over (or the clock went back).
    Stale {
        /// Age (s).
        age_s: f64,
    },
    /// A NaN or infinite force or stamp.
    NonFinite,
    /// ‖f_e‖ above `ttc.max_force` (N): not a person's guidance.
    TooLarge {
        /// ‖f_e‖ (N).
        force_n: f64,
    },
    /// The link index is not a link of the model.
    UnknownLink {
        /// The index given.
        link: usize,
    },
}

impl std::fmt::Display for WrenchIgnored {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Disabled => write!(f, "task transition control is disabled (ttc.enabled: false)"),
            Self::Stale { age_s } => write!(f, "stale: age {age_s:.3} s"),
            Self::NonFinite => write!(f, "non-finite force or stamp"),
            Self::TooLarge { force_n } => write!(f, "force {force_n:.1} N exceeds ttc.max_force"),
            Self::UnknownLink { link } => write!(f, "unknown contact link index {link}"),
        }
    }
}

/// What task transition control did in one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactReport {
    /// Barycentric weights (w₁, w₂, w₃) of T_ee, [T_ee, T_ic], [T_ic, T_ee]; (1, 0, 0) with
    /// TTC off or idle.
    pub weights: [f64; 3],
    /// The contact link used this step.
    pub link: Option<usize>,
    /// ‖f_e‖ used (N); 0 without a contact.
    pub force_n: f64,
    /// A wrench was given but not used, and why.
    pub ignored: Option<WrenchIgnored>,
    /// The TTC step's own figures (zero when it did not run).
    pub ttc: TtcReport,
}

impl Default for ContactReport {
    fn default() -> Self {
        Self { weights: [1.0, 0.0, 0.0], link: None, force_n: 0.0, ignored: None, ttc: TtcReport::default() }
    }
}

/// The motion to run (a `cowork_msgs/MotionCommand`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionCommand {
    /// Command id; a new id restarts the command (orientation to hold captured afresh).
    pub id: u32,
    /// The DS f.
    pub primitive: Primitive,
    /// Goal position g (m, base frame).
    pub goal: Vector3<f64>,
    /// `None`: hold the end-effector orientation of the command's first step; `Some`: drive it
    /// to this orientation (base frame).
    pub orientation: Option<UnitQuaternion<f64>>,
    /// Modulate the end-effector DS (disabled e.g. for a handover, Sec. 5.1.3; null-space link
    /// avoidance stays on).
    pub end_effector_avoidance: bool,
}

/// Everything one step reads. `Copy`: the ROS side hands it over through a mailbox.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlInput {
    /// Current time (s).
    pub time: f64,
    /// Measured joint positions (rad).
    pub q: JointVector,
    /// The motion to run.
    pub command: MotionCommand,
    /// Latest robot–obstacle distances.
    pub distances: Distances,
    /// Latest human state.
    pub human: HumanInput,
}

/// Why the robot is held.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HoldReason {
    /// A fault (stale or bad input).
    Fault(Fault),
    /// The command is [`Primitive::Hold`].
    Command,
    /// α_h = 0 (the person said stop).
    SpeedZero,
}

/// Progress of the motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Status {
    /// Moving towards the goal.
    Running,
    /// Within tolerance of the goal (the DS keeps regulating).
    Converged,
    /// Held (braking or at rest).
    Held(HoldReason),
}

/// Figures of one step, for logs and tests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Diagnostics {
    /// End-effector position (m, base frame).
    pub ee_position: Vector3<f64>,
    /// ‖x − g‖ (m).
    pub goal_error_m: f64,
    /// Orientation error (rad) to the held or driven orientation.
    pub orientation_error_rad: f64,
    /// α_h of eq. 5.3 (times the resume ramp).
    pub alpha: f64,
    /// Speed the primitive asked for before the nominal-speed limit and α_h (m/s).
    pub nominal_speed_m_s: f64,
    /// Distance of the end-effector's closest obstacle (m); ∞ when none.
    pub ee_distance_m: f64,
    /// Normal eigenvalue λ₁ used for the end effector (1 when unmodulated).
    pub ee_lambda_normal: f64,
    /// Link of the null-space task, if any.
    pub avoid_link: Option<usize>,
    /// Its distance (m); ∞ when none.
    pub link_distance_m: f64,
    /// Desired end-effector velocity after modulation and escape (m/s).
    pub ee_velocity: Vector3<f64>,
    /// Algorithm 5 is perturbing.
    pub escaping: bool,
    /// Saturations applied.
    pub saturation: Saturation,
    /// Link-task velocities.
    pub ik: IkReport,
    /// Factor (0, 1] of α_h from the age of the distance / human data (watchdog slow zone).
    pub age_scale: f64,
    /// What the link-distance damper did.
    pub safety: SafetyReport,
    /// Task transition control (a person's push).
    pub contact: ContactReport,
    /// Factor (0, 1] the whole q̇ was scaled by so the tool's actual speed ‖J_p q̇‖ keeps the
    /// allowed speed (1: not needed). The IK's lower-priority tasks move the tool through
    /// released joints and the damped projector's leak.
    pub tool_speed_scale: f64,
}

impl Default for Diagnostics {
    fn default() -> Self {
        Self {
            ee_position: Vector3::zeros(),
            goal_error_m: f64::NAN,
            orientation_error_rad: 0.0,
            alpha: 0.0,
            nominal_speed_m_s: 0.0,
            ee_distance_m: f64::INFINITY,
            ee_lambda_normal: 1.0,
            avoid_link: None,
            link_distance_m: f64::INFINITY,
            ee_velocity: Vector3::zeros(),
            escaping: false,
            saturation: Saturation::default(),
            ik: IkReport::default(),
            age_scale: 1.0,
            safety: SafetyReport {
                distance_m: f64::INFINITY,
                ..SafetyReport::default()
            },
            contact: ContactReport::default(),
            tool_speed_scale: 1.0,
        }
    }
}

/// What one step writes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlOutput {
    /// Joint velocity command (rad/s), within the speed limits and such that q + q̇ dt stays
    /// within the position limits.
    pub qdot: JointVector,
    /// Motion status.
    pub status: Status,
    /// Diagnostics.
    pub diagnostics: Diagnostics,
}

impl Default for ControlOutput {
    fn default() -> Self {
        Self {
            qdot: JointVector::zeros(),
            status: Status::Held(HoldReason::Command),
            diagnostics: Diagnostics::default(),
        }
    }
}

/// The reactive DS controller of Sec. 5.1.1. Build once, call [`step`](Self::step) every
/// period; no step allocates.
#[derive(Debug, Clone)]
pub struct DsController {
    model: RobotModel,
    cfg: ControllerConfig,
    reach: Reach,
    tip: usize,
    /// First link rigidly attached to the last joint: links from here on are "end effector".
    ee_first_link: usize,
    poses: LinkPoses,
    ik: Ik,
    safety: LinkSafety,
    escape: Escape,
    last_qdot: JointVector,
    command_id: Option<u32>,
    held_orientation: UnitQuaternion<f64>,
    /// Joint configuration at the start of the current command (posture task).
    posture_q: JointVector,
    /// Resume ramp in [0, 1]: 0 after a hold, rising to 1 over `resume_time_s`.
    ramp: f64,
    /// Command id the learned field was last reset for.
    field_command: Option<u32>,
    /// Task transition control (used when `cfg.ttc.enabled`).
    ttc: Ttc,
    /// The last contact link while the TTC weights are away from T¹.
    contact_link: Option<usize>,
}

impl DsController {
    /// A controller for `model` with `cfg` (validated here).
    pub fn new(model: RobotModel, cfg: ControllerConfig) -> Result<Self> {
        cfg.validate()?;
        let reach = Reach::of_model(&model);
        let tip = model.tip_link();
        let ee_first_link = model.joint_link(DOF - 1);
        Ok(Self {
            reach,
            tip,
            ee_first_link,
            poses: LinkPoses::new(),
            ik: Ik::new(cfg.ik),
            safety: LinkSafety::new(cfg.safety),
            escape: Escape::new(),
            last_qdot: JointVector::zeros(),
            command_id: None,
            held_orientation: UnitQuaternion::identity(),
            posture_q: JointVector::zeros(),
            ramp: 0.0,
            field_command: None,
            ttc: Ttc::new(cfg.ttc)?,
            contact_link: None,
            model,
            cfg,
        })
    }

    /// The robot model.
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// The configuration.
    pub fn config(&self) -> &ControllerConfig {
        &self.cfg
    }

    /// The arm's reach bound used for goal checks.
    pub fn reach(&self) -> &Reach {
        &self.reach
    }

    /// First link index treated as part of the end effector (links rigidly moved by the last
    /// joint); lower links are avoided in the null space.
    pub fn end_effector_first_link(&self) -> usize {
        self.ee_first_link
    }

    /// The last joint velocity command (rad/s).
    pub fn last_command(&self) -> &JointVector {
        &self.last_qdot
    }

    /// One control period.
    ///
    /// Always fills `out` with a command to send. On `Err` (stale or bad input) that command
    /// brakes every joint towards zero at `brake_deceleration` and the status is
    /// [`Status::Held`]; motion resumes (ramped over `resume_time_s`) at the first step whose
    /// inputs are fresh and valid. Allocation-free.
    pub fn step(
        &mut self,
        input: &ControlInput,
        out: &mut ControlOutput,
    ) -> std::result::Result<(), Fault> {
        self.step_with_field(input, None, out)
    }

    /// [`step`](Self::step) for a command whose primitive may be [`Primitive::Learned`]: `field`
    /// is its f (reset at the first step of each command id). A learned command without a
    /// field, or a non-finite field velocity, faults and holds. Allocation-free when the field
    /// is.
    pub fn step_with_field(
        &mut self,
        input: &ControlInput,
        field: Option<&mut dyn LearnedField>,
        out: &mut ControlOutput,
    ) -> std::result::Result<(), Fault> {
        self.step_with_contact(input, field, None, out)
    }

    /// Whether `wrench` may act this step (see [`WrenchIgnored`]).
    pub fn check_wrench(&self, time: f64, wrench: &ExternalWrench) -> std::result::Result<(), WrenchIgnored> {
        if !self.cfg.ttc.enabled {
            return Err(WrenchIgnored::Disabled);
        }
        if !(wrench.stamp.is_finite() && wrench.force.iter().all(|v| v.is_finite())) {
            return Err(WrenchIgnored::NonFinite);
        }
        let age = time - wrench.stamp;
        // Symmetric: lwr_sim stamps its report with its own time, which runs up to a few tens
        // of ms ahead of a loaded controller's mirrored /clock (joint states show the same);
        // a clock that went back is off by far more.
        if !(age.abs() <= self.cfg.ttc.max_wrench_age_s) {
            return Err(WrenchIgnored::Stale { age_s: age });
        }
        let force_n = wrench.force.norm();
        if force_n > self.cfg.ttc.max_force {
            return Err(WrenchIgnored::TooLarge { force_n });
        }
        if wrench.link >= self.model.link_count() {
            return Err(WrenchIgnored::UnknownLink { link: wrench.link });
        }
        Ok(())
    }

    /// [`step_with_field`](Self::step_with_field) with a person's push: with `ttc.enabled`, the
    /// IK's joint velocity is T¹ of task transition control ([`crate::ttc`], thesis Sec.
    /// 4.1.2) and `wrench` drives the blend towards [T_ee, T_ic] (‖f‖ ≥ `insert_force`) or
    /// [T_ic, T_ee] (≥ `switch_force`), the contact at the end of the wrench's link. A stale,
    /// non-finite, too large or unknown-link wrench is not used (`out.diagnostics.contact
    /// .ignored` says why; the step runs as without a touch). The weights keep moving after the
    /// touch ends, so the joint velocity does not jump; a hold resets them. The link-distance
    /// damper and the saturation still act on the blended velocity. Allocation-free.
    pub fn step_with_contact(
        &mut self,
        input: &ControlInput,
        field: Option<&mut dyn LearnedField>,
        wrench: Option<&ExternalWrench>,
        out: &mut ControlOutput,
    ) -> std::result::Result<(), Fault> {
        let mut checked = self.validate(input);
        if checked.is_ok() && matches!(input.command.primitive, Primitive::Learned) && field.is_none() {
            checked = Err(Fault::BadPrimitive { what: "learned model (none loaded)", value: f64::NAN });
        }
        if let Err(fault) = checked {
            self.brake(&input.q, out, HoldReason::Fault(fault));
            return Err(fault);
        }
        let cmd = &input.command;
        self.model.forward_kinematics(&input.q, &mut self.poses);
        let tip_pose = *self.poses.get(self.tip);
        let x = tip_pose.translation.vector;
        if self.command_id != Some(cmd.id) {
            self.command_id = Some(cmd.id);
            self.held_orientation = tip_pose.rotation;
            self.posture_q = input.q;
            self.escape.reset();
        }
        let goal_error = (cmd.goal - x).norm();
        let desired_rot = cmd.orientation.unwrap_or(self.held_orientation);
        let rot_err = orientation_error(&tip_pose.rotation, &desired_rot);
        let mut d = Diagnostics {
            ee_position: x,
            goal_error_m: goal_error,
            orientation_error_rad: rot_err.norm(),
            ..Diagnostics::default()
        };
        if matches!(cmd.primitive, Primitive::Hold) {
            self.brake(&input.q, out, HoldReason::Command);
            out.diagnostics = Diagnostics { alpha: 0.0, ..d };
            return Ok(());
        }

        let dt = self.cfg.period_s;
        let ramp_rate = if self.cfg.resume_time_s > 0.0 {
            dt / self.cfg.resume_time_s
        } else {
            1.0
        };
        self.ramp = (self.ramp + ramp_rate).min(1.0);
        // Watchdog slow zone: the older the newest distances / human state, the slower.
        let age = (input.time - input.distances.stamp).max(input.time - input.human.stamp);
        let age_scale = if age <= self.cfg.slow_after_s {
            1.0
        } else {
            ((self.cfg.stale_after_s - age) / (self.cfg.stale_after_s - self.cfg.slow_after_s))
                .clamp(0.0, 1.0)
        };
        d.age_scale = age_scale;
        let alpha = self.cfg.scaling.alpha(&input.human.state) * self.ramp * age_scale;
        d.alpha = alpha;
        if let Primitive::Joints(m) = cmd.primitive {
            self.joint_step(input, &m, alpha, d, out);
            return Ok(());
        }
        // A learned primitive's null-space (elbow) path, if it has one (Sec. 4.1.1).
        let mut null_space = None;
        let nominal = match (&cmd.primitive, field) {
            (Primitive::Learned, Some(field)) => {
                if self.field_command != Some(cmd.id) {
                    self.field_command = Some(cmd.id);
                    field.reset(&x, &cmd.goal);
                }
                let v = field.velocity(&x, &cmd.goal, dt * alpha);
                if !v.iter().all(|c| c.is_finite()) {
                    let fault = Fault::NonFinite { what: "learned primitive velocity", link: usize::MAX };
                    self.brake(&input.q, out, HoldReason::Fault(fault));
                    return Err(fault);
                }
                if let Some(link) = field.null_space_link().filter(|&l| l < self.model.link_count()) {
                    let v_link = field.null_space_velocity(&self.poses.get(link).translation.vector);
                    if !v_link.iter().all(|c| c.is_finite()) {
                        let fault = Fault::NonFinite { what: "learned null-space primitive velocity", link: usize::MAX };
                        self.brake(&input.q, out, HoldReason::Fault(fault));
                        return Err(fault);
                    }
                    // The same speed rule as the end effector's own task.
                    null_space = Some(PointTask { link, velocity: limit_speed(v_link, self.cfg.scaling.far_speed) * alpha });
                }
                v
            }
            _ => adapted_velocity(&cmd.primitive, &x, &cmd.goal),
        };
        // Eq. 5.3 with α_h the allowed speed over the far speed: f(x) is held to the far speed,
        // then α_h scales it, so the end effector's own task never outruns the allowed speed — a linear
        // DS of gain 8 on a goal 0.3 m away would ask 2.4 m/s.
        let f = limit_speed(nominal, self.cfg.scaling.far_speed) * alpha;
        d.nominal_speed_m_s = nominal.norm();

        // End effector: closest obstacle of the links rigidly moved by the last joint.
        let mc = &self.cfg.modulation;
        let eps = mc.epsilon;
        let weight = |d: f64| influence_weight(d, mc.full_distance, mc.influence_distance);
        let dist = &input.distances;
        let mut xdot = f;
        if self.cfg.modulation.end_effector && cmd.end_effector_avoidance {
            let found = closest(dist, self.ee_first_link, dist.count)
                .filter(|&i| weight(dist.links[i].distance) > 0.0);
            if let Some(i) = found {
                let o = &dist.links[i];
                let wgt = weight(o.distance);
                let n = Unit::new_normalize(o.normal);
                let v = orthonormal_basis(&n);
                let m = weighted_modulation_matrix_in_basis(&v, o.distance, eps, wgt);
                let modulated = modulate(&m, &f, &o.obstacle_velocity);
                let escaped = self
                    .escape
                    .step(&self.cfg.escape, &v, o.distance, &f, &modulated);
                // The tangential eigenvalues (up to 2 at the surface) would speed the tool past
                // the allowed speed; moving with an obstacle that comes at it stays allowed.
                let allowed = alpha * self.cfg.scaling.far_speed + o.obstacle_velocity.norm();
                xdot = limit_speed(escaped, allowed);
                d.ee_distance_m = o.distance;
                d.ee_lambda_normal = weighted_eigenvalues(o.distance, eps, wgt).x;
                d.escaping = self.escape.active();
            } else {
                self.escape.reset();
            }
        }
        d.ee_velocity = xdot;

        let w = limit_speed(rot_err * self.cfg.ik.orientation_gain, self.cfg.ik.max_angular_speed);

        // Null space: closest point of the other moving links.
        let mut task = None;
        if self.cfg.modulation.links {
            let first_moving = self.model.joint_link(0);
            let found = closest(dist, first_moving, self.ee_first_link.min(dist.count))
                .filter(|&i| weight(dist.links[i].distance) > 0.0);
            if let Some(i) = found {
                let o = &dist.links[i];
                let n = Unit::new_normalize(o.normal);
                let v = orthonormal_basis(&n);
                task = Some(LinkTask {
                    link: i,
                    point: o.robot_point,
                    modulation: weighted_modulation_matrix_in_basis(
                        &v,
                        o.distance,
                        eps,
                        weight(o.distance),
                    ),
                    obstacle_velocity: o.obstacle_velocity,
                });
                d.avoid_link = Some(i);
                d.link_distance_m = o.distance;
            }
        }

        let twist = Twist::new(xdot.x, xdot.y, xdot.z, w.x, w.y, w.z);
        let mut posture = limit_avoidance(&self.cfg.ik, self.model.joint_limits(), &input.q);
        let gain = self.cfg.ik.posture_gain;
        match &self.cfg.ik.posture_reference {
            Some(reference) => {
                for (j, r) in reference.iter().enumerate() {
                    if let Some(r) = r {
                        posture[j] += (r - input.q[j]) * gain;
                    }
                }
            }
            None => posture += (self.posture_q - input.q) * gain,
        }
        posture *= alpha;
        let pull = posture.norm();
        if pull > self.cfg.ik.posture_max_speed {
            posture *= self.cfg.ik.posture_max_speed / pull;
        }
        // A null-space primitive takes the lowest priority instead of the posture task.
        let mut qdot = self.ik.solve_with_null_space(
            &self.model,
            &self.poses,
            self.tip,
            &twist,
            task.as_ref(),
            &posture,
            null_space.as_ref(),
            Some((&input.q, dt)),
            &mut d.ik,
        );
        // Task transition control: the IK's q̇ is T¹; a push blends in T² / T³.
        let mut contact_report = ContactReport::default();
        let contact = match wrench {
            Some(w) => match self.check_wrench(input.time, w) {
                Ok(()) => Some(Contact {
                    link: w.link,
                    point: contact_point_at_link_end(&self.model, &self.poses, w.link),
                    force: w.force,
                }),
                Err(why) => {
                    contact_report.ignored = Some(why);
                    None
                }
            },
            None => None,
        };
        // After the touch (or a refused wrench) the guidance task stays in the stacks with
        // ẋ_ic = 0 at the last contact while the weights return to T¹: dropping it at once
        // would switch q̇² and q̇³ to q̇¹ in one step (a joint-velocity jump).
        let contact = contact.or_else(|| {
            (!self.ttc.idle()).then_some(self.contact_link).flatten().map(|link| Contact {
                link,
                point: contact_point_at_link_end(&self.model, &self.poses, link),
                force: Vector3::zeros(),
            })
        });
        if self.cfg.ttc.enabled && (contact.is_some() || !self.ttc.idle()) {
            self.contact_link = contact.map(|c| c.link);
            qdot = self.ttc.step_from(
                &self.model,
                &self.poses,
                self.tip,
                &twist,
                Some(&qdot),
                contact.as_ref(),
                dt,
                &mut contact_report.ttc,
            );
            contact_report.weights = contact_report.ttc.weights;
            contact_report.link = contact.filter(|c| c.force != Vector3::zeros()).map(|c| c.link);
            contact_report.force_n = contact.map_or(0.0, |c| c.force.norm());
            if self.ttc.idle() {
                self.contact_link = None;
            }
        }
        d.contact = contact_report;
        let converged = goal_error <= self.cfg.goal_tolerance_m
            && (cmd.orientation.is_none()
                || d.orientation_error_rad <= self.cfg.orientation_tolerance_rad);
        self.finish_step(input, qdot, alpha, converged, d, out);
        Ok(())
    }

    /// A [`Primitive::Joints`] step: q̇ = k (q_g − q), no joint faster than the move's
    /// `max_speed`, times α_h; then the damper, the tool's speed and the limits as every step.
    fn joint_step(&mut self, input: &ControlInput, m: &JointMove, alpha: f64, d: Diagnostics, out: &mut ControlOutput) {
        let error = JointVector::from_row_slice(&m.joints) - input.q;
        let mut qdot = error * m.gain;
        let fastest = qdot.amax();
        if fastest > m.max_speed {
            qdot *= m.max_speed / fastest;
        }
        qdot *= alpha;
        self.ik.update_tool_jacobian(&self.model, &self.poses, self.tip);
        self.finish_step(input, qdot, alpha, error.amax() <= JointMove::TOLERANCE_RAD, d, out);
    }

    /// The end of every moving step: the link damper, the tool's allowed speed, the joint
    /// limits on `qdot`; the command and the status into `out`.
    fn finish_step(&mut self, input: &ControlInput, mut qdot: JointVector, alpha: f64, converged: bool, mut d: Diagnostics, out: &mut ControlOutput) {
        let cmd = &input.command;
        let dist = &input.distances;
        let x = d.ee_position;
        // Safety above the end-effector task: no link closes on an obstacle faster than the
        // damper allows (the end-effector links too unless the command turned their avoidance
        // off).
        let ee_safety = self.cfg.safety.end_effector
            && self.cfg.modulation.end_effector
            && cmd.end_effector_avoidance;
        let to = if ee_safety { dist.count } else { self.ee_first_link };
        d.safety = self.safety.apply(
            &self.model,
            &self.poses,
            dist,
            self.model.joint_link(0),
            to,
            (!ee_safety).then_some(&Point3::from(x)),
            input.time - dist.stamp,
            // The swivel first (the tool keeps to its DS), unless a person is guiding the arm:
            // then the null space is the blend's, not the end-effector task's.
            self.ttc.idle().then_some(self.ik.null_space()),
            &mut qdot,
        );
        // The robot's own motion keeps the allowed speed at the tool, whatever the IK's lower
        // priorities did; a person guiding it (TTC) and obstacles coming at the arm may move it
        // faster (evasion at the obstacle's speed). Uniform scaling keeps every direction, so
        // the damper's and the limits' constraints still hold.
        if self.ttc.idle() {
            let allowed = alpha * self.cfg.scaling.far_speed + self.approaching_obstacle_speed(dist);
            let speed = (self.ik.tool_position_jacobian() * qdot).norm();
            if speed > allowed {
                d.tool_speed_scale = allowed / speed;
                qdot *= d.tool_speed_scale;
            }
        }
        let k = &self.cfg.ik;
        d.saturation = saturate(
            self.model.joint_limits(),
            &input.q,
            &mut qdot,
            self.cfg.period_s,
            k.velocity_limit_fraction,
            k.position_margin,
        );
        self.last_qdot = qdot;
        out.qdot = qdot;
        out.status = if self.cfg.scaling.alpha(&input.human.state) == 0.0 && self.ramp >= 1.0 {
            Status::Held(HoldReason::SpeedZero)
        } else if converged {
            Status::Converged
        } else {
            Status::Running
        };
        out.diagnostics = d;
    }

    /// Fastest approach (m/s, closing speed along the closest-point line) of an obstacle that is
    /// not a known scene object, within the modulation's influence or the damper's slow
    /// distance of any link: the arm may evade it at that speed. Scene objects stand still (their
    /// depth-image velocities are noise) and obstacles moving away need no evasion.
    fn approaching_obstacle_speed(&self, dist: &Distances) -> f64 {
        let reach = self.cfg.modulation.influence_distance.max(self.cfg.safety.slow_distance);
        let n = dist.count.min(dist.links.len());
        dist.links[..n]
            .iter()
            .zip(&dist.scene_object[..n])
            .filter(|(o, scene)| o.valid && !**scene && o.distance < reach)
            .map(|(o, _)| {
                let towards = o.robot_point - o.obstacle_point;
                let len = towards.norm();
                if len > 1e-6 { (towards / len).dot(&o.obstacle_velocity).max(0.0) } else { o.obstacle_velocity.norm() }
            })
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
    }

    /// Holds the robot for a reason found outside [`step`](Self::step) (e.g. stale joint
    /// states in the adapter): fills `out` with the braking command (the last command
    /// decelerated towards zero at `brake_deceleration`, within the position limits at `q`)
    /// and status [`Status::Held`]. The next valid [`step`](Self::step) resumes with the ramp.
    /// Allocation-free.
    pub fn hold(&mut self, q: &JointVector, out: &mut ControlOutput, reason: HoldReason) {
        self.brake(q, out, reason);
    }

    /// Decelerates the last command towards zero, within the position limits.
    fn brake(&mut self, q: &JointVector, out: &mut ControlOutput, reason: HoldReason) {
        let dv = self.cfg.brake_deceleration * self.cfg.period_s;
        let mut qdot = self.last_qdot.map(|v| v.signum() * (v.abs() - dv).max(0.0));
        let finite_q = q.iter().all(|v| v.is_finite());
        let sat = if finite_q {
            saturate(
                self.model.joint_limits(),
                q,
                &mut qdot,
                self.cfg.period_s,
                self.cfg.ik.velocity_limit_fraction,
                self.cfg.ik.position_margin,
            )
        } else {
            // Without a joint reading nothing can be checked against the limits: stop at once.
            qdot = JointVector::zeros();
            Saturation::default()
        };
        self.last_qdot = qdot;
        self.ramp = 0.0;
        self.escape.reset();
        self.ttc.reset();
        self.contact_link = None;
        out.qdot = qdot;
        out.status = Status::Held(reason);
        out.diagnostics = Diagnostics {
            saturation: sat,
            ..Diagnostics::default()
        };
    }

    fn validate(&self, input: &ControlInput) -> std::result::Result<(), Fault> {
        const NO_LINK: usize = usize::MAX;
        let bad = |what| Fault::NonFinite {
            what,
            link: NO_LINK,
        };
        if !input.time.is_finite() {
            return Err(bad("time"));
        }
        if !input.q.iter().all(|v| v.is_finite()) {
            return Err(bad("q"));
        }
        let cmd = &input.command;
        if !cmd.goal.iter().all(|v| v.is_finite()) {
            return Err(bad("goal"));
        }
        if let Some(r) = cmd.orientation
            && !r.coords.iter().all(|v| v.is_finite())
        {
            return Err(bad("goal orientation"));
        }
        if let Some((what, value)) = cmd.primitive.invalid_parameter() {
            return Err(Fault::BadPrimitive { what, value });
        }
        let stale = |stream, stamp: f64| {
            let age = input.time - stamp;
            // NaN stamps fail this comparison too; so do stamps from the future (a clock that
            // went back must not make old data look fresh).
            if age <= self.cfg.stale_after_s && age >= -self.cfg.future_tolerance_s {
                Ok(())
            } else {
                Err(Fault::Stale {
                    stream,
                    age_s: age,
                    bound_s: self.cfg.stale_after_s,
                })
            }
        };
        stale(Stream::Distances, input.distances.stamp)?;
        stale(Stream::Human, input.human.stamp)?;
        let dist = &input.distances;
        if dist.count > self.model.link_count() {
            return Err(Fault::TooManyLinks {
                given: dist.count,
                links: self.model.link_count(),
            });
        }
        for (link, o) in dist.links[..dist.count].iter().enumerate() {
            if !o.valid {
                continue;
            }
            let nf = |what| Fault::NonFinite { what, link };
            if !o.distance.is_finite() {
                return Err(nf("distance"));
            }
            if !o.normal.iter().all(|v| v.is_finite()) {
                return Err(nf("normal"));
            }
            if o.normal.norm() < 1e-9 {
                return Err(Fault::ZeroNormal { link });
            }
            if !o.robot_point.iter().all(|v| v.is_finite()) {
                return Err(nf("robot point"));
            }
            if !o.obstacle_point.iter().all(|v| v.is_finite()) {
                return Err(nf("obstacle point"));
            }
            if !o.obstacle_velocity.iter().all(|v| v.is_finite()) {
                return Err(nf("obstacle velocity"));
            }
        }
        if self.cfg.check_reach && !matches!(cmd.primitive, Primitive::Hold) {
            self.reach.check(&cmd.goal)?;
        }
        Ok(())
    }
}

/// `v` shortened to a norm of at most `max` (m/s, or rad/s for a rotation), direction kept.
fn limit_speed(v: Vector3<f64>, max: f64) -> Vector3<f64> {
    let speed = v.norm();
    if speed > max {
        v * (max / speed)
    } else {
        v
    }
}

/// Index of the valid entry with the smallest distance among links `from..to`.
fn closest(dist: &Distances, from: usize, to: usize) -> Option<usize> {
    let mut best: Option<usize> = None;
    for i in from..to.min(dist.count) {
        let o = &dist.links[i];
        if o.valid && best.is_none_or(|b| o.distance < dist.links[b].distance) {
            best = Some(i);
        }
    }
    best
}
