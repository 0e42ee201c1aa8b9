//! The named experiments (thesis Fig. 5.3–5.7, Sec. 5.1.3) and their `--key value` options.

use std::collections::BTreeMap;

use cowork_ds::primitive::ConstantSpeed;
use cowork_ds::{ControllerConfig, HumanMode, HumanState, Primitive};
use cowork_robot::{JointVector, RobotModel};
use cowork_sim::SceneObject;
use nalgebra::{Point3, Vector3};

use crate::error::{Error, Result};
use crate::obstacle::{Obstacle, open_box};
use crate::person::{Person, Track};
use crate::runner::{Goal, Setup, Start, StaticWorld, World, tcp};

/// Names of the scenarios, as `cowork scenario NAME` takes them.
pub const NAMES: [&str; 6] =
    ["three-obstacles", "box-in-out", "moving-sphere-hold", "moving-sphere-reach", "hand-hit", "stacking-human"];

/// `--key value` options of a scenario; every key must be used by the scenario, or building
/// it fails naming the key.
#[derive(Debug, Clone, Default)]
pub struct Options {
    scenario: String,
    values: BTreeMap<String, String>,
    used: std::cell::RefCell<Vec<String>>,
}

impl Options {
    /// Options from `(key, value)` pairs (keys without `--`).
    pub fn new<I, K, V>(scenario: &str, pairs: I) -> Self
    where
        I: IntoIterator<Item = (K, V)>,
        K: Into<String>,
        V: Into<String>,
    {
        Self {
            scenario: scenario.to_owned(),
            values: pairs.into_iter().map(|(k, v)| (k.into(), v.into())).collect(),
            used: Default::default(),
        }
    }

    fn bad(&self, key: &str, value: &str, reason: &str) -> Error {
        Error::BadOption {
            scenario: self.scenario.clone(),
            key: key.to_owned(),
            value: value.to_owned(),
            reason: reason.to_owned(),
        }
    }

    fn raw(&self, key: &str) -> Option<&str> {
        self.used.borrow_mut().push(key.to_owned());
        self.values.get(key).map(String::as_str)
    }

    /// A finite number, checked by `ok` (which names the admissible range).
    pub fn number(&self, key: &str, default: f64, ok: (fn(f64) -> bool, &str)) -> Result<f64> {
        let Some(v) = self.raw(key) else { return Ok(default) };
        let x: f64 = v.trim().parse().map_err(|_| self.bad(key, v, "not a number"))?;
        if !x.is_finite() || !(ok.0)(x) {
            return Err(self.bad(key, v, ok.1));
        }
        Ok(x)
    }

    /// A vector `x,y,z` of finite numbers.
    pub fn vector(&self, key: &str, default: Vector3<f64>) -> Result<Vector3<f64>> {
        let Some(v) = self.raw(key) else { return Ok(default) };
        let parts: Vec<&str> = v.split(',').collect();
        if parts.len() != 3 {
            return Err(self.bad(key, v, "expected three comma-separated numbers x,y,z"));
        }
        let mut out = Vector3::zeros();
        for (i, p) in parts.iter().enumerate() {
            out[i] = p.trim().parse::<f64>().map_err(|_| self.bad(key, v, "expected three numbers x,y,z"))?;
            if !out[i].is_finite() {
                return Err(self.bad(key, v, "must be finite"));
            }
        }
        Ok(out)
    }

    /// Fails on a key no getter asked for.
    fn check_all_used(&self) -> Result<()> {
        let used = self.used.borrow();
        for (k, v) in &self.values {
            if !used.iter().any(|u| u == k) {
                let mut known = used.clone();
                known.sort();
                known.dedup();
                return Err(self.bad(k, v, &format!("unknown option (known: {})", known.join(", "))));
            }
        }
        Ok(())
    }
}

const POSITIVE: (fn(f64) -> bool, &str) = (|x| x > 0.0, "must be > 0");
const NON_NEGATIVE: (fn(f64) -> bool, &str) = (|x| x >= 0.0, "must be ≥ 0");

/// The ready pose: tool pointing down above the table, TCP ≈ (0.54, 0, 0.28) m.
pub fn ready() -> JointVector {
    JointVector::from_row_slice(&[0.0, 30f64.to_radians(), 0.0, 90f64.to_radians(), 0.0, 60f64.to_radians(), 0.0])
}

