//! [`run`]: the node over DDS. [`run_loop`] is the whole behaviour, generic over where the
//! inputs come from: the DDS source here, a scripted one in the golden tests.

use anyhow::Result;
use cowork_msgs::msg::{Gesture, HumanState, Skeleton};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::String as RosString;
use cowork_msgs::topics;
use cowork_msgs::visualization_msgs::MarkerArray;
use cowork_ros::{DdsSource, Event, InputSource, RosNode, RunOptions, Warning, Warnings};

use crate::node::ObserverNode;

/// What the node takes in.
#[derive(Debug, Clone)]
pub enum Input {
    /// `/joint_states`: the robot's geometry for the distance.
    JointState(JointState),
    /// `/speech_command`: `stop` / `repeat`.
    Speech(RosString),
    /// `/human/skeleton`.
    Skeleton(Skeleton),
    /// `<arm>/joint_states` of the driven arm with this index in `retarget.arms`.
    ArmJointState(usize, JointState),
}

/// What the node puts out.
#[derive(Debug, Clone, serde::Serialize)]
pub enum Output {
    /// `/human/state`.
    State(HumanState),
    /// `/human/gesture`.
    Gesture(Gesture),
    /// `/human/markers`.
    Markers(MarkerArray),
    /// `<arm>/lwr/follow_joints` of the driven arm with this index in `retarget.arms`.
    FollowJoints(usize, JointState),
    /// A warning for the log (rate-limited by the caller).
    Warning(Warning),
}

/// What a run did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunSummary {
    /// Skeleton frames handled.
    pub skeletons: u64,
    /// `/human/state` messages published.
    pub states: u64,
    /// `/human/gesture` messages published.
    pub gestures: u64,
}

/// Hands every input of `source` to `observer` and every output to `emit`, ticking the steady
/// state and marker publication between inputs, until the source ends.
pub fn run_loop<S: InputSource<Input>>(source: &mut S, observer: &mut ObserverNode, emit: &mut dyn FnMut(Output)) -> RunSummary {
    let rate = observer.params().state_rate_hz.max(observer.params().markers_rate_hz);
    let tick_period = (0.5 / rate).clamp(0.001, 0.05);
    let mut summary = RunSummary::default();
    let mut next_tick = f64::NEG_INFINITY;
    loop {
        let event = source.next(next_tick.max(source.now_s()));
        // Frames handled now arrived now (the node's clock): silence is judged by arrival.
        let now = source.now_s();
        observer.set_clock(now);
        match event {
            Event::End => break,
            Event::Input(Input::JointState(m)) => {
                if let Err(w) = observer.on_joint_state(&m) {
                    emit(Output::Warning(w));
                }
            }
            Event::Input(Input::Speech(m)) => {
                observer.on_speech(&m);
            }
            Event::Input(Input::ArmJointState(i, m)) => {
                if let Err(w) = observer.on_arm_joint_state(i, &m) {
                    emit(Output::Warning(w));
                }
            }
            Event::Input(Input::Skeleton(m)) => {
                let demo = observer.on_demonstrator(&m);
                demo.warnings.into_iter().for_each(|w| emit(Output::Warning(w)));
                demo.targets.into_iter().for_each(|(i, t)| emit(Output::FollowJoints(i, t)));
                summary.skeletons += 1;
                if demo.track_as_person {
                    let out = observer.on_skeleton(&m);
                    out.warnings.into_iter().for_each(|w| emit(Output::Warning(w)));
                    emit(Output::State(out.state));
                    if let Some(g) = out.gesture {
                        emit(Output::Gesture(g));
                    }
                }
            }
            Event::Deadline => {}
        }
        if now >= next_tick {
            next_tick = now + tick_period;
            if let Some(s) = observer.on_tick(now) {
                emit(Output::State(s));
            }
            if observer.params().publish_markers
                && let Some(m) = observer.markers(now)
            {
                emit(Output::Markers(m.clone()));
            }
        }
    }
    summary.states = observer.states();
    summary.gestures = observer.gestures();
    summary
}

/// Runs the node until Ctrl-C, `options.stop` or `options.duration_s`.
pub fn run(node: RosNode, mut observer: ObserverNode, options: &RunOptions) -> Result<RunSummary> {
    let mut source = DdsSource::new(node, options.start())?;
    source.add(&topics::JOINT_STATES, Input::JointState)?;
    source.add(&topics::SPEECH_COMMAND, Input::Speech)?;
    source.add(&topics::SKELETON, Input::Skeleton)?;
    let states = source.node().advertise(&topics::HUMAN_STATE)?;
    let gestures = source.node().advertise(&topics::GESTURE)?;
    let markers = if observer.params().publish_markers { Some(source.node().advertise(&topics::HUMAN_MARKERS)?) } else { None };
    let mut follow = Vec::new();
    let arms: Vec<String> = observer.retarget_arms().map(|a| a.arm.clone()).collect();
    for (i, arm) in arms.iter().enumerate() {
        let ns = if arm.is_empty() { source.node().namespace().to_owned() } else { format!("/{arm}") };
        source.add_in(&topics::JOINT_STATES, &ns, move |m| Input::ArmJointState(i, m))?;
        follow.push(source.node().advertise_in(&topics::FOLLOW_JOINTS, &ns)?);
        tracing::info!("imitation teaching: an Xsens demonstrator drives {}", topics::FOLLOW_JOINTS.name_in(&ns));
    }
    let mut warnings = Warnings::new(observer.params().warning_period_s);
    tracing::info!(
        "human_observer running: {} gesture templates, /human/state at >= {} Hz",
        observer.observer().classifier().map_or(0, |c| c.model().templates.len()),
        observer.params().state_rate_hz
    );
    let summary = run_loop(&mut source, &mut observer, &mut |out| {
        let failed = match out {
            Output::State(m) => states.send(m),
            Output::Gesture(m) => gestures.send(m),
            Output::Markers(m) => markers.as_ref().and_then(|p| p.send(m)),
            Output::FollowJoints(i, m) => follow[i].send(m),
            Output::Warning(w) => Some(w),
        };
        if let Some(w) = failed {
            warnings.warn(cowork_ros::monotonic_s(), &w);
        }
    });
    tracing::info!("human_observer stopped: {} skeleton frames, {} states, {} gestures", summary.skeletons, summary.states, summary.gestures);
    Ok(summary)
}
