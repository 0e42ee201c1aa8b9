//! `pizza-demo-left` / `pizza-demo-right`: imitation teaching of the whole pizza topping task
//! (thesis Sec. 5.2.4, Fig. 5.24) by one arm of a person wearing an Xsens suit. The bag holds
//! the person's skeleton (`/human/skeleton`, 120 Hz, 11 segments, `world` frame) and the words
//! the person says to the arm (`/speech_command`: `left: teach`, `left: gripper close`,
//! `left: gripper open`, `left: done`).
//!
//! The demonstration is built backwards through the retargeting of eq. 4.7
//! (`cowork_observer::Retargeter`): the robot arm's joint path is planned first (keyframe tool
//! positions → inverse kinematics on joints 1–4, joints 5–7 held at the scene's initial joints,
//! which move neither the elbow nor the wrist point; minimum-jerk joint-space moves), then the
//! person's upper arm and forearm are pointed along the robot's shoulder → elbow → wrist
//! directions turned into the person's sternum frame (`mount⁻¹`), at the person's own segment
//! lengths. Streaming the skeletons through the retargeter from the scene's initial joints gives
//! back the planned joints.
//!
//! Per ingredient (tomato, cheese, oil, basil): approach above it, down to the grasp (the tool
//! point `grasp_above_m` over the bottle's top), `gripper close`, lift, carry above the pizza,
//! down into the pizza's proximity sphere with the bottle tilted and its mouth over the pizza,
//! sprinkle (small tilting shakes), back up, carry back and down to the grasp configuration (the
//! bottle lands upright where it was taken), `gripper open`, retreat up. The robot manager cuts
//! this into FOA / NOA at the proximity spheres (r = 0.12 m around each object's surface) and
//! at the gripper commands; the planner checks that the tool is in no sphere but the intended
//! one at every keyframe and along the moves.

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::Skeleton;
use cowork_msgs::std_msgs::String as RosString;
use cowork_people::{
    Action, BodySize, MessageMeta, Performer, Segment, SegmentState, Side, SkeletonPose, Stance,
};
use cowork_robot::{DOF, JointVector, LinkPoses, RobotModel};
use cowork_sim::{Shape, Simulator};
use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::plan::min_jerk;
use crate::streams::{Streams, Ticker, rates, topics};
use crate::{Result, SynthError};

/// The ingredients, in the order they are demonstrated.
pub const INGREDIENTS: [&str; 4] = ["tomato", "cheese", "oil", "basil"];
/// The object the ingredients are sprinkled on.
pub const PIZZA: &str = "pizza";
/// Tracker id of the demonstrator.
pub const PERSON_ID: u32 = 1;
/// The scene frame of the skeletons (the pizza scenes name their arms).
pub const FRAME: &str = cowork_sim::WORLD_FRAME;
/// Joint speeds of the plan stay below this fraction of the URDF limits.
pub const SPEED_FRACTION: f64 = 0.45;
/// Joints 1–4 stay this far inside their limits, rad (12°).
pub const JOINT_MARGIN_RAD: f64 = 12.0 * std::f64::consts::PI / 180.0;
/// Every link mesh stays this far above the table top, m (the gripper links excepted near a
/// grasp or a put-down).
pub const LINK_CLEARANCE_M: f64 = 0.03;
/// The robot manager's proximity sphere radius around an object's surface, m (Table 5.3).
pub const PROXIMITY_RADIUS_M: f64 = 0.12;
/// The tool keeps this far from a sphere's boundary at the keyframes, m: inside points are at
/// most `r − margin` from the object, outside points at least `r + margin`.
pub const SPHERE_MARGIN_M: f64 = 0.02;
/// The approach / lift point is this far forward (+x) of the grasp, m: straight above it the
/// elbow would fold past its margin for the nearer bottles.
const APPROACH_FORWARD_M: f64 = 0.06;
/// The tool crosses no sphere it should not along a move by less than this, m.
const PATH_MARGIN_M: f64 = 0.01;
/// The held bottle's lowest point above the pizza top while sprinkling, m (0.05–0.20 asked).
pub const HOLD_BOTTOM_RANGE_M: (f64, f64) = (0.05, 0.20);
/// The held bottle's centre within this of the pizza's centre in x-y while sprinkling, m.
pub const HOLD_CENTRE_RADIUS_M: f64 = 0.08;

/// The demonstrating arm: the robot arm of that name in the scene, driven by the person's arm
/// of the same side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DemoArm {
    /// Arm `left`, the person's left arm.
    Left,
    /// Arm `right`, the person's right arm.
    Right,
}

impl DemoArm {
    /// The scene's arm name (`left` / `right`), also the prefix of the spoken words.
    pub fn name(self) -> &'static str {
        match self {
            DemoArm::Left => "left",
            DemoArm::Right => "right",
        }
    }

    /// The person's arm that demonstrates.
    pub fn side(self) -> Side {
        match self {
            DemoArm::Left => Side::Left,
            DemoArm::Right => Side::Right,
        }
    }

    /// The scene file the scenario runs in (`config/scenes/`).
    pub fn scene_file(self) -> &'static str {
        match self {
            DemoArm::Left => "pizza-teach-left.yaml",
            DemoArm::Right => "pizza-teach-right.yaml",
        }
    }

    fn scenario(self) -> &'static str {
        match self {
            DemoArm::Left => "pizza-demo-left",
            DemoArm::Right => "pizza-demo-right",
        }
    }
}