/// Builds scenario `name` with `options` for `model`.
pub fn build(model: &RobotModel, name: &str, options: &Options) -> Result<Setup> {
    let mut controller = ControllerConfig::default();
    controller.ik.link_damping = options.number("link-damping", controller.ik.link_damping, NON_NEGATIVE)?;
    controller.ik.damping = options.number("damping", controller.ik.damping, NON_NEGATIVE)?;
    controller.ik.posture_gain = options.number("posture-gain", 0.0, NON_NEGATIVE)?;
    controller.modulation.links = options.number("link-avoidance", 1.0, (|x| x == 0.0 || x == 1.0, "must be 0 or 1"))? == 1.0;
    if options.number("avoidance", 1.0, (|x| x == 0.0 || x == 1.0, "must be 0 or 1"))? == 0.0 {
        // Counterfactual runs: the plain DS, no modulation and no link safety layer at all.
        controller.modulation.end_effector = false;
        controller.modulation.links = false;
        controller.safety.enabled = false;
    }
    let rate = options.number("distance-rate", 1000.0, (|x| x > 0.0 && x <= 1000.0, "must be in (0, 1000] Hz"))?;
    let setup = match name {
        "three-obstacles" => three_obstacles(options, controller)?,
        "box-in-out" => box_in_out(options, controller)?,
        "moving-sphere-hold" => moving_sphere(model, options, controller, false)?,
        "moving-sphere-reach" => moving_sphere(model, options, controller, true)?,
        "hand-hit" => hand_hit(model, options, controller)?,
        "stacking-human" => {
            controller.scaling.far_speed = options.number("far-speed", 0.3, POSITIVE)?;
            controller.scaling.interaction_speed = options.number("interaction-speed", 0.1, POSITIVE)?;
            stacking_human(options, controller)?
        }
        other => {
            return Err(Error::UnknownScenario { name: other.to_owned(), known: NAMES.join(", ") });
        }
    };
    let setup = Setup { distance_rate_hz: options.number("distance-rate", rate, POSITIVE)?, ..setup };
    let duration = options.number("duration", setup.duration_s, POSITIVE)?;
    options.check_all_used()?;
    Ok(Setup { duration_s: duration, ..setup })
}

fn base(name: &str, controller: ControllerConfig) -> Setup {
    Setup {
        name: name.to_owned(),
        ready: ready(),
        start: Start::Joints(ready()),
        goals: Vec::new(),
        world: Box::new(StaticWorld(Vec::new())),
        objects: Vec::new(),
        duration_s: 10.0,
        settle_s: Some(0.5),
        controller,
        distance_rate_hz: 1000.0,
        hand_collisions_only: false,
    }
}

/// Fig. 5.3: ẋ = 2 (g − x) past a box on the path near the start, then between two spheres
/// whose surfaces are 25 cm apart, either side of the straight path.
fn three_obstacles(o: &Options, controller: ControllerConfig) -> Result<Setup> {
    let gain = o.number("gain", 2.0, POSITIVE)?;
    let gap = o.number("gap", 0.25, POSITIVE)?;
    let h = o.number("height", 0.15, POSITIVE)?;
    let px = o.number("path-x", 0.55, POSITIVE)?;
    let a = Vector3::new(px, 0.35, h);
    let g = Vector3::new(px, -0.35, h);
    let r = 0.06;
    let obstacles = vec![
        Obstacle::cuboid("obstacle1.box", Point3::new(px - 0.05, 0.17, h), Vector3::new(0.10, 0.10, 0.10)),
        Obstacle::sphere("obstacle2.sphere", Point3::new(px - 0.5 * gap - r, -0.12, h), r, Vector3::zeros()),
        Obstacle::sphere("obstacle3.sphere", Point3::new(px + 0.5 * gap + r, -0.12, h), r, Vector3::zeros()),
    ];
    Ok(Setup {
        start: Start::Position(a),
        goals: vec![Goal::linear(g, gain)],
        world: Box::new(StaticWorld(obstacles)),
        duration_s: 25.0,
        ..base("three-obstacles", controller)
    })
}

