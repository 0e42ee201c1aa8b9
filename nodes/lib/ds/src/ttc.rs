//! Task transition control (thesis Sec. 4.1.2, eq. 4.1–4.6, Table 4.1): a learned end-effector
//! motion T_ee and a person's physical guidance T_ic, with priorities that follow how hard the
//! person pushes and joint velocities that never jump.
//!
//! - T_ic is an admittance at the contact point: ẋ_ic = c f_e (eq. 4.6), the contact taken at
//!   the end of the contact link as the thesis assumes ([`contact_point_at_link_end`]).
//! - Three stacks (Table 4.1, f = ‖f_e‖): T¹ = T_ee (f < f_i); T² = [T_ee, T_ic] (f_i ≤ f < f_s:
//!   the guidance only in T_ee's null space); T³ = [T_ic, T_ee] (f ≥ f_s: the guidance first).
//!   Each stack's q̇ⁱ comes from task-priority IK (Nakamura's form, as [`crate::ik`]):
//!   q̇¹ = J_ee† ẋ_ee; q̇² = q̇¹ + N_ee (J_c N_ee)† (ẋ_ic − J_c q̇¹);
//!   q̇³ = J_c† ẋ_ic + N_c (J_ee N_c)† (ẋ_ee − J_ee J_c† ẋ_ic), N = I − J†J, damped †.
//! - q̇ = Σ wᵢ q̇ⁱ (eq. 4.1) with barycentric coordinates w driven towards the Table 4.1 corner
//!   w_d = êᵢ by the second-order (s = 1) linear system of eq. 4.2,
//!   ẅ = −k₁ ẇ + k₀ (w_d − w), k₁ = 2 √k₀ (critically damped: no overshoot from rest),
//!   integrated exactly over each step. Every component follows the same linear dynamics, so
//!   Σ w = 1 holds by construction; a target switched mid-transition (eq. 4.5's "from rest"
//!   not met) could leave the simplex by rounding or overshoot, so w is projected back onto it
//!   (clamped at 0, renormalised) — Definition 1 then holds at every step and
//!   ‖q̇‖ ≤ max ‖q̇ⁱ‖ (Theorem 3) follows from convexity.
//!
//! Allocation-free: fixed-size matrices only; one instance per controller. Frames: robot base
//! frame; m, rad, s, N.

use cowork_robot::{
    Jacobian, JointMatrix, JointVector, LinkPoses, PositionJacobian, RobotModel,
    damped_pseudo_inverse, damped_pseudo_inverse_3, null_space_projector,
};
use nalgebra::{Point3, SVector, Vector3};

use crate::ik::Twist;
use crate::{Error, Result};

/// Parameters of the task transition controller (thesis values as defaults).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TtcConfig {
    /// Run task transition control inside [`crate::DsController`] (its
    /// [`step_with_contact`](crate::DsController::step_with_contact)); off: a reported wrench
    /// is ignored and the controller is today's. [`Ttc`] itself ignores this flag.
    pub enabled: bool,
    /// A reported external wrench counts for the controller while younger than this (s, by its
    /// stamp); older, the touch is over (the simulator reports an active push at 1 kHz).
    pub max_wrench_age_s: f64,
    /// A reported force above this (N) is not a person's guidance (a collision or a sensor
    /// fault): ignored, the primitive runs on. The LWR's own collision detection is the
    /// safety net for that, not the guidance task.
    pub max_force: f64,
    /// Admittance gain c of eq. 4.6 (m/(N·s)): ẋ_ic = c f_e. Thesis: 0.005.
    pub contact_gain: f64,
    /// Force f_i (N) from which the guidance is inserted below T_ee (T²). Thesis: 5 N.
    pub insert_force: f64,
    /// Force f_s (N) from which the guidance takes priority (T³), ≥ `insert_force`. Thesis: 15 N.
    pub switch_force: f64,
    /// k₀ of eq. 4.2 (1/s²); k₁ = 2√k₀. 100 gives a transition 95 % done in about 0.47 s.
    pub transition_gain: f64,
    /// Damping λ of the end-effector task's pseudo-inverses (mixed m/rad units).
    pub damping: f64,
    /// Damping λ of the contact task's pseudo-inverses (m/rad).
    pub contact_damping: f64,
}

impl Default for TtcConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            max_wrench_age_s: 0.05,
            max_force: 150.0,
            contact_gain: 0.005,
            insert_force: 5.0,
            switch_force: 15.0,
            transition_gain: 100.0,
            damping: 0.01,
            contact_damping: 0.02,
        }
    }
}

