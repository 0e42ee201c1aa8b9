//! Link-distance safety: a velocity damper on every moving link's distance to its closest
//! obstacle, applied **above** the end-effector task (ours, beyond eq. 5.13).
//!
//! Why: eq. 5.13 avoids links only in the null space of the end-effector task. With the
//! orientation held (Sec. 5.1.3) that is one redundant DoF, and nothing slows the arm when a
//! link — not the end effector — closes on a person: in `cowork experiment stacking-hri` the
//! forearm swept into a hand held on the path while the end effector kept to its DS. The thesis
//! notes that "if collision avoidance is the most important task ... task priorities can be
//! changed to guarantee that the collision avoidance has always priority" (Sec. 5.1.1); this is
//! that change, in its simplest exact form.
//!
//! For link `l` with distance `d` (m), closest robot point `p_r`, obstacle point `p_o` and
//! obstacle velocity `v_O` (base frame), `u = (p_r − p_o)/‖p_r − p_o‖` (the obstacle normal when
//! the points coincide) and the distance rate is `ḋ = uᵀ(J_l q̇ − v_O)`. The damper asks
//!
//! ```text
//! ḋ ≥ −a(d),   a(d) = approach_speed · clamp((d − stop)/(slow − stop), 0, 1)     (d ≥ stop)
//!              a(d) = −retreat_gain · (stop − d)                                   (d < stop)
//! ```
//!
//! i.e. the speed at which a link may approach an obstacle falls linearly from
//! `approach_speed` at `slow_distance` to zero at `stop_distance`, and inside `stop_distance`
//! the link must move away. Only an approaching obstacle's speed is counted (`max(uᵀv_O, 0)`,
//! capped at `max_obstacle_speed`: a receding hand's noisy velocity never lets the arm close
//! in), and the distance is first reduced by how far that obstacle travels while the data ages
//! (`age · max(uᵀv_O, 0)`).
//!
//! **Known scene objects** (`Distances::scene_object`: the link's closest obstacle point lies
//! on an object of the task's scene, at the pose the world reports) are kept at the shorter
//! `scene_stop_distance` / `scene_slow_distance` instead. Why: the damper is for what the task
//! does not know — a person's hand closing on the forearm. The scene's objects are where the
//! teacher worked: pouring into the cup brings the forearm within 12 cm of the coffee jar
//! beside it, and with the person distances (stop 10 cm, slow 30 cm) the damper held the
//! forearm off the jar until the action timed out (`cowork_manager`'s pour, 2468 "approach
//! limited" statuses, every one on the jar: `nodes/robot_manager/scripts/damper_census.py`).
//! A link still never pushes into a known object (it stops at `scene_stop_distance`), and an
//! unknown obstacle closer than the object is that link's closest point again, damped in full.
//!
//! Each violated constraint `jᵀq̇ ≥ b` (`j = J_lᵀu`) is met first **in the null space of the
//! end-effector task** when the caller gives its projector `N`: `q̇ += N j δ/max(jᵀN j, λ²)`,
//! `δ = b − jᵀq̇`, at most `null_space_max_speed` rad/s — the elbow swivels off the obstacle
//! while the tool keeps to its DS. Whatever that leaves (an obstacle the redundancy cannot
//! avoid, one coming too fast) is met by the smallest joint-velocity change,
//! `q̇ += j δ/(jᵀj + λ²)`, which gives up the end-effector task. Why: with the damper above
//! the whole task, a jar poured over the cup with the put-back bottle 3 cm from the elbow held
//! links 3–4 and the pour for 2 × 120 s (`coffee-cooperative` seeds 1 and 3, 2026-12-03),
//! although a swivel of the elbow cleared the bottle. The links are swept a few times
//! (alternating projections onto the half-spaces). The motion along the obstacle surface is
//! kept, only the approach is removed — with a static obstacle at `stop_distance` the arm holds
//! rather than pushes. The later uniform speed saturation keeps every constraint whose `b ≤ 0`.
//! Allocation-free.

use cowork_robot::{JointMatrix, JointVector, LinkPoses, MAX_LINKS, PositionJacobian, RobotModel};
use nalgebra::Vector3;

use crate::controller::Distances;

