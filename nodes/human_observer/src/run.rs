//! [`run`]: the node over DDS, one loop: drain the subscriptions, handle, publish, tick.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::Result;
use cowork_msgs::RosMessage;
use cowork_msgs::msg::{Gesture, HumanState, Skeleton};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::String as RosString;
use cowork_msgs::visualization_msgs::MarkerArray;
use cowork_ros::{Publisher, RosNode, qos};

use crate::node::{ObserverNode, Warning, Warnings};
use crate::{TOPIC_GESTURE, TOPIC_JOINT_STATES, TOPIC_MARKERS, TOPIC_SKELETON, TOPIC_SPEECH, TOPIC_STATE};

/// Options of [`run`].
#[derive(Debug, Default, Clone)]
pub struct RunOptions {
    /// Stop after this many wall-clock seconds.
    pub duration_s: Option<f64>,
    /// Stop when this flag is raised (besides Ctrl-C / SIGTERM).
    pub stop: Option<Arc<AtomicBool>>,
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

/// Runs the node until Ctrl-C, `options.stop` or `options.duration_s`.
pub fn run(mut node: RosNode, mut observer: ObserverNode, options: &RunOptions) -> Result<RunSummary> {
    let skeletons = node.subscription::<Skeleton>(TOPIC_SKELETON, &qos::reliable())?;
    // Best effort: a 1 kHz stream where only the newest sample counts. A reliable reader that
    // stalls (a frozen process) makes lwr_sim's writes fail for every reader and silenced
    // /joint_states graph-wide for ~20 s (tests/crosscheck/stranger.py chaos).
    let joints = node.subscription::<JointState>(TOPIC_JOINT_STATES, &qos::best_effort_depth(100))?;
    let speech = node.subscription::<RosString>(TOPIC_SPEECH, &qos::reliable())?;
    let states = node.publisher::<HumanState>(TOPIC_STATE, &qos::reliable())?;
    let gestures = node.publisher::<Gesture>(TOPIC_GESTURE, &qos::reliable())?;
    let markers = if observer.params().publish_markers { Some(node.publisher::<MarkerArray>(TOPIC_MARKERS, &qos::reliable())?) } else { None };
    let mut warnings = Warnings::new(observer.params().warning_period_s);
    tracing::info!(
        "human_observer running: {} gesture templates, /human/state at >= {} Hz",
        observer.observer().classifier().map_or(0, |c| c.model().templates.len()),
        observer.params().state_rate_hz
    );
    let started = Instant::now();
    let mut summary = RunSummary::default();
    let stop_requested = || {
        cowork_ros::shutdown::requested()
            || options.stop.as_ref().is_some_and(|s| s.load(Ordering::SeqCst))
            || options.duration_s.is_some_and(|d| started.elapsed().as_secs_f64() >= d)
    };
    while !stop_requested() {
        let mut any = false;
        // Frames handled below arrived now (the node's clock): silence is judged by arrival.
        if node.clock_started() {
            observer.set_clock(node.now().to_secs_f64());
        }
        while let Some(m) = joints.take() {
            if let Err(w) = observer.on_joint_state(&m) {
                warnings.warn(&w);
            }
            any = true;
        }
        while let Some(m) = speech.take() {
            observer.on_speech(&m);
            any = true;
        }
        while let Some(m) = skeletons.take() {
            // Taken now: a batch that takes long to handle must not look silent at the tick.
            if node.clock_started() {
                observer.set_clock(node.now().to_secs_f64());
            }
            let out = observer.on_skeleton(&m);
            summary.skeletons += 1;
            for w in &out.warnings {
                warnings.warn(w);
            }
            publish(&states, out.state, &mut warnings);
            if let Some(g) = out.gesture {
                publish(&gestures, g, &mut warnings);
            }
            any = true;
        }
        if node.clock_started() {
            let now = node.now().to_secs_f64();
            if let Some(s) = observer.on_tick(now) {
                publish(&states, s, &mut warnings);
            }
            if let Some(p) = &markers
                && let Some(m) = observer.markers(now)
            {
                publish(p, m.clone(), &mut warnings);
            }
        }
        if !any {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    summary.states = observer.states();
    summary.gestures = observer.gestures();
    tracing::info!("human_observer stopped: {} skeleton frames, {} states, {} gestures", summary.skeletons, summary.states, summary.gestures);
    Ok(summary)
}

/// Publishes `msg`; a failure is logged (rate-limited) and the node goes on.
fn publish<T: RosMessage>(publisher: &Publisher<T>, msg: T, warnings: &mut Warnings) {
    if let Err(e) = publisher.publish(msg) {
        warnings.warn(&Warning { kind: format!("publish:{}", publisher.topic()), message: format!("{}: publishing failed: {e:#}", publisher.topic()) });
    }
}