/// Fig. 5.4: into an open box (40 × 35 × 20 cm, open top, on the table) to its centre g1, then
/// out to g2, each with ẋ = 2 (g − x).
fn box_in_out(o: &Options, controller: ControllerConfig) -> Result<Setup> {
    let gain = o.number("gain", 2.0, POSITIVE)?;
    let centre = Point3::new(0.55, 0.0, 0.10);
    let walls = open_box(centre, Vector3::new(0.40, 0.35, 0.20), 0.01);
    let g1 = Goal { dwell_s: 0.5, ..Goal::linear(centre.coords, gain) };
    let g2 = Goal::linear(Vector3::new(0.35, -0.35, 0.35), gain);
    Ok(Setup {
        start: Start::Position(Vector3::new(0.35, 0.35, 0.35)),
        goals: vec![g1, g2],
        world: Box::new(StaticWorld(walls)),
        duration_s: 40.0,
        ..base("box-in-out", controller)
    })
}

/// A sphere moving at constant velocity.
#[derive(Debug, Clone)]
struct MovingSphere {
    start: Point3<f64>,
    velocity: Vector3<f64>,
    radius: f64,
}

impl World for MovingSphere {
    fn obstacles(&mut self, t: f64, out: &mut Vec<Obstacle>) {
        out.push(Obstacle::sphere("sphere", self.start + self.velocity * t, self.radius, self.velocity));
    }
}

/// Fig. 5.5 (`reach` false): hold the TCP at the ready pose with ẋ = 3 (g − x) while a sphere
/// starting 1 m away flies through it. Fig. 5.6 (`reach` true): go from (0.40, 0, 0.30) to
/// (0.70, 0, 0.30) with ẋ = 3 (g − x); the sphere crosses the path's middle, timed so the robot
/// is there when it arrives. Only the hand links count as collisions (the figures judge the
/// end effector); `min_distance_m` covers the whole arm.
fn moving_sphere(model: &RobotModel, o: &Options, controller: ControllerConfig, reach: bool) -> Result<Setup> {
    let velocity = o.vector("obstacle-velocity", Vector3::new(0.0, 0.7, 0.0))?;
    let speed = velocity.norm();
    if speed <= 0.0 {
        return Err(Error::BadOption {
            scenario: if reach { "moving-sphere-reach" } else { "moving-sphere-hold" }.into(),
            key: "obstacle-velocity".into(),
            value: format!("{},{},{}", velocity.x, velocity.y, velocity.z),
            reason: "must be non-zero".into(),
        });
    }
    let radius = o.number("radius", 0.1, POSITIVE)?;
    let gain = o.number("gain", 3.0, POSITIVE)?;
    let dir = velocity / speed;
    let (name, start, goals, obstacle_start) = if reach {
        let a = Vector3::new(0.40, 0.0, 0.30);
        let b = Vector3::new(0.70, 0.0, 0.30);
        let crossing = Point3::from(0.5 * (a + b));
        let obstacle_start = o.vector("obstacle-start", crossing.coords - dir)?;
        // The linear DS is half-way after ln 2 / k s: start the motion then before the sphere
        // reaches the crossing point.
        let arrival = (crossing.coords - obstacle_start).dot(&dir) / speed;
        let lead = o.number("lead", std::f64::consts::LN_2 / gain, NON_NEGATIVE)?;
        let go = Goal { not_before_s: (arrival - lead).max(0.0), ..Goal::linear(b, gain) };
        let hold_a = Goal { dwell_s: 0.0, ..Goal::linear(a, gain) };
        ("moving-sphere-reach", Start::Position(a), vec![hold_a, go], obstacle_start)
    } else {
        let g = tcp(model, &ready());
        let obstacle_start = o.vector("obstacle-start", g.coords - dir)?;
        ("moving-sphere-hold", Start::Joints(ready()), vec![Goal::linear(g.coords, gain)], obstacle_start)
    };
    let travel = 2.0 / speed;
    Ok(Setup {
        start,
        goals: goals.clone(),
        world: Box::new(MovingSphere { start: Point3::from(obstacle_start), velocity, radius }),
        duration_s: goals.iter().map(|g| g.not_before_s).fold(0.0, f64::max) + travel + 3.0,
        settle_s: None,
        hand_collisions_only: true,
        ..base(name, controller)
    })
}