/// How the scripted demonstrator performs: pace, grasp, heights, pauses, path noise. The
/// default is the bundled teacher; [`PizzaStyle::from_seed`] draws another one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PizzaStyle {
    /// Multiplies every move's nominal duration (> 1: slower).
    pub pace: f64,
    /// Tool point over the bottle's top at the grasp, m (within the 5 cm grasp reach).
    pub grasp_above_m: f64,
    /// Approach / lift point above the grasp, m (outside the bottle's proximity sphere).
    pub approach_height_m: f64,
    /// The bottle's lowest point above the pizza top while sprinkling, m.
    pub hold_bottom_m: f64,
    /// Tilt of the bottle while sprinkling, rad.
    pub tilt_rad: f64,
    /// Offset of the bottle's mouth from the pizza centre while sprinkling (x, y), m.
    pub hold_offset_m: [f64; 2],
    /// Still time before and after each gripper command, s.
    pub pause_s: f64,
    /// Sprinkling shakes (each a tilt up and back).
    pub shakes: u32,
    /// Height of a shake (the tool up and back), m.
    pub shake_m: f64,
    /// Amplitude of the noise added to the free via points (approach, lift, over the pizza), m.
    pub path_noise_m: f64,
    /// The demonstrator's standing height, m.
    pub body_height_m: f64,
    /// Seed of the path noise and of the person's postural sway.
    pub seed: u64,
}

impl Default for PizzaStyle {
    fn default() -> Self {
        Self {
            pace: 1.0,
            grasp_above_m: 0.02,
            approach_height_m: 0.17,
            hold_bottom_m: 0.06,
            tilt_rad: 1.5,
            hold_offset_m: [0.0, 0.0],
            pause_s: 0.6,
            shakes: 3,
            shake_m: 0.015,
            path_noise_m: 0.0,
            body_height_m: BodySize::MEDIUM.height,
            seed: 0,
        }
    }
}

impl PizzaStyle {
    /// Seed 0: the bundled teacher ([`Default`]); another seed: pace ×0.85–1.2, grasp 1–3 cm
    /// over the top, approach from 16–19 cm, bottle 5.5–7 cm over the pizza, tilt 1.4–1.55 rad,
    /// mouth ±2.5 cm from the centre, pauses 0.4–0.9 s, 2–4 shakes, via points ±1.5 cm, a person
    /// of 1.60–1.88 m.
    pub fn from_seed(seed: u64) -> Self {
        if seed == 0 {
            return Self::default();
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7069_7a7a_615f_6465);
        Self {
            pace: rng.random_range(0.85..1.2),
            grasp_above_m: rng.random_range(0.01..0.03),
            approach_height_m: rng.random_range(0.16..0.19),
            hold_bottom_m: rng.random_range(0.055..0.07),
            tilt_rad: rng.random_range(1.4..1.55),
            hold_offset_m: [
                rng.random_range(-0.025..0.025),
                rng.random_range(-0.025..0.025),
            ],
            pause_s: rng.random_range(0.4..0.9),
            shakes: rng.random_range(2..=4),
            shake_m: rng.random_range(0.01..0.02),
            path_noise_m: 0.015,
            body_height_m: rng.random_range(1.60..1.88),
            seed,
        }
    }
}

/// One minimum-jerk joint move, at rest at both ends.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Move {
    t0: f64,
    duration: f64,
    from: JointVector,
    to: JointVector,
}

/// What happened to one ingredient in the plan.
#[derive(Debug, Clone, PartialEq)]
pub struct IngredientPlan {
    /// Object name.
    pub name: String,
    /// Its pose when taken (and where it is put back), scene frame.
    pub taken: Isometry3<f64>,
    /// Joints at the grasp (and at the put-down), rad.
    pub grasp_joints: JointVector,
    /// Time of `gripper close`, s.
    pub close_s: f64,
    /// Time window of the sprinkling (the bottle at its hold pose), s.
    pub hold_window: (f64, f64),
    /// Tilt of the bottle from upright while sprinkling (at the hold keyframe), rad.
    pub hold_tilt_rad: f64,
    /// Time of `gripper open`, s.
    pub open_s: f64,
}

/// A planned demonstration: the robot arm's joint path, the speech, and what it does.
#[derive(Debug, Clone)]
pub struct PizzaPlan {
    /// The demonstrating arm.
    pub arm: DemoArm,
    /// Its index in the simulator.
    pub arm_index: usize,
    /// The style it was planned with.
    pub style: PizzaStyle,
    start: JointVector,
    moves: Vec<Move>,
    /// Speech: (time s, words with the arm prefix).
    pub speech: Vec<(f64, String)>,
    /// Per ingredient, in demonstration order.
    pub ingredients: Vec<IngredientPlan>,
    /// Length of the demonstration, s.
    pub duration_s: f64,
}

