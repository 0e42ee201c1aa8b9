//! [`run`]: the node over DDS. One thread takes every message, hands it to the node, publishes
//! what it produced and ticks at `tick_rate_hz`; a saver thread writes the database when it
//! changed. Why a second thread: a save syncs the file and its directory, which took 2.6 s on
//! a loaded machine, and meanwhile the `/lwr/world` reports of a demonstration (100 Hz of
//! simulated time, a depth-100 queue) overflowed — a whole NOA was never segmented. The saver
//! always writes the newest copy it was given; saves finish in order.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::Result;
use cowork_manager::Stamp;
use cowork_msgs::msg::{ActionCommand, Gesture, MotionCommand, MotionStatus, ObjectStream, RobotStream, WorldState};
use cowork_msgs::std_msgs::String as RosString;
use cowork_ros::{RosNode, qos};

use crate::node::{Outbox, RobotManagerNode, write_database};
use crate::topics;

/// Options of [`run`].
#[derive(Debug, Default, Clone)]
pub struct RunOptions {
    /// Stop after this many wall-clock seconds.
    pub duration_s: Option<f64>,
    /// Stop when this flag is raised (besides Ctrl-C / SIGTERM).
    pub stop: Option<Arc<AtomicBool>>,
}

/// Wall clock, s since the Unix epoch.
pub fn unix_s() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs())
}

/// Runs the node until Ctrl-C, `options.stop` or `options.duration_s`; returns it (with its
/// database) for tests.
pub fn run(mut node: RosNode, mut rm: RobotManagerNode, tick_rate_hz: f64, options: &RunOptions) -> Result<RobotManagerNode> {
    let world = node.subscription::<WorldState>(topics::WORLD, &qos::reliable_depth(100))?;
    let speech = node.subscription::<RosString>(topics::SPEECH, &qos::reliable())?;
    let actions = node.subscription::<ActionCommand>(topics::ACTION, &qos::reliable())?;
    let status = node.subscription::<MotionStatus>(topics::MOTION_STATUS, &qos::reliable_depth(10))?;
    let gestures = node.subscription::<Gesture>(topics::GESTURE, &qos::reliable())?;
    let motion_pub = node.publisher::<MotionCommand>(topics::MOTION_COMMAND, &qos::reliable_depth(10))?;
    let gripper_pub = node.publisher::<RosString>(topics::GRIPPER, &qos::reliable())?;
    let robot_pub = node.publisher::<RobotStream>(topics::ROBOT_STREAM, &qos::reliable_depth(100))?;
    let objects_pub = node.publisher::<ObjectStream>(topics::OBJECT_STREAM, &qos::reliable())?;
    let manipulated_pub = node.publisher::<ObjectStream>(topics::MANIPULATED, &qos::reliable_depth(100))?;
    tracing::info!(
        "robot_manager running: {} primitives in {}, waiting for {}",
        rm.manager().database().primitives.len(),
        rm.database_path().display(),
        topics::WORLD
    );
    let started = Instant::now();
    let stop_requested = || {
        cowork_ros::shutdown::requested()
            || options.stop.as_ref().is_some_and(|s| s.load(Ordering::SeqCst))
            || options.duration_s.is_some_and(|d| started.elapsed().as_secs_f64() >= d)
    };
    let mut out = Outbox::default();
    let period = 1.0 / tick_rate_hz;
    let mut next_tick = 0.0f64;
    let mut save_retry: Option<Instant> = None;
    let mut told_world = false;
    let (save_tx, save_rx) = std::sync::mpsc::channel::<cowork_manager::Database>();
    let (done_tx, done_rx) = std::sync::mpsc::channel::<Result<usize, String>>();
    let saver = {
        let path = rm.database_path().to_path_buf();
        std::thread::Builder::new().name("robot_manager-save".into()).spawn(move || {
            while let Ok(mut db) = save_rx.recv() {
                // Only the newest copy matters.
                while let Ok(newer) = save_rx.try_recv() {
                    db = newer;
                }
                let r = write_database(&path, &db).map(|()| db.primitives.len()).map_err(|e| e.to_string());
                if done_tx.send(r).is_err() {
                    break;
                }
            }
        })?
    };
    let path = rm.database_path().display().to_string();
    let report = |rm: &mut RobotManagerNode, r: Result<usize, String>, save_retry: &mut Option<Instant>| match r {
        Ok(n) => tracing::info!("primitive database saved: {n} primitives in {path}"),
        Err(e) => {
            rm.save_failed();
            *save_retry = Some(Instant::now());
            tracing::error!("cannot save the primitive database (retrying every second): {e}");
        }
    };
    while !stop_requested() {
        let stamp = Stamp { t: node.now().to_secs_f64(), unix_s: unix_s() };
        out.clear();
        let mut any = false;
        // Controller status and supervisor commands first, then the world that followed them.
        while let Some(m) = status.take() {
            rm.on_motion_status(&m, stamp, &mut out);
            any = true;
        }
        while let Some(m) = actions.take() {
            rm.on_action(&m, stamp, &mut out);
            any = true;
        }
        while let Some(m) = speech.take() {
            tracing::info!("speech: {:?}", m.data);
            rm.on_speech(&m, stamp, &mut out);
            any = true;
        }
        while let Some(m) = gestures.take() {
            rm.on_gesture(&m, stamp, &mut out);
            any = true;
        }
        while let Some(m) = world.take() {
            if !told_world {
                told_world = true;
                tracing::info!("first {} report: {} objects", topics::WORLD, m.objects.len());
            }
            rm.on_world(&m, stamp, &mut out);
            any = true;
        }
        if stamp.t >= next_tick || stamp.t + 2.0 * period < next_tick {
            next_tick = stamp.t + period;
            rm.tick(stamp, &mut out);
        }
        for m in out.motion.drain(..) {
            motion_pub.publish(m)?;
        }
        for m in out.gripper.drain(..) {
            gripper_pub.publish(m)?;
        }
        for m in out.robot_stream.drain(..) {
            robot_pub.publish(m)?;
        }
        for m in out.object_stream.drain(..) {
            objects_pub.publish(m)?;
        }
        for m in out.manipulated.drain(..) {
            manipulated_pub.publish(m)?;
        }
        while let Ok(r) = done_rx.try_recv() {
            report(&mut rm, r, &mut save_retry);
        }
        if rm.database_dirty() && save_retry.is_none_or(|t| t.elapsed() >= Duration::from_secs(1)) {
            save_retry = None;
            if let Some(db) = rm.take_changes()
                && save_tx.send(db).is_err()
            {
                anyhow::bail!("the primitive database saver stopped");
            }
        }
        if !any {
            std::thread::sleep(Duration::from_micros(500));
        }
    }
    // Let the saver finish what it was given, then save what is still unsaved here.
    drop(save_tx);
    if saver.join().is_err() {
        tracing::error!("the primitive database saver panicked");
    }
    while let Ok(r) = done_rx.try_recv() {
        report(&mut rm, r, &mut save_retry);
    }
    if rm.database_dirty() {
        rm.save_if_changed()
            .map_err(|e| anyhow::anyhow!("cannot save the primitive database {}: {e}", rm.database_path().display()))?;
    }
    tracing::info!("robot_manager stopped ({} warnings)", rm.warnings());
    Ok(rm)
}