/// A scripted person and what the human observer would report about them.
struct PersonWorld {
    person: Person,
    /// Interaction below this robot–person distance (m), far again above it + 0.1 m.
    interaction_distance: f64,
    /// The person is tracked while the pelvis is closer than this to the robot base (m).
    tracking_range: f64,
    interacting: bool,
    /// A reach for the gripper, triggered by where the robot is.
    reach: Option<ReachForGripper>,
}

/// The person, standing at the table, reaches with the right hand for the gripper the first
/// time it comes within `range` of the right shoulder: the hand sweeps to where the TCP was at
/// that instant in `reach_s`, stays `hold_s`, and goes back to rest in `back_s`; then the person
/// leaves (pelvis back to `far_x` in `walk_s`). Without a trigger by `give_up` the person
/// leaves without reaching.
#[derive(Debug, Clone)]
struct ReachForGripper {
    /// Earliest trigger time (s): the person has arrived.
    from: f64,
    /// Latest trigger time (s).
    give_up: f64,
    range: f64,
    reach_s: f64,
    hold_s: f64,
    back_s: f64,
    walk_s: f64,
    far_x: f64,
    /// Trigger time and target, once triggered.
    triggered: Option<(f64, Point3<f64>)>,
}

impl PersonWorld {
    /// Re-scripts the person from `t` on: reach for `target` (or not, when `None`), then leave.
    fn script_from(&mut self, t: f64, target: Option<Point3<f64>>) {
        let Some(r) = &self.reach else { return };
        let pelvis = self.person.pelvis.at(t);
        let hand = self.person.hand(t);
        let rest = Person::rest_hand(pelvis.x, pelvis.y, self.person.pelvis_z);
        let mut hand_keys = vec![(t, hand)];
        let mut t_back = t;
        if let Some(target) = target {
            hand_keys.push((t + r.reach_s, target));
            hand_keys.push((t + r.reach_s + r.hold_s, target));
            t_back = t + r.reach_s + r.hold_s + r.back_s;
            hand_keys.push((t_back, rest));
        }
        let t_out = t_back + 0.5 + r.walk_s;
        let far = Point3::new(r.far_x, pelvis.y, 0.0);
        hand_keys.push((t_back + 0.5, rest));
        hand_keys.push((t_out, Person::rest_hand(far.x, far.y, self.person.pelvis_z)));
        self.person.right_hand = Track(hand_keys);
        self.person.pelvis = Track(vec![(t, pelvis), (t_back + 0.5, pelvis), (t_out, far)]);
    }
}

impl World for PersonWorld {
    fn observe(&mut self, t: f64, tcp: &Point3<f64>) {
        let Some(r) = &self.reach else { return };
        if r.triggered.is_some() || t < r.from {
            return;
        }
        let shoulder = self.person.right_shoulder(t);
        if (tcp - shoulder).norm() <= r.range {
            self.script_from(t, Some(*tcp));
            if let Some(r) = &mut self.reach {
                r.triggered = Some((t, *tcp));
            }
        } else if t >= r.give_up {
            self.script_from(t, None);
            if let Some(r) = &mut self.reach {
                r.triggered = Some((t, Point3::new(f64::NAN, f64::NAN, f64::NAN)));
            }
        }
    }

    fn obstacles(&mut self, t: f64, out: &mut Vec<Obstacle>) {
        self.person.obstacles(t, out);
    }

    fn human(&mut self, t: f64, human_distance: f64) -> HumanState {
        let p = self.person.pelvis_at(t);
        let present = p.coords.xy().norm() < self.tracking_range;
        if human_distance < self.interaction_distance {
            self.interacting = true;
        } else if human_distance > self.interaction_distance + 0.1 {
            self.interacting = false;
        }
        HumanState {
            present,
            mode: if present && self.interacting { HumanMode::Interaction } else { HumanMode::Far },
            stopped: false,
        }
    }
}

const PELVIS_Z: f64 = 0.2;

fn key(t: f64, x: f64, y: f64, z: f64) -> (f64, Point3<f64>) {
    (t, Point3::new(x, y, z))
}