/// Parameters of the link-distance damper. Distances are fDED's (link mesh points to depth
/// pixels, m), so `stop_distance` must cover its sampling error and the latency of the chain.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SafetyConfig {
    /// Damp link approaches at all (false: eq. 5.13 alone, as the thesis).
    pub enabled: bool,
    /// A link may not approach an obstacle closer than this; inside it, it retreats (m, > 0).
    pub stop_distance: f64,
    /// From this distance on the allowed approach speed falls to 0 at `stop_distance`
    /// (m, > `stop_distance`).
    pub slow_distance: f64,
    /// Approach speed allowed at `slow_distance` (m/s, > 0).
    pub approach_speed: f64,
    /// Retreat speed per metre inside `stop_distance` (1/s, ≥ 0).
    pub retreat_gain: f64,
    /// `stop_distance` for a link whose closest obstacle is a known scene object (m, > 0,
    /// ≤ `stop_distance`): the task works next to its objects; this keeps the link off them.
    pub scene_stop_distance: f64,
    /// `slow_distance` for a known scene object (m, > `scene_stop_distance`, ≤ `slow_distance`).
    pub scene_slow_distance: f64,
    /// Largest obstacle approach speed the arm follows (m/s, ≥ 0): a person's hand moves at up
    /// to ~1.5 m/s; faster estimates are noise or a new obstacle.
    pub max_obstacle_speed: f64,
    /// Damp the end-effector links too (never while a command turns end-effector avoidance
    /// off, e.g. the handover, where the hand is the goal).
    pub end_effector: bool,
    /// Link points within this distance of the tool point belong to the hand (m, ≥ 0): it
    /// touches objects by design (grasp, place, the wrist right above a block), so its
    /// approaches are left to the end-effector DS modulation; the damper guards the arm
    /// behind it (elbow, forearm).
    pub hand_radius: f64,
    /// Damping λ of the projections (m/rad): bounds the joint speed asked of a link point the
    /// joints can hardly move along `u`.
    pub damping: f64,
    /// Sweeps over the links (≥ 1).
    pub iterations: u32,
    /// Meet a constraint in the end-effector task's null space first (the swivel), when the
    /// controller gives the projector; false: always override the task, as before.
    pub null_space_first: bool,
    /// Largest joint-velocity change (rad/s, norm) one constraint may ask of the null space;
    /// the rest overrides the end-effector task (> 0).
    pub null_space_max_speed: f64,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            stop_distance: 0.10,
            slow_distance: 0.30,
            scene_stop_distance: 0.03,
            scene_slow_distance: 0.10,
            approach_speed: 0.3,
            retreat_gain: 2.0,
            max_obstacle_speed: 1.5,
            end_effector: false,
            hand_radius: 0.12,
            damping: 0.02,
            iterations: 3,
            null_space_first: true,
            null_space_max_speed: 1.0,
        }
    }
}

/// What [`LinkSafety::apply`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SafetyReport {
    /// Some constraint was active (q̇ changed).
    pub active: bool,
    /// Link of the largest correction.
    pub link: Option<usize>,
    /// Its effective distance (m, after the age extrapolation); ∞ when none.
    pub distance_m: f64,
    /// Largest distance-rate deficit corrected by overriding the end-effector task (m/s); 0,
    /// with `link` `None`, when the null space met every constraint.
    pub correction_m_s: f64,
}

/// The damper's scratch (one per controller).
#[derive(Debug, Clone)]
pub struct LinkSafety {
    cfg: SafetyConfig,
    rows: [JointVector; MAX_LINKS],
    bounds: [f64; MAX_LINKS],
    dist: [f64; MAX_LINKS],
    pj: PositionJacobian,
}

impl LinkSafety {
    /// With `cfg` (validated by the controller config).
    pub fn new(cfg: SafetyConfig) -> Self {
        Self {
            cfg,
            rows: [JointVector::zeros(); MAX_LINKS],
            bounds: [0.0; MAX_LINKS],
            dist: [0.0; MAX_LINKS],
            pj: PositionJacobian::zeros(),
        }
    }

    /// Parameters.
    pub fn config(&self) -> &SafetyConfig {
        &self.cfg
    }

    /// Allowed approach speed (m/s; negative: required retreat) at effective distance `d` (m)
    /// to an unknown obstacle (a person).
    pub fn allowed_approach(&self, d: f64) -> f64 {
        self.allowed_approach_to(d, false)
    }

    /// Allowed approach speed (m/s; negative: required retreat) at effective distance `d` (m),
    /// to a known scene object (`scene`: the scene distances) or to anything else.
    pub fn allowed_approach_to(&self, d: f64, scene: bool) -> f64 {
        let c = &self.cfg;
        let (stop, slow) = if scene { (c.scene_stop_distance, c.scene_slow_distance) } else { (c.stop_distance, c.slow_distance) };
        if d >= stop {
            c.approach_speed * ((d - stop) / (slow - stop)).min(1.0)
        } else {
            -c.retreat_gain * (stop - d)
        }
    }