impl TtcConfig {
    /// Rejects NaN, infinite and out-of-range values, naming the field.
    pub fn validate(&self) -> Result<()> {
        let check = |field: &'static str, value: f64, ok: bool, reason: &'static str| {
            if value.is_finite() && ok { Ok(()) } else { Err(Error::Config { field, value, reason }) }
        };
        check("ttc.contact_gain", self.contact_gain, self.contact_gain > 0.0, "must be > 0 m/(N s)")?;
        check("ttc.insert_force", self.insert_force, self.insert_force > 0.0, "must be > 0 N")?;
        check(
            "ttc.switch_force",
            self.switch_force,
            self.switch_force >= self.insert_force,
            "must be ≥ insert_force N",
        )?;
        check("ttc.transition_gain", self.transition_gain, self.transition_gain > 0.0, "must be > 0 1/s²")?;
        check("ttc.damping", self.damping, self.damping >= 0.0, "must be ≥ 0")?;
        check("ttc.contact_damping", self.contact_damping, self.contact_damping >= 0.0, "must be ≥ 0")?;
        check("ttc.max_wrench_age_s", self.max_wrench_age_s, self.max_wrench_age_s > 0.0, "must be > 0 s")?;
        check(
            "ttc.max_force",
            self.max_force,
            self.max_force > self.switch_force,
            "must exceed switch_force N",
        )
    }
}

/// Which stack of Table 4.1 a force asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stack {
    /// T¹ = T_ee: no (or a light) touch.
    EndEffector,
    /// T² = [T_ee, T_ic]: the guidance in T_ee's null space.
    GuidanceBelow,
    /// T³ = [T_ic, T_ee]: the guidance first.
    GuidanceFirst,
}

impl Stack {
    /// Table 4.1 for the force norm `f` (N); NaN (an unusable estimate) counts as no touch.
    pub fn for_force(f: f64, cfg: &TtcConfig) -> Self {
        if f >= cfg.switch_force {
            Stack::GuidanceFirst
        } else if f >= cfg.insert_force {
            Stack::GuidanceBelow
        } else {
            Stack::EndEffector
        }
    }

    fn index(self) -> usize {
        match self {
            Stack::EndEffector => 0,
            Stack::GuidanceBelow => 1,
            Stack::GuidanceFirst => 2,
        }
    }
}

/// Where the person touches the arm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// The contact link (model index).
    pub link: usize,
    /// The contact point (m, base frame); the thesis takes the end of the contact link.
    pub point: Point3<f64>,
    /// External force f_e at that point (N, base frame).
    pub force: Vector3<f64>,
}

/// The end of link `link` at `poses`: the origin of the next link that a joint moves (the
/// joint the link ends in), or the link's own origin for the last one (m, base frame).
pub fn contact_point_at_link_end(model: &RobotModel, poses: &LinkPoses, link: usize) -> Point3<f64> {
    let next = (link + 1..model.link_count()).find(|&l| model.joints_moving_link(l) > model.joints_moving_link(link));
    Point3::from(poses.get(next.unwrap_or(link)).translation.vector)
}

/// What one [`Ttc::step`] did, besides q̇.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TtcReport {
    /// Barycentric coordinates (w₁, w₂, w₃) of T¹, T², T³ after the step.
    pub weights: [f64; 3],
    /// The stack Table 4.1 asks for (index 0, 1, 2).
    pub target: usize,
    /// ẋ_ic = c f_e (m/s, base frame); zero without a contact.
    pub contact_velocity_desired: Vector3<f64>,
    /// Velocity of the contact point under the returned q̇ (m/s).
    pub contact_velocity: Vector3<f64>,
    /// End-effector twist under the returned q̇ ([m/s; rad/s]).
    pub end_effector_twist: Twist,
    /// ‖q̇ⁱ‖ of the three stacks (rad/s).
    pub stack_norms: [f64; 3],
}

/// The task transition controller: state w, ẇ and scratch matrices.
#[derive(Debug, Clone)]
pub struct Ttc {
    cfg: TtcConfig,
    w: SVector<f64, 3>,
    w_dot: SVector<f64, 3>,
    j_ee: Jacobian,
    j_c: PositionJacobian,
}