/// Fig. 5.7 (analytic, no bag): a person in front of the table swings the right hand into the
/// end effector held with ẋ = 3 (g − x) at the ready pose; the hand stops where the TCP was,
/// stays 1 s and withdraws.
fn hand_hit(model: &RobotModel, o: &Options, controller: ControllerConfig) -> Result<Setup> {
    let gain = o.number("gain", 3.0, POSITIVE)?;
    let sweep = o.number("sweep-time", 0.5, POSITIVE)?;
    let g = tcp(model, &ready());
    let (px, py) = (1.15, -0.1);
    let rest = Person::rest_hand(px, py, PELVIS_Z);
    let hit = g + Vector3::new(0.03, 0.0, 0.0);
    let t0 = 1.0;
    let person = Person {
        pelvis: Track(vec![key(0.0, px, py, 0.0)]),
        right_hand: Track(vec![
            (t0, rest),
            (t0 + sweep, hit),
            (t0 + sweep + 1.0, hit),
            (t0 + sweep + 2.0, rest),
        ]),
        pelvis_z: PELVIS_Z,
    };
    Ok(Setup {
        goals: vec![Goal::linear(g.coords, gain)],
        world: Box::new(PersonWorld { person, interaction_distance: 0.0, tracking_range: 0.0, interacting: false, reach: None }),
        // 6 s after the withdrawal: the robot is back (Fig. 5.7: ≈ 3 s; here ≈ 4 s, see README).
        duration_s: t0 + sweep + 2.0 + 6.0,
        settle_s: None,
        ..base("hand-hit", controller)
    })
}

/// Sec. 5.1.3: stack two blocks (four constant-speed motions ẋ = α_h (g − x)/‖g − x‖, grasp,
/// place, grasp, place on top) while a person walks up to the table, reaches into the robot's
/// path and leaves. α_h = 0.1 m/s while the person is within `interaction-distance` of the
/// robot, 0.3 m/s otherwise.
///
/// The reach (default): the first time the gripper comes within `reach-range` of the person's
/// right shoulder, the hand sweeps in `reach-time` to where the TCP was at that instant (so it
/// arrives on the arm's path, Fig. 5.13(b)), stays `hold`, withdraws in 1.5 s, and the person
/// leaves. `--reach-to x,y,z` replaces it with a reach to a fixed point at a fixed time (the
/// hand then stays ≥ 25 cm from the arm: the robot yields early).
fn stacking_human(o: &Options, controller: ControllerConfig) -> Result<Setup> {
    let interaction_distance = o.number("interaction-distance", 0.8, POSITIVE)?;
    let fixed_reach = o.raw("reach-to").is_some();
    let reach_to = o.vector("reach-to", Vector3::new(0.72, 0.05, 0.22))?;
    let enter = o.number("enter-at", 3.0, NON_NEGATIVE)?;
    let hold = o.number("hold", if fixed_reach { 2.5 } else { 1.5 }, POSITIVE)?;
    let reach = o.number("reach-time", if fixed_reach { 1.5 } else { 0.6 }, POSITIVE)?;
    let reach_range = o.number("reach-range", 0.85, POSITIVE)?;
    let near_x = o.number("stand-x", 1.0, (|x| x >= 0.9, "must be ≥ 0.9 m (the table edge is at 1.15 m)"))?;
    let speed = controller.scaling.far_speed;
    let cs = |p: Vector3<f64>, grip: bool| Goal {
        position: p,
        primitive: Primitive::ConstantSpeed(ConstantSpeed::new(speed)),
        dwell_s: 0.3,
        not_before_s: 0.0,
        gripper: Some(grip),
        end_effector_avoidance: true,
    };
    let stack = Vector3::new(0.55, -0.25, 0.0);
    let goals = vec![
        cs(Vector3::new(0.50, 0.40, 0.03), true),
        cs(stack + Vector3::new(0.0, 0.0, 0.035), false),
        cs(Vector3::new(0.60, 0.40, 0.03), true),
        cs(stack + Vector3::new(0.0, 0.0, 0.095), false),
    ];
    let block = |name: &str, x: f64, y: f64| -> Result<SceneObject> {
        serde_json::from_value(serde_json::json!({
            "name": name,
            "shape": { "type": "box", "size": [0.06, 0.06, 0.06] },
            "pose": { "position": [x, y, 0.03] }
        }))
        .map_err(|e| Error::Scene { message: e.to_string() })
    };
    let (far_x, py) = (2.6, 0.0);
    let (walk, back) = (2.0, 1.5);
    let t_in = enter + walk;
    let t_reach = t_in + 0.5 + reach;
    let t_back = t_reach + hold + back;
    let t_out = t_back + 0.5 + walk;
    let rest = |x: f64| Person::rest_hand(x, py, PELVIS_Z);
    let (person, robot_reach) = if fixed_reach {
        let person = Person {
            pelvis: Track(vec![
                key(enter, far_x, py, 0.0),
                key(t_in, near_x, py, 0.0),
                key(t_back + 0.5, near_x, py, 0.0),
                key(t_out, far_x, py, 0.0),
            ]),
            right_hand: Track(vec![
                (enter, rest(far_x)),
                (t_in + 0.5, rest(near_x)),
                (t_reach, Point3::from(reach_to)),
                (t_reach + hold, Point3::from(reach_to)),
                (t_back, rest(near_x)),
                (t_back + 0.5, rest(near_x)),
                (t_out, rest(far_x)),
            ]),
            pelvis_z: PELVIS_Z,
        };
        (person, None)
    } else {
        // Walk in and wait at the table; the rest is scripted when the reach triggers.
        let person = Person {
            pelvis: Track(vec![key(enter, far_x, py, 0.0), key(t_in, near_x, py, 0.0)]),
            right_hand: Track(vec![(enter, rest(far_x)), (t_in + 0.5, rest(near_x))]),
            pelvis_z: PELVIS_Z,
        };
        let r = ReachForGripper {
            from: t_in + 0.5,
            give_up: t_in + 30.0,
            range: reach_range,
            reach_s: reach,
            hold_s: hold,
            back_s: back,
            walk_s: walk,
            far_x,
            triggered: None,
        };
        (person, Some(r))
    };
    Ok(Setup {
        start: Start::Joints(ready()),
        goals,
        world: Box::new(PersonWorld { person, interaction_distance, tracking_range: 2.4, interacting: false, reach: robot_reach }),
        objects: vec![block("block1", 0.50, 0.40)?, block("block2", 0.60, 0.40)?],
        duration_s: 90.0,
        settle_s: Some(0.5),
        controller,
        distance_rate_hz: 1000.0,
        ..base("stacking-human", controller)
    })
}

