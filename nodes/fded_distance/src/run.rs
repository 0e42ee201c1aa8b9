//! [`run`]: the node over DDS. The calling thread moves messages from the subscriptions into
//! the [`Inbox`]; a worker thread takes the newest frame, runs fDED and publishes.

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use cowork_msgs::msg::{LinkDistances, ObjectStream};
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState};
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_msgs::topics;
use cowork_msgs::visualization_msgs::MarkerArray;
use cowork_ros::{DdsSource, Event, InputSource, Publisher, RosNode, RunOptions, Warnings};

use crate::inbox::{Batch, Inbox};
use crate::node::FdedNode;

/// What the node takes in.
#[derive(Debug, Clone)]
pub enum Input {
    /// `/camera/depth/image_raw`.
    Depth(Image),
    /// `/camera/depth/camera_info`.
    CameraInfo(CameraInfo),
    /// `/joint_states`.
    JointState(JointState),
    /// `/tf_static`: the camera pose.
    TfStatic(TFMessage),
    /// `/manipulated_objects`.
    Manipulated(ObjectStream),
}

/// Moves every input of `source` into `inbox` (the worker takes them from there) until the
/// source ends or `finished()` says the worker stopped.
pub fn feed<S: InputSource<Input>>(source: &mut S, inbox: &Inbox, finished: &dyn Fn() -> bool) {
    while !finished() {
        match source.next(f64::INFINITY) {
            Event::Input(input) => post(inbox, input),
            Event::Deadline => {}
            Event::End => break,
        }
    }
}

fn post(inbox: &Inbox, input: Input) {
    match input {
        Input::Depth(m) => inbox.post_image(m),
        Input::CameraInfo(m) => inbox.post_camera_info(m),
        Input::JointState(m) => inbox.post_joint_state(m),
        Input::TfStatic(m) => inbox.post_tf_static(m),
        Input::Manipulated(m) => inbox.post_manipulated(m),
    }
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
pub fn run(node: RosNode, fded: FdedNode, options: &RunOptions) -> Result<RunSummary> {
    let mut source = DdsSource::new(node, options.start())?;
    source.add(&topics::TF_STATIC, Input::TfStatic)?;
    source.add(&topics::DEPTH_CAMERA_INFO, Input::CameraInfo)?;
    // Best effort (the topic's reader delivery): a 1 kHz stream where only the newest sample
    // counts. A reliable reader that stalls (a frozen process) makes lwr_sim's writes fail for
    // every reader and silenced /joint_states graph-wide for ~20 s (stranger.py chaos).
    source.add(&topics::JOINT_STATES, Input::JointState)?;
    source.add(&topics::MANIPULATED_OBJECTS, Input::Manipulated)?;
    source.add(&topics::DEPTH_IMAGE, Input::Depth)?;
    let outputs = Outputs {
        distances: source.node().advertise(&topics::FDED_DISTANCES)?,
        markers: if fded.params().publish_markers { Some(source.node().advertise(&topics::FDED_MARKERS)?) } else { None },
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
    feed(&mut source, &inbox, &|| worker.is_finished());
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

/// What the node puts out, borrowed from it.
#[derive(Debug, Clone, Copy)]
pub enum Output<'a> {
    /// `/fded/distances`.
    Distances(&'a LinkDistances),
    /// `/fded/markers` (when `publish_markers`).
    Markers(&'a MarkerArray),
    /// A warning for the log (rate-limited by the caller).
    Warning(&'a cowork_ros::Warning),
}

/// Everything that waited in the inbox, handled in order: transforms, intrinsics, joint
/// states, manipulated objects, then the newest depth frame.
fn handle_batch(fded: &mut FdedNode, batch: Batch, summary: &mut RunSummary, emit: &mut dyn FnMut(Output<'_>)) {
    let Batch { image, camera_info, joint_states, tf_static, manipulated } = batch;
    let warn = |r: Result<(), cowork_ros::Warning>, emit: &mut dyn FnMut(Output<'_>)| {
        if let Err(w) = r {
            emit(Output::Warning(&w));
        }
    };
    for m in &tf_static {
        warn(fded.on_tf_static(m), emit);
    }
    if let Some(m) = &camera_info {
        warn(fded.on_camera_info(m), emit);
    }
    for m in &joint_states {
        warn(fded.on_joint_state(m), emit);
    }
    for m in &manipulated {
        warn(fded.on_manipulated(m), emit);
    }
    if let Some(image) = image {
        match fded.on_depth(&image) {
            Ok(msg) => {
                emit(Output::Distances(msg));
                if fded.params().publish_markers {
                    emit(Output::Markers(fded.markers()));
                }
                summary.frames += 1;
            }
            Err(s) => {
                summary.skipped += 1;
                emit(Output::Warning(&s));
            }
        }
        if let Some(s) = fded.take_notice() {
            emit(Output::Warning(&s));
        }
    }
}

/// The node without threads, for golden tests: every input of `source` goes through the
/// inbox and is handled at once (as a worker that is never late), until the source ends.
pub fn run_scripted<S: InputSource<Input>>(source: &mut S, fded: &mut FdedNode, emit: &mut dyn FnMut(Output<'_>)) -> RunSummary {
    let inbox = Inbox::new();
    let mut summary = RunSummary::default();
    loop {
        match source.next(f64::INFINITY) {
            Event::Input(input) => post(&inbox, input),
            Event::Deadline => continue,
            Event::End => break,
        }
        if let Some(batch) = inbox.take(Duration::ZERO) {
            handle_batch(fded, batch, &mut summary, emit);
        }
    }
    summary
}

/// The worker: newest frame in, fDED, results out, until the inbox closes.
fn worker(mut fded: FdedNode, inbox: &Inbox, outputs: &Outputs) -> Result<RunSummary> {
    let mut warnings = Warnings::new(fded.params().warning_period_s);
    let report = cowork_ros::duration_s(fded.params().report_period_s);
    let mut last_report = Instant::now();
    let mut summary = RunSummary::default();
    let mut dropped_at_report = 0;
    while let Some(batch) = inbox.take(Duration::from_millis(100)) {
        handle_batch(&mut fded, batch, &mut summary, &mut |out| {
            let failed = match out {
                Output::Distances(m) => outputs.distances.send(m.clone()),
                Output::Markers(m) => outputs.markers.as_ref().and_then(|p| p.send(m.clone())),
                Output::Warning(w) => Some(w.clone()),
            };
            if let Some(w) = failed {
                warnings.warn(cowork_ros::monotonic_s(), &w);
            }
        });
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
