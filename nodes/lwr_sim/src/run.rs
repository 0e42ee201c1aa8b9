//! [`run`]: the node over DDS. [`run_loop`] is the whole behaviour, generic over where the
//! inputs come from: the DDS source here, a scripted one in the golden tests. The loop is
//! time-driven: its deadlines are the simulation's step times (paced against the source's
//! clock), and inputs that arrive between two steps are handled before the next one.

use std::sync::Arc;

use anyhow::{Context as _, Result, bail};
use cowork_msgs::sensor_msgs::{CameraInfo, Image};
use cowork_msgs::std_msgs::String as RosString;
use cowork_msgs::topics::{self, Delivery};
use cowork_ros::{DdsSource, Event, InputSource, RosNode, RunOptions, Warnings};

use crate::depth::{DepthCamera, Mailbox};
use crate::node::{Input, LwrSim, Output, absolute_mesh_uris, prefix_link_names};
use crate::params::WrenchMode;

/// How simulated time relates to the source's (wall) time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pacing {
    /// Simulated seconds per wall second.
    Rate(f64),
    /// As fast as possible.
    Max,
}

impl Pacing {
    /// From `--rate R` / `--max`.
    pub fn from_args(rate: f64, max: bool) -> Result<Self> {
        if max {
            return Ok(Self::Max);
        }
        if !(rate.is_finite() && rate > 0.0) {
            bail!("--rate {rate}: must be a positive number (use --max for as fast as possible)");
        }
        Ok(Self::Rate(rate))
    }
}

/// While the simulator waits for a replayed teacher's wrench, the loop wakes at least this
/// often (s of the source's clock) to look again; an arriving wrench wakes it at once.
pub const HOLD_RECHECK_S: f64 = 0.01;

/// Identical warnings are logged at most once per this many seconds.
pub const WARNING_REPEAT_S: f64 = 5.0;

/// What a run did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RunSummary {
    /// Simulation steps.
    pub steps: u64,
    /// Inputs handled.
    pub inputs: u64,
    /// Warnings put out.
    pub warnings: u64,
}

/// Steps `lwr` at `pacing` against the source's clock until `duration_s` simulated seconds
/// (or the source ends), handing every input to its handler as it arrives and every output to
/// `emit`. While [`LwrSim::waiting_for_wrench`] the simulator holds (no step) and the pace
/// restarts from where it was when the wrench arrives.
pub fn run_loop<S: InputSource<Input>>(
    source: &mut S,
    lwr: &mut LwrSim,
    pacing: Pacing,
    duration_s: Option<f64>,
    emit: &mut dyn FnMut(Output),
) -> RunSummary {
    let end_ns = duration_s.map(|d| (d * 1e9) as i64);
    let mut summary = RunSummary::default();
    let mut out = Vec::new();
    // Source time at which simulated time 0 was (or would have been) due; moved on by holds.
    // A simulation kept from before an in-process restart goes on from where it was.
    let mut start_s = match pacing {
        Pacing::Rate(rate) => source.now_s() - lwr.time_s() / rate,
        Pacing::Max => source.now_s(),
    };
    let mut held_since: Option<f64> = None;
    loop {
        if end_ns.is_some_and(|end| lwr.simulator().time_ns() >= end) {
            break;
        }
        let now = source.now_s();
        let deadline = if lwr.waiting_for_wrench() {
            held_since.get_or_insert(now);
            now + HOLD_RECHECK_S
        } else {
            if let Some(since) = held_since.take() {
                start_s += now - since;
            }
            match pacing {
                Pacing::Rate(rate) => start_s + lwr.time_s() / rate,
                Pacing::Max => now,
            }
        };
        match source.next(deadline) {
            Event::End => break,
            Event::Input(input) => {
                summary.inputs += 1;
                if let Some(o) = lwr.on_input(&input) {
                    summary.warnings += matches!(o, Output::Warning(_)) as u64;
                    emit(o);
                }
            }
            Event::Deadline if lwr.waiting_for_wrench() => {}
            Event::Deadline => {
                summary.steps += 1;
                lwr.on_step(&mut out);
                for o in out.drain(..) {
                    summary.warnings += matches!(o, Output::Warning(_)) as u64;
                    emit(o);
                }
            }
        }
    }
    summary
}

