//! `stacking-human`: the stacking scene of thesis Sec. 5.1.3. The robot moves two boxes from the
//! +y side of the table to the −y side and back, over and over, with point-to-point DS motions `ẋ = α (g − x)/‖g − x‖`
//! (orientation held), at α = 0.3 m/s, scaled to 0.1 m/s while a person is within
//! [`CLOSE_M`] of the tool; meanwhile a person walks in, stands beside the table, reaches
//! towards the arm, sweeps a hand across the robot's path and walks out. The person is written
//! as Xsens skeletons (120 Hz) and drawn as capsules in the depth frames.
//!
//! The kinematic simulator cannot stack (a released object drops to the table top), so boxes
//! are placed beside each other rather than on top.

use cowork_depth::Capsule;
use cowork_people::{BodySize, Room, Sampler, SensorConfig, Timeline};
use cowork_robot::{Jacobian, damped_pseudo_inverse};
use cowork_sim::Simulator;
use nalgebra::{Point3, UnitQuaternion, Vector3, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::depth::{DepthRig, people_capsules};
use crate::runner::Runner;
use crate::streams::topics;
use crate::{Result, SynthError};

/// Nominal DS speed, m/s (Sec. 5.1.3).
pub const SPEED_FAR: f64 = 0.3;
/// Speed while a person is close, m/s.
pub const SPEED_CLOSE: f64 = 0.1;
/// A person closer than this to the tool point (capsule surface) counts as close, m.
pub const CLOSE_M: f64 = 0.6;
/// The person starts walking in at this time, s.
pub const PERSON_ENTERS_S: f64 = 1.0;
/// (box picked, where it goes: centre x, y) in the stacking scene.
pub const MOVES: [(&str, [f64; 2]); 2] = [("box1", [0.50, -0.28]), ("box2", [0.60, -0.28])];

#[derive(Debug, Clone, Copy)]
enum Step {
    Go(Vector3<f64>),
    Gripper(bool),
}

/// The robot's side of the scenario: a list of point-to-point goals and gripper actions.
#[derive(Debug)]
struct Stacker {
    steps: Vec<Step>,
    next: usize,
    orientation: UnitQuaternion<f64>,
    jacobian: Jacobian,
}

impl Stacker {
    fn new(sim: &Simulator) -> Result<Self> {
        let home = sim.tool_pose();
        let clearance = Vector3::new(0.0, 0.0, 0.15);
        let mut there = Vec::new();
        let mut back = Vec::new();
        for (name, to) in MOVES {
            let object = sim.objects().iter().find(|o| o.name == name).ok_or_else(|| SynthError::Plan {
                scenario: "stacking-human",
                reason: format!("the scene has no object `{name}` (stacking.yaml has box1..box4)"),
            })?;
            // Tool point 1 cm above the box's top to grasp; released 5 mm above the table.
            let from = object.pose.translation.vector + Vector3::new(0.0, 0.0, half_height(&object.shape) + 0.01);
            let to = Vector3::new(to[0], to[1], from.z);
            let release = Vector3::new(0.0, 0.0, 0.005);
            for (list, a, b) in [(&mut there, from, to), (&mut back, to, from)] {
                list.extend([
                    Step::Go(a + clearance),
                    Step::Go(a),
                    Step::Gripper(true),
                    Step::Go(a + clearance),
                    Step::Go(b + clearance),
                    Step::Go(b + release),
                    Step::Gripper(false),
                    Step::Go(b + clearance),
                ]);
            }
        }
        // Boxes over, then back again, for as long as the bag lasts.
        let mut steps = there;
        steps.extend(back);
        steps.push(Step::Go(home.translation.vector));
        Ok(Self { steps, next: 0, orientation: home.rotation, jacobian: Jacobian::zeros() })
    }

    /// Sets the joint velocity command for this step at speed `alpha` (m/s).
    fn command(&mut self, sim: &mut Simulator, alpha: f64) -> Result<()> {
        let tool = sim.tool_pose();
        let x = tool.translation.vector;
        let v = loop {
            match self.steps.get(self.next) {
                Some(Step::Gripper(close)) => {
                    sim.command_gripper(*close);
                    self.next = (self.next + 1) % self.steps.len();
                }
                Some(Step::Go(g)) => {
                    let e = g - x;
                    let d = e.norm();
                    if d < 0.002 {
                        self.next = (self.next + 1) % self.steps.len();
                        continue;
                    }
                    // The DS of Sec. 5.1.3, slowed within 3 cm of the goal so it stops there.
                    break e / d * alpha * (d / 0.03).min(1.0);
                }
                None => break Vector3::zeros(), // no steps

            }
        };
        let w = 2.0 * (self.orientation * tool.rotation.inverse()).scaled_axis();
        let twist = Vector6::new(v.x, v.y, v.z, w.x, w.y, w.z);
        let tip = sim.model().tip_link();
        sim.model().jacobian(sim.link_poses(), tip, &Point3::origin(), &mut self.jacobian);
        let qd = damped_pseudo_inverse(&self.jacobian, 0.02) * twist;
        sim.set_velocity_command(qd.as_slice())
            .map_err(|source| SynthError::Command { what: "a joint velocity command", source })
    }
}

fn half_height(shape: &cowork_sim::Shape) -> f64 {
    match *shape {
        cowork_sim::Shape::Box { size } => 0.5 * size[2],
        cowork_sim::Shape::Cylinder { height, .. } => 0.5 * height,
        cowork_sim::Shape::Sphere { radius } => radius,
    }
}

/// The person of the scenario: a visit of the default room with a body size drawn from `seed`.
pub(crate) fn person_timeline(seed: u64) -> Result<Timeline> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5157_4143_4b49_4e47);
    let body = BodySize::new(rng.random_range(1.55..=1.90))?;
    let room = Room::default();
    // Reach towards the arm above the −y boxes, then sweep the hand across the robot's path.
    let reach = Point3::new(0.45, -0.55, 0.30);
    let sweep = (Point3::new(0.30, -0.55, 0.25), Point3::new(0.70, -0.55, 0.25));
    let visit = room.visit(1, body, rng.random(), reach, sweep)?;
    let mut timeline = Timeline::new();
    timeline.add(PERSON_ENTERS_S, visit)?;
    Ok(timeline)
}