impl PizzaPlan {
    /// Joint positions (rad) of the robot arm at `t` s (the start before 0, the end after the
    /// last move).
    pub fn joints_at(&self, t: f64) -> JointVector {
        let i = self.moves.partition_point(|m| m.t0 + m.duration < t);
        match self.moves.get(i) {
            Some(m) if t >= m.t0 => {
                let (s, _) = min_jerk((t - m.t0) / m.duration);
                m.from + (m.to - m.from) * s
            }
            Some(m) => m.from,
            None => self.moves.last().map_or(self.start, |m| m.to),
        }
    }

    /// Joint velocities (rad/s) of the plan at `t` s.
    pub fn velocities_at(&self, t: f64) -> JointVector {
        let i = self.moves.partition_point(|m| m.t0 + m.duration < t);
        match self.moves.get(i) {
            Some(m) if t >= m.t0 => {
                let (_, ds) = min_jerk((t - m.t0) / m.duration);
                (m.to - m.from) * (ds / m.duration)
            }
            _ => JointVector::zeros(),
        }
    }
}

fn plan_error(arm: DemoArm, reason: String) -> SynthError {
    SynthError::Plan {
        scenario: arm.scenario(),
        reason,
    }
}

/// Forward kinematics of one arm in the scene frame with joints 5–7 held.
#[derive(Debug, Clone)]
pub(crate) struct ArmKin<'m> {
    model: &'m RobotModel,
    base: Isometry3<f64>,
    held: JointVector,
    limits: [(f64, f64); 4],
    /// A subset of each link mesh's vertices, link frame (none for a link without a mesh).
    corners: Vec<Vec<Point3<f64>>>,
}

/// The four planned joints (1–4), rad.
type Q4 = [f64; 4];

impl<'m> ArmKin<'m> {
    fn new(model: &'m RobotModel, base: Isometry3<f64>, q0: JointVector) -> Self {
        let l = model.joint_limits();
        // Every 4th mesh vertex: the lowest point to within a few mm, at a quarter of the cost.
        let corners = (0..model.link_count())
            .map(|link| {
                model.link_mesh(link).map_or_else(Vec::new, |m| {
                    m.vertices.iter().step_by(4).copied().collect()
                })
            })
            .collect();
        Self {
            model,
            base,
            held: q0,
            limits: [0, 1, 2, 3].map(|i| (l[i].lower, l[i].upper)),
            corners,
        }
    }

    fn full(&self, a: &Q4) -> JointVector {
        let mut q = self.held;
        q.fixed_rows_mut::<4>(0).copy_from_slice(a);
        q
    }

    fn poses(&self, a: &Q4) -> LinkPoses {
        let mut p = LinkPoses::new();
        self.model.forward_kinematics(&self.full(a), &mut p);
        p
    }

    /// Tool pose, scene frame.
    fn tool(&self, a: &Q4) -> Isometry3<f64> {
        self.base * self.poses(a).get(self.model.tip_link())
    }