impl Ttc {
    /// A controller at T¹ (w = ê₁, at rest). `cfg` must pass [`TtcConfig::validate`].
    pub fn new(cfg: TtcConfig) -> Result<Self> {
        cfg.validate()?;
        Ok(Self {
            cfg,
            w: SVector::<f64, 3>::new(1.0, 0.0, 0.0),
            w_dot: SVector::zeros(),
            j_ee: Jacobian::zeros(),
            j_c: PositionJacobian::zeros(),
        })
    }

    /// Parameters.
    pub fn config(&self) -> &TtcConfig {
        &self.cfg
    }

    /// Current barycentric coordinates (w₁, w₂, w₃).
    pub fn weights(&self) -> [f64; 3] {
        [self.w[0], self.w[1], self.w[2]]
    }

    /// At T¹ and at rest (w = ê₁, ẇ = 0): without a touch a step would return q̇¹ unchanged.
    pub fn idle(&self) -> bool {
        self.w[0] == 1.0 && self.w_dot.iter().all(|v| *v == 0.0)
    }

    /// Back to T¹ at rest (a new primitive, or after a hold).
    pub fn reset(&mut self) {
        self.w = SVector::<f64, 3>::new(1.0, 0.0, 0.0);
        self.w_dot = SVector::zeros();
    }