impl LwrSim {
    /// `/robot_description` of arm `arm`: the URDF the simulator runs, with each relative mesh
    /// path made an absolute `file://` URI so RViz's RobotModel and Foxglove's 3D panel on this
    /// machine find the meshes (`package://` and absolute URIs are left as they are). A named
    /// arm's link names carry its frame prefix (`left/lwr_link_3`), as its tf frames do.
    pub fn robot_description(&self, arm: usize) -> Result<RosString> {
        let source = self.simulator().model().source();
        let text = std::fs::read_to_string(source)
            .with_context(|| format!("cannot read the robot description {}", source.display()))?;
        let dir = source.parent().unwrap_or(std::path::Path::new("."));
        let dir = std::fs::canonicalize(dir).with_context(|| format!("cannot resolve {}", dir.display()))?;
        let text = absolute_mesh_uris(&text, &dir);
        let prefix = self.simulator().arm(arm).frames()[0].strip_suffix(&self.simulator().model().link_names()[0]).unwrap_or("");
        let links = self.simulator().model().link_names();
        Ok(RosString { data: if prefix.is_empty() { text } else { prefix_link_names(&text, links, prefix) } })
    }
}

/// Renders and publishes every snapshot the loop posts, until the mailbox closes.
fn depth_worker(
    mut camera: DepthCamera,
    mailbox: &Mailbox,
    image_pub: &cowork_ros::Publisher<Image>,
    info_pub: &cowork_ros::Publisher<CameraInfo>,
) {
    let mut image = Image::default();
    let mut info = CameraInfo::default();
    let mut warnings = Warnings::new(WARNING_REPEAT_S);
    let mut done = None;
    while let Some(snap) = mailbox.take(done.take()) {
        match camera.render(&snap, &mut image, &mut info) {
            Ok(()) => {
                // The publisher takes ownership; the buffer is rebuilt next frame.
                for w in [image_pub.send(std::mem::take(&mut image)), info_pub.send(info.clone())].into_iter().flatten() {
                    warnings.warn(cowork_ros::monotonic_s(), &w);
                }
            }
            Err(e) => {
                let w = cowork_ros::Warning::new("depth:render", format!("depth frame at {:?} not rendered: {e:#}", snap.stamp));
                warnings.warn(cowork_ros::monotonic_s(), &w);
            }
        }
        done = Some(snap);
    }
}

/// Runs the node until Ctrl-C or `duration` simulated seconds.
pub fn run(node: RosNode, mut lwr: LwrSim, pacing: Pacing, duration: Option<f64>) -> Result<()> {
    run_with(node, &mut lwr, pacing, duration)
}