    /// Lowest point (scene z, m) of the meshes of links `links`.
    fn lowest(&self, poses: &LinkPoses, links: std::ops::Range<usize>) -> f64 {
        links
            .filter_map(|l| {
                let m = self.model.link_mesh(l)?;
                let pose = self.base * poses.get(l);
                m.vertices.iter().map(|v| (pose * v).z).reduce(f64::min)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Links that are the gripper (exempt from the table clearance at a grasp): link 7 and on.
    fn gripper_links(&self) -> usize {
        self.model.joint_link(6)
    }
}

/// A Levenberg–Marquardt least-squares solve over joints 1–4 with numeric Jacobians.
fn solve(residual: &dyn Fn(&Q4, &mut Vec<f64>), a0: Q4, iterations: usize) -> (Q4, f64) {
    let mut a = a0;
    let mut r = Vec::new();
    residual(&a, &mut r);
    let mut cost: f64 = r.iter().map(|v| v * v).sum();
    let mut lambda = 1e-3;
    let (mut rp, mut rm) = (Vec::new(), Vec::new());
    for _ in 0..iterations {
        let n = r.len();
        let mut jac = vec![[0.0; 4]; n];
        for k in 0..4 {
            let h = 1e-6;
            let (mut ap, mut am) = (a, a);
            ap[k] += h;
            am[k] -= h;
            residual(&ap, &mut rp);
            residual(&am, &mut rm);
            for i in 0..n {
                jac[i][k] = (rp[i] - rm[i]) / (2.0 * h);
            }
        }
        let mut jtj = nalgebra::Matrix4::<f64>::zeros();
        let mut jtr = nalgebra::Vector4::<f64>::zeros();
        for i in 0..n {
            for p in 0..4 {
                jtr[p] += jac[i][p] * r[i];
                for q in 0..4 {
                    jtj[(p, q)] += jac[i][p] * jac[i][q];
                }
            }
        }
        let mut improved = false;
        for _ in 0..12 {
            let mut m = jtj;
            for p in 0..4 {
                m[(p, p)] += lambda * (1.0 + jtj[(p, p)]);
            }
            let Some(step) = m.lu().solve(&(-jtr)) else {
                break;
            };
            let cand = [
                a[0] + step[0],
                a[1] + step[1],
                a[2] + step[2],
                a[3] + step[3],
            ];
            residual(&cand, &mut rp);
            let c: f64 = rp.iter().map(|v| v * v).sum();
            if c < cost {
                a = cand;
                std::mem::swap(&mut r, &mut rp);
                let gain = cost - c;
                cost = c;
                lambda = (lambda * 0.3).max(1e-9);
                improved = gain > 1e-16;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    (a, cost)
}

/// Penalties shared by every keyframe: joints inside their limits by [`JOINT_MARGIN_RAD`],
/// non-gripper links above the table by [`LINK_CLEARANCE_M`] (+1 cm), the elbow bent.
fn keep_safe(kin: &ArmKin<'_>, a: &Q4, poses: &LinkPoses, r: &mut Vec<f64>) {
    for (i, (lo, hi)) in kin.limits.iter().enumerate() {
        let over =
            (a[i] - (hi - JOINT_MARGIN_RAD)).max(0.0) + ((lo + JOINT_MARGIN_RAD) - a[i]).max(0.0);
        r.push(10.0 * over);
    }
    // Keep the elbow bent (joint 4 away from 0: the retargeting of a straight arm is singular).
    r.push(10.0 * (0.35 - a[3].abs()).max(0.0));
    // The (sampled) meshes of the non-gripper links clear the table by LINK_CLEARANCE_M + 5 mm.
    for (l, corners) in kin
        .corners
        .iter()
        .enumerate()
        .take(kin.gripper_links())
        .skip(1)
    {
        let pose = kin.base * poses.get(l);
        let z = corners
            .iter()
            .map(|c| (pose * c).z)
            .fold(f64::INFINITY, f64::min);
        r.push(30.0 * (LINK_CLEARANCE_M + 0.005 - z).max(0.0));
    }
}

/// Height of a shape along its z axis, m.
fn shape_height(shape: &Shape) -> f64 {
    match *shape {
        Shape::Box { size } => size[2],
        Shape::Cylinder { height, .. } => height,
        Shape::Sphere { radius } => 2.0 * radius,
    }
}

/// Radius of a shape's footprint (the half diagonal of a box), m.
fn shape_radius(shape: &Shape) -> f64 {
    match *shape {
        Shape::Box { size } => 0.5 * size[0].hypot(size[1]),
        Shape::Cylinder { radius, .. } | Shape::Sphere { radius } => radius,
    }
}

/// Lowest point (z, m) of an upright-symmetric shape of height `h` and radius `r` at `pose`.
fn lowest_point(pose: &Isometry3<f64>, h: f64, r: f64) -> f64 {
    let axis = pose.rotation * Vector3::z();
    pose.translation.vector.z - 0.5 * h * axis.z.abs() - r * (1.0 - axis.z * axis.z).max(0.0).sqrt()
}

/// Rotation error `from → to` as a scaled axis, rad.
fn rotation_error(from: &UnitQuaternion<f64>, to: &UnitQuaternion<f64>) -> Vector3<f64> {
    (to * from.inverse()).scaled_axis()
}

/// Where the tool may be while a move runs: inside the sphere of at most this object (the
/// others' spheres are kept out of by [`PATH_MARGIN_M`]); `held` has no sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Zone {
    allowed: Option<usize>,
    held: Option<usize>,
    /// The gripper links may come near the table (grasp, put-down).
    near_table: bool,
}

/// The planner's working state.
struct Planner<'a> {
    arm: DemoArm,
    kin: ArmKin<'a>,
    sim: &'a Simulator,
    style: PizzaStyle,
    rng: ChaCha8Rng,
    t: f64,
    current: Q4,
    moves: Vec<Move>,
    zones: Vec<Zone>,
    speech: Vec<(f64, String)>,
}

impl Planner<'_> {
    fn err(&self, reason: String) -> SynthError {
        plan_error(self.arm, reason)
    }

    /// A minimum-jerk move to `to` of nominal length `nominal` s (× pace), stretched so that
    /// no joint exceeds [`SPEED_FRACTION`] of its speed limit (peak speed 1.875 Δq / T).
    fn move_to(&mut self, to: Q4, nominal: f64, zone: Zone) {
        let limits = self.kin.model.joint_limits();
        let mut duration = nominal * self.style.pace;
        for i in 0..4 {
            let need =
                1.875 * (to[i] - self.current[i]).abs() / (SPEED_FRACTION * limits[i].velocity);
            duration = duration.max(need);
        }
        let duration = (duration * 1e3).ceil() * 1e-3;
        self.moves.push(Move {
            t0: self.t,
            duration,
            from: self.kin.full(&self.current),
            to: self.kin.full(&to),
        });
        self.zones.push(zone);
        self.t += duration;
        self.current = to;
    }

    fn hold(&mut self, s: f64) {
        self.t += s;
    }

    fn say(&mut self, words: &str) {
        let t = (self.t * 1e3).round() * 1e-3;
        self.speech
            .push((t, format!("{}: {words}", self.arm.name())));
    }

    fn noise(&mut self) -> Vector3<f64> {
        let a = self.style.path_noise_m;
        if a <= 0.0 {
            return Vector3::zeros();
        }
        Vector3::new(
            self.rng.random_range(-a..a),
            self.rng.random_range(-a..a),
            self.rng.random_range(0.0..a),
        )
    }

    /// Tool point at `target` (scene frame) with the tool turned as `orientation` (weight
    /// `w_rot` per rad), near the posture `posture`, from `start`.
    fn reach(
        &self,
        target: Vector3<f64>,
        orientation: &UnitQuaternion<f64>,
        w_rot: f64,
        posture: Q4,
        start: Q4,
    ) -> (Q4, f64) {
        let kin = &self.kin;
        let tip = kin.model.tip_link();
        let f = |q: &Q4, r: &mut Vec<f64>| {
            r.clear();
            let p = kin.poses(q);
            let t = kin.base * p.get(tip);
            r.extend((t.translation.vector - target).iter().map(|v| 10.0 * v));
            r.extend(
                rotation_error(&t.rotation, orientation)
                    .iter()
                    .map(|v| w_rot * v),
            );
            r.extend((0..4).map(|i| 0.02 * (q[i] - posture[i])));
            keep_safe(kin, q, &p, r);
        };
        let (q, _) = solve(&f, start, 300);
        let miss = (self.kin.tool(&q).translation.vector - target).norm();
        (q, miss)
    }

    fn object(&self, name: &str) -> Result<usize> {
        self.sim.objects().iter().position(|o| o.name == name).ok_or_else(|| {
            self.err(format!("the scene has no object `{name}` (the pizza teaching scenes have pizza, tomato, cheese, oil and basil)"))
        })
    }
}

/// Plans the demonstration of `arm` in `sim`'s scene (a scene with the named arms `left` and
/// `right`, a pizza and the four ingredients) as `style` performs it.
pub fn plan_demo(sim: &Simulator, arm: DemoArm, style: &PizzaStyle) -> Result<PizzaPlan> {
    if !sim.scene().has_named_arms() {
        return Err(plan_error(arm, "the scene has no named arms (`arms:` with `left` and `right`, as config/scenes/pizza.yaml)".into()));
    }
    let Some(arm_index) = sim.arm_index(arm.name()) else {
        let names: Vec<&str> = sim.arms().iter().map(|a| a.name()).collect();
        return Err(plan_error(
            arm,
            format!(
                "the scene has no arm `{}` (arms: {})",
                arm.name(),
                names.join(", ")
            ),
        ));
    };
    let a = sim.arm(arm_index);
    let q0 = *a.joint_positions();
    let kin = ArmKin::new(sim.model(), *a.base(), q0);
    let a0: Q4 = [q0[0], q0[1], q0[2], q0[3]];
    let mut p = Planner {
        arm,
        kin,
        sim,
        style: *style,
        rng: ChaCha8Rng::seed_from_u64(style.seed ^ 0x7061_7468),
        t: 0.0,
        current: a0,
        moves: Vec::new(),
        zones: Vec::new(),
        speech: Vec::new(),
    };
    let pizza_i = p.object(PIZZA)?;
    let pizza = &sim.objects()[pizza_i];
    let pizza_top = pizza.pose.translation.vector.z + 0.5 * shape_height(&pizza.shape);
    let pizza_r = shape_radius(&pizza.shape);
    let pizza_c = pizza.pose.translation.vector;
    let tip = sim.model().tip_link();
    let free = Zone {
        allowed: None,
        held: None,
        near_table: false,
    };

    p.hold(1.0);
    p.say("teach");
    p.hold(0.5 * style.pace);
    let mut ingredients = Vec::new();
    for name in INGREDIENTS {
        let oi = p.object(name)?;
        let obj = &sim.objects()[oi];
        if !obj.graspable {
            return Err(p.err(format!("`{name}` is not graspable in the scene")));
        }
        let (h, r) = (shape_height(&obj.shape), shape_radius(&obj.shape));
        let taken = obj.pose;
        let top = taken * Point3::new(0.0, 0.0, 0.5 * h);
        // Grasp: the tool point over the top, the tool as close to pointing down as joints
        // 1-4 allow, near the initial posture.
        let down = UnitQuaternion::rotation_between(
            &(p.kin.tool(&a0).rotation * Vector3::z()),
            &-Vector3::z(),
        )
        .unwrap_or_else(UnitQuaternion::identity)
            * p.kin.tool(&a0).rotation;
        let grasp_at = top.coords + Vector3::new(0.0, 0.0, style.grasp_above_m);
        let (qg, miss) = p.reach(grasp_at, &down, 1.0, a0, p.current);
        let tool_g = p.kin.tool(&qg);
        let reach_d = obj.distance_to(&Point3::from(tool_g.translation.vector));
        if reach_d > sim.params().grasp_reach_m - 0.01 {
            return Err(p.err(format!(
                "`{name}` at {:?} cannot be grasped by arm `{}`: the tool comes to {:.3} m of it (grasp reach {} m; IK miss {miss:.3} m)",
                taken.translation.vector.as_slice(),
                arm.name(),
                reach_d,
                sim.params().grasp_reach_m
            )));
        }
        let noise = p.noise();
        let (qpre, miss) = p.reach(
            grasp_at + Vector3::new(APPROACH_FORWARD_M, 0.0, style.approach_height_m) + noise,
            &tool_g.rotation,
            0.3,
            qg,
            qg,
        );
        if miss > 0.02 {
            return Err(p.err(format!(
                "the approach above `{name}` is out of reach of arm `{}` ({miss:.3} m)",
                arm.name()
            )));
        }
        // Approach and take.
        p.move_to(qpre, 2.5, free);
        p.move_to(
            qg,
            1.8,
            Zone {
                allowed: Some(oi),
                held: None,
                near_table: true,
            },
        );
        p.hold(style.pause_s);
        let close_s = p.t;
        p.say("gripper close");
        p.hold(style.pause_s);
        let held = Zone {
            allowed: None,
            held: Some(oi),
            near_table: true,
        };
        p.move_to(qpre, 1.5, held);
        // Above the pizza, the bottle upright, outside the pizza's sphere.
        let grip = tool_g.inverse() * taken;
        let mouth_at = Vector3::new(
            pizza_c.x + style.hold_offset_m[0],
            pizza_c.y + style.hold_offset_m[1],
            0.0,
        );
        let over_at =
            mouth_at + Vector3::new(0.0, 0.0, pizza_top + PROXIMITY_RADIUS_M + 0.16) + p.noise();
        let (qover, miss) = p.reach(over_at, &tool_g.rotation, 1.0, qpre, qpre);
        if miss > 0.03 {
            return Err(p.err(format!(
                "the point above the pizza is out of reach of arm `{}` with `{name}` ({miss:.3} m)",
                arm.name()
            )));
        }
        let carry = Zone {
            allowed: None,
            held: Some(oi),
            near_table: false,
        };
        p.move_to(qover, 2.5, carry);
        // Sprinkling: tilted, the mouth over the pizza, the bottle's lowest point
        // `hold_bottom_m` over it, the tool inside the pizza's sphere.
        let kin = &p.kin;
        let target_low = pizza_top + style.hold_bottom_m;
        let tool_in = PROXIMITY_RADIUS_M - SPHERE_MARGIN_M - 0.005;
        let f = |q: &Q4, res: &mut Vec<f64>| {
            res.clear();
            let poses = kin.poses(q);
            let t = kin.base * poses.get(tip);
            let o = t * grip;
            let axis = o.rotation * Vector3::z();
            let mouth = o * Point3::new(0.0, 0.0, 0.5 * h);
            let c = o.translation.vector;
            res.push(10.0 * (c.x - mouth_at.x));
            res.push(10.0 * (c.y - mouth_at.y));
            res.push(
                30.0 * ((mouth.x - pizza_c.x).hypot(mouth.y - pizza_c.y) - (pizza_r - 0.04))
                    .max(0.0),
            );
            let low = lowest_point(&o, h, r);
            res.push(10.0 * (low - target_low));
            res.push(50.0 * (pizza_top + HOLD_BOTTOM_RANGE_M.0 + 0.008 - low).max(0.0));
            res.push(2.0 * (axis.z - style.tilt_rad.cos()));
            res.push(
                50.0 * (pizza.distance_to(&Point3::from(t.translation.vector)) - tool_in).max(0.0),
            );
            res.extend((0..4).map(|i| 0.02 * (q[i] - qover[i])));
            keep_safe(kin, q, &poses, res);
        };
        let mut best: Option<(Q4, f64)> = None;
        for start in [
            qover,
            qg,
            [qover[0], qover[1], qover[2] - 0.8, qover[3]],
            [qover[0], qover[1], qover[2] + 0.8, qover[3]],
        ] {
            let (q, c) = solve(&f, start, 400);
            if best.is_none_or(|b| c < b.1) {
                best = Some((q, c));
            }
        }
        let Some((qhold, _)) = best else {
            return Err(p.err("no sprinkling pose".into()));
        };
        let tool_h = p.kin.tool(&qhold);
        let bottle_h = tool_h * grip;
        let tilt = (bottle_h.rotation * Vector3::z()).angle(&Vector3::z());
        let low = lowest_point(&bottle_h, h, r) - pizza_top;
        let centre_off = (bottle_h.translation.vector.xy() - pizza_c.xy()).norm();
        let tool_d = pizza.distance_to(&Point3::from(tool_h.translation.vector));
        if !(HOLD_BOTTOM_RANGE_M.0 + 0.003..=HOLD_BOTTOM_RANGE_M.1).contains(&low)
            || centre_off > HOLD_CENTRE_RADIUS_M - 0.01
            || tool_d > PROXIMITY_RADIUS_M - 0.015
        {
            return Err(p.err(format!(
                "arm `{}` cannot hold `{name}` over the pizza: lowest point {low:.3} m over it, centre {centre_off:.3} m off, tool {tool_d:.3} m from it",
                arm.name()
            )));
        }
        let near_pizza = Zone {
            allowed: Some(pizza_i),
            held: Some(oi),
            near_table: false,
        };
        p.move_to(qhold, 1.8, near_pizza);
        let hold_start = p.t;
        p.hold(0.3 * style.pace);
        for k in 0..style.shakes {
            let side = if k % 2 == 0 { 1.0 } else { -1.0 };
            let up = tool_h.translation.vector + Vector3::new(0.0, side * 0.008, style.shake_m);
            let (qup, _) = p.reach(up, &tool_h.rotation, 3.0, qhold, qhold);
            p.move_to(qup, 0.35, near_pizza);
            p.move_to(qhold, 0.35, near_pizza);
        }
        p.hold(0.3 * style.pace);
        let hold_end = p.t;
        p.move_to(qover, 1.5, near_pizza);
        // Back where it was taken: the grasp configuration puts it back upright.
        p.move_to(qpre, 2.5, carry);
        p.move_to(qg, 1.8, held);
        p.hold(style.pause_s);
        let open_s = p.t;
        p.say("gripper open");
        p.hold(style.pause_s);
        p.move_to(
            qpre,
            1.5,
            Zone {
                allowed: Some(oi),
                held: None,
                near_table: true,
            },
        );
        ingredients.push(IngredientPlan {
            name: name.to_owned(),
            taken,
            grasp_joints: p.kin.full(&qg),
            close_s,
            hold_window: (hold_start, hold_end),
            hold_tilt_rad: tilt,
            open_s,
        });
    }
    p.move_to(a0, 2.5, free);
    p.hold(1.0);
    p.say("done");
    p.hold(0.5);
    let plan = PizzaPlan {
        arm,
        arm_index,
        style: *style,
        start: q0,
        moves: p.moves.clone(),
        speech: p.speech.clone(),
        ingredients,
        duration_s: (p.t * 1e3).round() * 1e-3,
    };
    check_plan(&p, &plan, pizza_i)?;
    Ok(plan)
}

/// Checks the planned path every 10 ms: joints inside their margins, links above the table,
/// the tool in no proximity sphere but the one the move may enter.
fn check_plan(p: &Planner<'_>, plan: &PizzaPlan, pizza_i: usize) -> Result<()> {
    let sim = p.sim;
    let tip = sim.model().tip_link();
    let limits = sim.model().joint_limits();
    let gripper = p.kin.gripper_links();
    let mut held_pose: Option<(usize, Isometry3<f64>)> = None;
    for (m, zone) in plan.moves.iter().zip(&p.zones) {
        let steps = (m.duration / 0.01).ceil() as usize;
        for k in 0..=steps {
            let t = m.t0 + m.duration * k as f64 / steps as f64;
            let q = plan.joints_at(t);
            for i in 0..DOF {
                if q[i] < limits[i].lower + JOINT_MARGIN_RAD - 0.02
                    || q[i] > limits[i].upper - JOINT_MARGIN_RAD + 0.02
                {
                    return Err(p.err(format!(
                        "joint {} reaches {:.1} deg at {t:.2} s (limits ±{:.0} deg, 10 deg margin)",
                        i + 1,
                        q[i].to_degrees(),
                        limits[i].upper.to_degrees()
                    )));
                }
            }
            let a: Q4 = [q[0], q[1], q[2], q[3]];
            let poses = p.kin.poses(&a);
            let low = p.kin.lowest(&poses, 1..gripper);
            let low_gripper = p.kin.lowest(&poses, gripper..sim.model().link_count());
            let floor = sim.scene().table_top_z() + LINK_CLEARANCE_M;
            if low < floor
                || (!zone.near_table && low_gripper < floor)
                || low_gripper < sim.scene().table_top_z() + 0.005
            {
                return Err(p.err(format!(
                    "a link comes {:.3} m (gripper {:.3} m) over the table at {t:.2} s",
                    low, low_gripper
                )));
            }
            let tool = p.kin.base * poses.get(tip);
            let tp = Point3::from(tool.translation.vector);
            if zone.held.is_some() && held_pose.is_none_or(|(i, _)| Some(i) != zone.held) {
                let i = zone.held.unwrap_or(0);
                held_pose = Some((i, tool.inverse() * sim.objects()[i].pose));
            }
            for (i, o) in sim.objects().iter().enumerate() {
                if Some(i) == zone.held || Some(i) == zone.allowed {
                    continue;
                }
                let d = o.distance_to(&tp);
                if d < PROXIMITY_RADIUS_M + PATH_MARGIN_M {
                    return Err(p.err(format!(
                        "at {t:.2} s the tool passes {d:.3} m from `{}` (its proximity sphere is {PROXIMITY_RADIUS_M} m: the robot manager would cut a segment there)",
                        o.name
                    )));
                }
            }
            let _ = pizza_i;
        }
    }
    Ok(())
}

/// The demonstrator: a standing person at the robot torso's place, facing +x, whose `side` arm
/// is set from the plan at every instant.
#[derive(Debug)]
pub struct Demonstrator<'a> {
    plan: &'a PizzaPlan,
    model: &'a RobotModel,
    performer: Performer,
    mount_inv: UnitQuaternion<f64>,
    lengths: (f64, f64, f64),
}

/// Roll, pitch, yaw (rad) of the person's sternum frame in the base frame of arm `base`: the
/// inverse of the base's rotation in the scene (the graph's `mount_rpy` for the pizza arms).
pub fn mount_rpy(base: &Isometry3<f64>) -> [f64; 3] {
    let (r, p, y) = base.rotation.inverse().euler_angles();
    [r, p, y]
}

impl<'a> Demonstrator<'a> {
    /// The person of `plan.style` for `plan` in `sim`'s scene.
    pub fn new(sim: &'a Simulator, plan: &'a PizzaPlan, extra_s: f64) -> Result<Self> {
        let body = BodySize::new(plan.style.body_height_m)?;
        let performer = Performer::new(
            PERSON_ID,
            body,
            Stance::new(-0.15, 0.0, 0.0),
            plan.style.seed,
        )?
        .then(Action::Stand {
            duration: plan.duration_s + extra_s + 1.0,
        })?;
        let base = *sim.arm(plan.arm_index).base();
        let [r, p, y] = mount_rpy(&base);
        let l = body.lengths();
        Ok(Self {
            plan,
            model: sim.model(),
            performer,
            mount_inv: UnitQuaternion::from_euler_angles(r, p, y).inverse(),
            lengths: (l.upper_arm, l.forearm, l.hand),
        })
    }

    /// Shoulder, elbow, wrist, hand segments of the demonstrating arm at `t` given the sternum
    /// orientation and the shoulder point.
    fn arm(
        &self,
        t: f64,
        sternum: &UnitQuaternion<f64>,
        shoulder: &Point3<f64>,
    ) -> [SegmentState; 4] {
        let q = self.plan.joints_at(t);
        let mut poses = LinkPoses::new();
        self.model.forward_kinematics(&q, &mut poses);
        let at = |l: usize| poses.get(self.model.joint_link(l)).translation.vector;
        let (s, e, w) = (at(1), at(3), at(5));
        let turn = sternum * self.mount_inv;
        let ua = turn * (e - s).normalize();
        let uf = turn * (w - e).normalize();
        let (la, lf, lh) = self.lengths;
        let elbow = shoulder + la * ua;
        let wrist = elbow + lf * uf;
        let hand = wrist + 0.5 * lh * uf;
        let fallback = sternum * Vector3::x();
        let frame = |limb: Vector3<f64>, reference: Vector3<f64>| {
            let z = -limb;
            let mut x = reference - z * reference.dot(&z);
            if x.norm() < 1e-6 {
                x = fallback - z * fallback.dot(&z);
            }
            let x = x.normalize();
            let y = z.cross(&x);
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
                Matrix3::from_columns(&[x, y, z]),
            ))
        };
        let upper = frame(ua, uf);
        let fore = frame(uf, -ua);
        let state = |position: Point3<f64>, orientation| SegmentState {
            position,
            orientation,
            ..SegmentState::default()
        };
        [
            state(*shoulder, upper),
            state(elbow, fore),
            state(wrist, fore),
            state(hand, fore),
        ]
    }