    /// One step of `dt` seconds: joint velocity (rad/s, unsaturated) for the end-effector twist
    /// `ee_twist` of link `tip` at its origin and the person's `contact` (none: no touch), at the
    /// link `poses` of forward kinematics. A non-finite force counts as no touch.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        model: &RobotModel,
        poses: &LinkPoses,
        tip: usize,
        ee_twist: &Twist,
        contact: Option<&Contact>,
        dt: f64,
        report: &mut TtcReport,
    ) -> JointVector {
        self.step_from(model, poses, tip, ee_twist, None, contact, dt, report)
    }

    /// [`step`](Self::step) with the T¹ solution given: `primary` replaces q̇¹ = J_ee† ẋ_ee
    /// (e.g. [`crate::DsController`]'s IK, which adds null-space link avoidance and a posture
    /// task below T_ee); T² builds on it (q̇² = q̇¹ + N_ee (J_c N_ee)† (ẋ_ic − J_c q̇¹)), T³ is
    /// computed from ẋ_ee as in `step`. `None`: q̇¹ = J_ee† ẋ_ee.
    #[allow(clippy::too_many_arguments)]
    pub fn step_from(
        &mut self,
        model: &RobotModel,
        poses: &LinkPoses,
        tip: usize,
        ee_twist: &Twist,
        primary: Option<&JointVector>,
        contact: Option<&Contact>,
        dt: f64,
        report: &mut TtcReport,
    ) -> JointVector {
        let contact = contact.filter(|c| c.force.iter().all(|v| v.is_finite()) && c.point.iter().all(|v| v.is_finite()));
        let force = contact.map_or(0.0, |c| c.force.norm());
        let target = Stack::for_force(force, &self.cfg);
        self.advance_weights(target, dt);

        model.jacobian(poses, tip, &Point3::origin(), &mut self.j_ee);
        let ee_pinv = damped_pseudo_inverse(&self.j_ee, self.cfg.damping);
        let q1 = match primary {
            Some(q) => *q,
            None => ee_pinv * ee_twist,
        };
        let (q2, q3, x_ic) = match contact {
            Some(c) => {
                let in_link = poses.get(c.link).inverse_transform_point(&c.point);
                model.position_jacobian(poses, c.link, &in_link, &mut self.j_c);
                let x_ic = self.cfg.contact_gain * c.force;
                // T² = [T_ee, T_ic].
                let n_ee = null_space_projector(&self.j_ee, &ee_pinv);
                let jc_n: PositionJacobian = self.j_c * n_ee;
                let jc_n_pinv = damped_pseudo_inverse_3(&jc_n, self.cfg.contact_damping);
                let q2 = q1 + n_ee * (jc_n_pinv * (x_ic - self.j_c * q1));
                // T³ = [T_ic, T_ee].
                let c_pinv = damped_pseudo_inverse_3(&self.j_c, self.cfg.contact_damping);
                let qc = c_pinv * x_ic;
                let n_c: JointMatrix = null_space_projector(&self.j_c, &c_pinv);
                let jee_n: Jacobian = self.j_ee * n_c;
                let jee_n_pinv = damped_pseudo_inverse(&jee_n, self.cfg.damping);
                let q3 = qc + n_c * (jee_n_pinv * (ee_twist - self.j_ee * qc));
                (q2, q3, x_ic)
            }
            // Without a touch the guidance task asks for nothing: every stack is T_ee.
            None => (q1, q1, Vector3::zeros()),
        };
        let qdot = self.w[0] * q1 + self.w[1] * q2 + self.w[2] * q3;
        *report = TtcReport {
            weights: self.weights(),
            target: target.index(),
            contact_velocity_desired: x_ic,
            contact_velocity: if contact.is_some() { self.j_c * qdot } else { Vector3::zeros() },
            end_effector_twist: self.j_ee * qdot,
            stack_norms: [q1.norm(), q2.norm(), q3.norm()],
        };
        qdot
    }

    /// Eq. 4.2 with s = 1 over `dt`, solved exactly (critically damped, ω = √k₀): the error
    /// e = w − w_d evolves as e(t) = (e₀ + (ė₀ + ω e₀) t) e^{−ωt}. Then w is projected onto the
    /// simplex (Definition 1).
    fn advance_weights(&mut self, target: Stack, dt: f64) {
        let mut wd = SVector::<f64, 3>::zeros();
        wd[target.index()] = 1.0;
        let dt = if dt.is_finite() && dt > 0.0 { dt } else { 0.0 };
        let omega = self.cfg.transition_gain.sqrt();
        let decay = (-omega * dt).exp();
        let e0 = self.w - wd;
        let b = self.w_dot + omega * e0;
        let e = (e0 + b * dt) * decay;
        self.w_dot = (self.w_dot - omega * b * dt) * decay;
        self.w = wd + e;
        let mut clamped = false;
        for i in 0..3 {
            if self.w[i] < 0.0 {
                self.w[i] = 0.0;
                self.w_dot[i] = 0.0;
                clamped = true;
            }
        }
        let sum = self.w.sum();
        if clamped || (sum - 1.0).abs() > 1e-12 {
            if sum > 0.0 {
                self.w /= sum;
            } else {
                self.w = wd;
                self.w_dot = SVector::zeros();
            }
        }
        // Settled: snap to the corner (a change of < 1e-9 in w), so that a controller can tell
        // T¹ at rest ([`Ttc::idle`]) instead of decaying for ever.
        if (self.w - wd).amax() < 1e-9 && self.w_dot.amax() < 1e-9 {
            self.w = wd;
            self.w_dot = SVector::zeros();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_4_1() {
        let c = TtcConfig::default();
        assert_eq!(Stack::for_force(0.0, &c), Stack::EndEffector);
        assert_eq!(Stack::for_force(4.99, &c), Stack::EndEffector);
        assert_eq!(Stack::for_force(5.0, &c), Stack::GuidanceBelow);
        assert_eq!(Stack::for_force(14.99, &c), Stack::GuidanceBelow);
        assert_eq!(Stack::for_force(15.0, &c), Stack::GuidanceFirst);
        assert_eq!(Stack::for_force(f64::NAN, &c), Stack::EndEffector);
    }

    #[test]
    fn a_transition_from_rest_is_smooth_monotone_and_stays_on_the_simplex() {
        let mut t = Ttc::new(TtcConfig::default()).expect("config");
        let mut prev = t.weights();
        let mut max_jump: f64 = 0.0;
        for _ in 0..1000 {
            t.advance_weights(Stack::GuidanceFirst, 1e-3);
            let w = t.weights();
            assert!(w.iter().all(|v| *v >= 0.0), "{w:?}");
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            assert!(w[2] >= prev[2] && w[0] <= prev[0], "monotone from rest: {prev:?} -> {w:?}");
            max_jump = max_jump.max((w[2] - prev[2]).abs());
            prev = w;
        }
        assert!(prev[2] > 0.999, "done after 1 s: {prev:?}");
        // Critically damped, ω = 10/s: the fastest change is ω/e per s, 3.7e-3 per 1 ms step.
        assert!(max_jump < 4e-3, "{max_jump}");
    }

    #[test]
    fn bad_parameters_are_refused_by_name() {
        let c = TtcConfig { switch_force: 4.0, ..TtcConfig::default() };
        let e = Ttc::new(c).expect_err("f_s < f_i");
        assert!(e.to_string().contains("ttc.switch_force"), "{e}");
        let c = TtcConfig { contact_gain: f64::NAN, ..TtcConfig::default() };
        assert!(Ttc::new(c).expect_err("NaN").to_string().contains("ttc.contact_gain"));
    }
}