/// [`run`] on a simulation the caller keeps: the node binary keeps it across an in-process
/// restart (`cowork_ros::node_main` after a stop and continue), so that the robot, the objects
/// and the clock go on from where they were instead of starting over.
pub fn run_with(node: RosNode, lwr: &mut LwrSim, pacing: Pacing, duration: Option<f64>) -> Result<()> {
    let lwr = &mut *lwr;
    let mut source = DdsSource::new(node, RunOptions::default().start())?;
    let arms = lwr.simulator().arms().len();
    for arm in 0..arms {
        let ns = lwr.namespace(arm);
        // Best effort: only the newest command counts (a lost one is covered by the next, 1 ms
        // later, and by the command timeout), and a best-effort reader never holds the
        // controller's writer back. A reliable one did when this process was stopped and
        // continued: the reader of the participant it left behind acknowledged nothing until
        // its lease ran out, and the controller's writer dropped most commands for everyone
        // (chaos `lwr_sim:stop`: 16,384 dropped in 21 s, the pour 31 s slower).
        source.add_in(&topics::JOINT_VELOCITY_COMMAND.reading(Delivery::BestEffort { depth: 10 }), &ns, move |m| Input::VelocityCommand(arm, m))?;
        source.add_in(&topics::GRIPPER_COMMAND, &ns, move |m| Input::GripperCommand(arm, m))?;
        // Deep (the topic's 1000): a replayed teacher may send its wrenches ahead of their stamps.
        source.add_in(&topics::EXTERNAL_WRENCH, &ns, move |m| Input::Wrench(arm, m))?;
        source.add_in(&topics::FOLLOW_JOINTS, &ns, move |m| Input::FollowJoints(arm, m))?;
    }
    // Best effort matches every writer (reliable bags, best-effort trackers).
    source.add(&topics::SKELETON.reading(Delivery::BestEffort { depth: 20 }), Input::Skeleton)?;
    source.add(&topics::PLACE_OBJECT, Input::PlaceObject)?;
    let node = source.node();
    let clock = node.advertise(&topics::CLOCK)?;
    let tf = node.advertise(&topics::TF)?;
    let tf_static = node.advertise(&topics::TF_STATIC)?;
    let (mut joint_states, mut world, mut wrench_report, mut descriptions) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for arm in 0..arms {
        let ns = lwr.namespace(arm);
        joint_states.push(node.advertise_in(&topics::JOINT_STATES, &ns)?);
        world.push(node.advertise_in(&topics::WORLD, &ns)?);
        wrench_report.push(node.advertise_in(&topics::LWR_EXTERNAL_WRENCH, &ns)?);
        // Latched, as robot_state_publisher's: a viewer that joins later still gets it.
        let description = node.advertise_in(&topics::ROBOT_DESCRIPTION, &ns)?;
        description.publish(lwr.robot_description(arm)?)?;
        descriptions.push(description);
    }
    tf_static.publish(lwr.tf_static())?;
    let camera = if lwr.depth_config().enabled {
        let image = node.advertise(&topics::DEPTH_IMAGE)?;
        let info = node.advertise(&topics::DEPTH_CAMERA_INFO)?;
        let camera = DepthCamera::new(lwr.simulator(), lwr.depth_config())?;
        let mailbox = Mailbox::new();
        let worker = {
            let mailbox = Arc::clone(&mailbox);
            std::thread::Builder::new()
                .name("lwr_sim_depth".into())
                .spawn(move || depth_worker(camera, &mailbox, &image, &info))?
        };
        Some((mailbox, worker))
    } else {
        None
    };
    tracing::info!(
        "lwr_sim running: {} arm(s) ({}) of {} joints, {} objects, pacing {pacing:?}, {}: {}",
        arms,
        (0..arms).map(|a| lwr.namespace(a)).collect::<Vec<_>>().join(", "),
        lwr.simulator().model().joint_names().len(),
        lwr.simulator().objects().len(),
        topics::EXTERNAL_WRENCH.name,
        match lwr.wrench_mode() {
            WrenchMode::Teach => "teach (the arm yields by admittance)".to_owned(),
            WrenchMode::Execute => {
                format!("execute (reported on {}, the arm moves only as commanded)", topics::LWR_EXTERNAL_WRENCH.name)
            }
        }
    );

    let names: Vec<String> = lwr.simulator().arms().iter().map(|a| a.name().to_owned()).collect();
    let arm_label = |arm: usize| if names[arm].is_empty() { String::new() } else { format!("{}: ", names[arm]) };
    let mut warnings = Warnings::new(WARNING_REPEAT_S);
    let started_s = cowork_ros::monotonic_s();
    let mut last_report_s = started_s;
    let summary = run_loop(&mut source, lwr, pacing, duration, &mut |out| {
        let failed = match out {
            Output::Clock(m) => {
                let now = cowork_ros::monotonic_s();
                if now - last_report_s >= 10.0 {
                    last_report_s = now;
                    let sim_s = m.clock.to_secs_f64();
                    tracing::info!(
                        "t_sim = {sim_s:.1} s, real-time factor {:.2}{}",
                        sim_s / (now - started_s),
                        camera.as_ref().map_or(String::new(), |(m, _)| format!(
                            ", depth frames dropped (renderer busy): {}",
                            m.dropped()
                        ))
                    );
                }
                clock.send(m)
            }
            Output::JointStates(arm, m) => joint_states[arm].send(m),
            Output::Tf(m) => tf.send(m),
            Output::World(arm, m) => world[arm].send(m),
            Output::ExternalWrench(arm, m) => wrench_report[arm].send(m),
            Output::Depth(snap) => {
                if let Some((mailbox, _)) = &camera {
                    mailbox.post_snapshot(*snap);
                }
                None
            }
            Output::Gripper { arm, closed: true, object: Some(name) } => {
                tracing::info!("{}gripper closed on {name}", arm_label(arm));
                None
            }
            Output::Gripper { arm, closed: true, object: None } => {
                tracing::info!("{}gripper closed on nothing (no object within reach)", arm_label(arm));
                None
            }
            Output::Gripper { arm, closed: false, .. } => {
                tracing::info!("{}gripper open", arm_label(arm));
                None
            }
            Output::Warning(w) => Some(w),
        };
        if let Some(w) = failed {
            warnings.warn(cowork_ros::monotonic_s(), &w);
        }
    });
    if let Some((mailbox, worker)) = camera {
        mailbox.close();
        if worker.join().is_err() {
            bail!("the depth camera thread panicked");
        }
    }
    tracing::info!(
        "lwr_sim stopped at t_sim = {:.3} s ({} steps, {} inputs, {} warnings)",
        lwr.time_s(),
        summary.steps,
        summary.inputs,
        summary.warnings
    );
    Ok(())
}