    /// Corrects `qdot` (rad/s) in place so that no link in `from..to` of `dist` (and no link
    /// beyond `to` whose entry is a [`Distances::floor`]) approaches its obstacle faster than
    /// allowed; `tool` is the tool point (m, base frame), `age_s` the age
    /// of `dist` (s, ≥ 0), `poses` the forward kinematics at the current q. Links at or beyond
    /// `slow_distance` (`scene_slow_distance` for a known scene object), closest points within
    /// `hand_radius` of the tool (unless `from..to`
    /// includes the end-effector links on purpose: `hand` false; never for a `floor` entry), invalid entries and links the
    /// joints cannot move (zero Jacobian) are left alone.
    #[allow(clippy::too_many_arguments)]
    pub fn apply(
        &mut self,
        model: &RobotModel,
        poses: &LinkPoses,
        dist: &Distances,
        from: usize,
        to: usize,
        tool: Option<&nalgebra::Point3<f64>>,
        age_s: f64,
        null_space: Option<&JointMatrix>,
        qdot: &mut JointVector,
    ) -> SafetyReport {
        let mut report = SafetyReport {
            distance_m: f64::INFINITY,
            ..SafetyReport::default()
        };
        if !self.cfg.enabled {
            return report;
        }
        let c = self.cfg;
        let age = age_s.max(0.0);
        let end = dist.count.min(MAX_LINKS);
        let to = to.min(end);
        let mut n = 0usize;
        let mut links = [0usize; MAX_LINKS];
        for l in from..end {
            // Beyond `to` (the end-effector links) only the floor holds them.
            if l >= to && !dist.floor[l] {
                continue;
            }
            let o = &dist.links[l];
            if !o.valid || o.distance >= c.slow_distance + age * c.max_obstacle_speed {
                continue;
            }
            if !dist.floor[l] && tool.is_some_and(|t| (o.robot_point - t).norm() < c.hand_radius) {
                continue;
            }
            let diff: Vector3<f64> = o.robot_point - o.obstacle_point;
            let norm = diff.norm();
            let u = if norm > 1e-3 && o.distance > 1e-3 {
                diff / norm
            } else {
                let nn = o.normal.norm();
                if nn < 1e-9 {
                    continue;
                }
                o.normal / nn
            };
            let closing = u.dot(&o.obstacle_velocity).clamp(0.0, c.max_obstacle_speed);
            let d_eff = o.distance - closing * age;
            let scene = dist.scene_object[l];
            if d_eff >= if scene { c.scene_slow_distance } else { c.slow_distance } {
                continue;
            }
            let in_link = poses.get(l).inverse_transform_point(&o.robot_point);
            model.position_jacobian(poses, l, &in_link, &mut self.pj);
            let j: JointVector = self.pj.transpose() * u;
            if j.norm_squared() < 1e-12 {
                continue;
            }
            self.rows[n] = j;
            self.bounds[n] = closing - self.allowed_approach_to(d_eff, scene);
            self.dist[n] = d_eff;
            links[n] = l;
            n += 1;
        }
        let lambda2 = c.damping * c.damping;
        for _ in 0..c.iterations.max(1) {
            let mut changed = false;
            for (k, j) in self.rows.iter().enumerate().take(n) {
                let mut deficit = self.bounds[k] - j.dot(qdot);
                if deficit <= 1e-9 {
                    continue;
                }
                changed = true;
                if let Some(n) = null_space.filter(|_| c.null_space_first) {
                    let nj: JointVector = n * j;
                    // Undamped down to λ²: a swivel that can meet the constraint meets all of it.
                    let mut step = nj * (deficit / j.dot(&nj).max(lambda2));
                    let size = step.norm();
                    if size > c.null_space_max_speed {
                        step *= c.null_space_max_speed / size;
                    }
                    let met = j.dot(&step);
                    if met > 0.0 {
                        *qdot += step;
                        deficit -= met;
                    }
                }
                if deficit > 1e-9 {
                    *qdot += j * (deficit / (j.norm_squared() + lambda2));
                    if deficit > report.correction_m_s {
                        report.correction_m_s = deficit;
                        report.link = Some(links[k]);
                        report.distance_m = self.dist[k];
                    }
                }
            }
            report.active |= changed;
            if !changed {
                break;
            }
        }
        report
    }
}