/// One speed of a moving-sphere sweep.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SweepPoint {
    /// Obstacle speed (m/s).
    pub speed_m_s: f64,
    /// Avoided (no hand contact) and goal regained (final error ≤ `tolerance`).
    pub ok: bool,
    /// The run's summary.
    pub summary: crate::Summary,
}

/// Runs `moving-sphere-hold` (or `-reach`) for each speed along +y and judges it: the hand is
/// never touched and the final goal error is at most `tolerance` (m).
pub fn sweep_moving_sphere(model: &RobotModel, reach: bool, speeds: &[f64], tolerance: f64) -> Result<Vec<SweepPoint>> {
    sweep_moving_sphere_with(model, reach, speeds, tolerance, &[])
}

/// [`sweep_moving_sphere`] with further scenario options (`--obstacle-start`, `--radius`, …;
/// not `obstacle-velocity`, which the sweep sets) applied to every run.
pub fn sweep_moving_sphere_with(
    model: &RobotModel,
    reach: bool,
    speeds: &[f64],
    tolerance: f64,
    extra: &[(String, String)],
) -> Result<Vec<SweepPoint>> {
    let name = if reach { "moving-sphere-reach" } else { "moving-sphere-hold" };
    if let Some((k, v)) = extra.iter().find(|(k, _)| k == "obstacle-velocity") {
        return Err(Error::BadOption {
            scenario: name.into(),
            key: k.clone(),
            value: v.clone(),
            reason: "set by the sweep (speeds along +y)".into(),
        });
    }
    let mut out = Vec::new();
    for &v in speeds {
        let mut pairs = vec![("obstacle-velocity".to_owned(), format!("0,{v},0"))];
        pairs.extend(extra.iter().cloned());
        let opts = Options::new(name, pairs);
        let summary = crate::run(model, build(model, name, &opts)?, None)?;
        let ok = summary.collisions == 0 && summary.final_goal_error_m <= tolerance;
        out.push(SweepPoint { speed_m_s: v, ok, summary });
    }
    Ok(out)
}