    /// The pose at `t` s: the standing person with the demonstrating arm from the plan;
    /// velocities by central differences over ±0.5 ms.
    pub fn pose(&self, t: f64) -> SkeletonPose {
        let mut pose = self.performer.pose(t);
        let segs = Segment::arm(self.plan.arm.side());
        let h = 5e-4;
        let around = |dt: f64| {
            let p = self.performer.pose(t + dt);
            let st = p.segment(Segment::Sternum).orientation;
            self.arm(t + dt, &st, &p.position(segs[0]))
        };
        let (before, now, after) = (around(-h), around(0.0), around(h));
        for k in 0..4 {
            let mut s = now[k];
            s.linear_velocity = (after[k].position - before[k].position) / (2.0 * h);
            s.angular_velocity =
                (after[k].orientation * before[k].orientation.inverse()).scaled_axis() / (2.0 * h);
            pose.segments[segs[k].index()] = s;
        }
        pose
    }
}

/// Writes the bag of `plan` (skeletons at 120 Hz, speech, `/clock` at 100 Hz) of length
/// `duration_s` (≥ the plan's; the person stands still after `done`).
pub(crate) fn write_demo(
    sim: &Simulator,
    plan: &PizzaPlan,
    path: &std::path::Path,
    duration_s: f64,
    progress: &mut dyn FnMut(f64),
) -> Result<std::collections::BTreeMap<String, u64>> {
    let person = Demonstrator::new(sim, plan, duration_s - plan.duration_s)?;
    let mut streams = Streams::create(path, sim)?;
    let mut clock = Ticker::new(rates::CLOCK_HZ);
    let mut xsens = Ticker::new(rates::XSENS_HZ);
    let mut speech = plan.speech.iter().peekable();
    let end_ns = (duration_s * 1e9).round() as i64;
    let mut msg = Skeleton::default();
    let mut now = 0_i64;
    let mut next_report = 0_i64;
    while now <= end_ns {
        while let Some(t) = clock.due(now) {
            streams.clock(t)?;
        }
        while let Some(t) = xsens.due(now) {
            let pose = person.pose(t as f64 * 1e-9);
            let meta = MessageMeta {
                stamp: Time::from_nanos(t),
                frame_id: FRAME,
                source: Skeleton::SOURCE_XSENS,
                person_id: PERSON_ID,
                with_velocities: true,
            };
            pose.write_message(&meta, &mut msg);
            streams.write(topics::SKELETON, t, &msg)?;
        }
        while let Some((at, words)) = speech.next_if(|(at, _)| (at * 1e9).round() as i64 <= now) {
            let t = (at * 1e9).round() as i64;
            streams.write(
                topics::SPEECH,
                t,
                &RosString {
                    data: words.clone(),
                },
            )?;
        }
        if now >= next_report {
            progress(now as f64 / end_ns.max(1) as f64);
            next_report += 1_000_000_000;
        }
        now += 1_000_000;
    }
    streams.finish()
}