/// Default length: the visit plus one second (rounded up to 0.1 s), at least 20 s.
pub(crate) fn default_duration_s(seed: u64) -> Result<f64> {
    Ok(((person_timeline(seed)?.duration() + 1.0) * 10.0).ceil().max(200.0) / 10.0)
}

/// Runs the scenario.
pub(crate) fn run_stacking(run: &mut Runner<'_>, depth: &mut Option<DepthRig>, seed: u64, noise: bool) -> Result<()> {
    let timeline = person_timeline(seed)?;
    let sensor = if noise { SensorConfig::xsens() } else { SensorConfig::xsens().noiseless() };
    let end_ns = run.now() + (run.duration_s() * 1e9) as i64;
    let mut skeletons = Sampler::new(&timeline, sensor, seed)?
        .take_while(|m| m.header.stamp.to_nanos() <= end_ns)
        .peekable();
    let mut stacker = Stacker::new(&run.sim)?;
    let mut capsules: Vec<Capsule> = Vec::new();
    while !run.done() {
        let now = run.now();
        while let Some(m) = skeletons.next_if(|m| m.header.stamp.to_nanos() <= now) {
            run.streams.write(topics::SKELETON, m.header.stamp.to_nanos(), &m)?;
        }
        people_capsules(&timeline, now as f64 * 1e-9, &mut capsules);
        let tool = Point3::from(run.sim.tool_pose().translation.vector);
        let close = capsules.iter().any(|c| c.signed_distance(&tool) < CLOSE_M);
        stacker.command(&mut run.sim, if close { SPEED_CLOSE } else { SPEED_FAR })?;
        run.step()?;
        if let Some(rig) = depth.as_mut() {
            while let Some(t) = rig.due(run.now()) {
                people_capsules(&timeline, t as f64 * 1e-9, &mut capsules);
                rig.write_frame(&mut run.streams, t, &run.sim, &capsules)?;
            }
        }
    }
    Ok(())
}
