//! [`run`]: the node over DDS. The calling thread moves messages from the subscriptions into
//! the [`Inbox`]; a worker thread takes the newest frame, runs fDED and publishes.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use cowork_msgs::msg::{LinkDistances, ObjectStream};
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState};
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_msgs::visualization_msgs::MarkerArray;
use cowork_ros::{Publisher, RosNode, qos};

use crate::inbox::{Batch, Inbox};
use crate::node::{FdedNode, RateLimitedWarnings, Skip};
use crate::{
    TOPIC_CAMERA_INFO, TOPIC_DEPTH, TOPIC_DISTANCES, TOPIC_JOINT_STATES, TOPIC_MANIPULATED, TOPIC_MARKERS, TOPIC_TF_STATIC,
};

/// Options of [`run`].
#[derive(Debug, Default, Clone)]
pub struct RunOptions {
    /// Stop after this many wall-clock seconds.
    pub duration_s: Option<f64>,
    /// Stop when this flag is raised (besides Ctrl-C / SIGTERM).
    pub stop: Option<Arc<AtomicBool>>,
}

/// What a run did, for the final log line and for tests.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunSummary {
    /// Frames processed and published.
    pub frames: u64,
    /// Frames skipped (bad input, missing camera info or joint state).
    pub skipped: u64,
    /// Frames replaced by a newer one before the worker took them.
    pub dropped: u64,
}

struct Outputs {
    distances: Publisher<LinkDistances>,
    markers: Option<Publisher<MarkerArray>>,
}

/// Runs the node until Ctrl-C, `options.stop` or `options.duration_s`.
pub fn run(mut node: RosNode, fded: FdedNode, options: &RunOptions) -> Result<RunSummary> {
    let images = node.subscription::<Image>(TOPIC_DEPTH, &qos::sensor_data())?;
    let infos = node.subscription::<CameraInfo>(TOPIC_CAMERA_INFO, &qos::sensor_data())?;
    // Best effort: a 1 kHz stream where only the newest sample counts. A reliable reader that
    // stalls (a frozen process) makes lwr_sim's writes fail for every reader and silenced
    // /joint_states graph-wide for ~20 s (tests/crosscheck/stranger.py chaos).
    let joints = node.subscription::<JointState>(TOPIC_JOINT_STATES, &qos::best_effort_depth(100))?;
    let tf_static = node.subscription::<TFMessage>(TOPIC_TF_STATIC, &qos::latched())?;
    let manipulated = node.subscription::<ObjectStream>(TOPIC_MANIPULATED, &qos::reliable_depth(100))?;
    let outputs = Outputs {
        distances: node.publisher::<LinkDistances>(TOPIC_DISTANCES, &qos::reliable())?,
        markers: if fded.params().publish_markers {
            Some(node.publisher::<MarkerArray>(TOPIC_MARKERS, &qos::reliable())?)
        } else {
            None
        },
    };
    tracing::info!("fded_distance running: backend request {:?}, waiting for camera info and depth", fded.request());

    let inbox = Arc::new(Inbox::new());
    let worker = {
        let inbox = Arc::clone(&inbox);
        std::thread::Builder::new()
            .name("fded_worker".into())
            .spawn(move || worker(fded, &inbox, &outputs))
            .context("cannot start the fDED worker thread")?
    };

    let started = Instant::now();
    let stop_requested = || {
        cowork_ros::shutdown::requested()
            || options.stop.as_ref().is_some_and(|s| s.load(Ordering::SeqCst))
            || options.duration_s.is_some_and(|d| started.elapsed().as_secs_f64() >= d)
    };
    while !stop_requested() && !worker.is_finished() {
        let mut any = false;
        while let Some(m) = tf_static.take() {
            inbox.post_tf_static(m);
            any = true;
        }
        if let Some(m) = infos.take_latest() {
            inbox.post_camera_info(m);
            any = true;
        }
        while let Some(m) = joints.take() {
            inbox.post_joint_state(m);
            any = true;
        }
        while let Some(m) = manipulated.take() {
            inbox.post_manipulated(m);
            any = true;
        }
        while let Some(m) = images.take() {
            inbox.post_image(m);
            any = true;
        }
        if !any {
            std::thread::sleep(Duration::from_millis(1));
        }
    }
    inbox.close();
    let summary = match worker.join() {
        Ok(r) => r?,
        Err(_) => anyhow::bail!("the fDED worker thread panicked"),
    };
    let summary = RunSummary { dropped: inbox.dropped_images(), ..summary };
    tracing::info!(
        "fded_distance stopped: {} frames processed, {} skipped, {} stale frames dropped",
        summary.frames,
        summary.skipped,
        summary.dropped
    );
    Ok(summary)
}

/// The worker: newest frame in, fDED, results out, until the inbox closes.
fn worker(mut fded: FdedNode, inbox: &Inbox, outputs: &Outputs) -> Result<RunSummary> {
    let mut warnings = RateLimitedWarnings::new(fded.params().warning_period_s);
    let report = cowork_ros::duration_s(fded.params().report_period_s);
    let mut last_report = Instant::now();
    let mut summary = RunSummary::default();
    let mut dropped_at_report = 0;
    while let Some(batch) = inbox.take(Duration::from_millis(100)) {
        let Batch { image, camera_info, joint_states, tf_static, manipulated } = batch;
        for m in &tf_static {
            if let Err(s) = fded.on_tf_static(m) {
                warnings.warn(&s);
            }
        }
        if let Some(m) = &camera_info
            && let Err(s) = fded.on_camera_info(m)
        {
            warnings.warn(&s);
        }
        for m in &joint_states {
            if let Err(s) = fded.on_joint_state(m) {
                warnings.warn(&s);
            }
        }
        for m in &manipulated {
            if let Err(s) = fded.on_manipulated(m) {
                warnings.warn(&s);
            }
        }
        if let Some(image) = image {
            match fded.on_depth(&image) {
                Ok(msg) => {
                    publish(&outputs.distances, msg, &mut warnings);
                    if let Some(p) = &outputs.markers {
                        publish(p, fded.markers(), &mut warnings);
                    }
                    summary.frames += 1;
                }
                Err(s) => {
                    summary.skipped += 1;
                    warnings.warn(&s);
                }
            }
            if let Some(s) = fded.take_notice() {
                warnings.warn(&s);
            }
        }
        let since = last_report.elapsed();
        if since >= report {
            last_report = Instant::now();
            let dropped = inbox.dropped_images();
            if let Some((median, max, n)) = fded.take_timing() {
                tracing::info!(
                    "fDED ({}): {n} frames in {:.1} s ({:.1} Hz), processing median {:.2} ms, max {:.2} ms; {} stale frames dropped, {} skipped in all",
                    fded.backend().unwrap_or("-"),
                    since.as_secs_f64(),
                    n as f64 / since.as_secs_f64(),
                    median * 1e3,
                    max * 1e3,
                    dropped - dropped_at_report,
                    summary.skipped
                );
            }
            dropped_at_report = dropped;
        }
    }
    summary.frames = fded.frames();
    Ok(summary)
}

/// Publishes a copy of `msg`; a failure is logged (rate-limited) and the node goes on.
fn publish<T: cowork_msgs::RosMessage>(publisher: &Publisher<T>, msg: &T, warnings: &mut RateLimitedWarnings) {
    if let Err(e) = publisher.publish(msg.clone()) {
        warnings.warn(&Skip { kind: "publish", message: format!("{}: publishing failed: {e:#}", publisher.topic()) });
    }
}
