//! [`run`]: the node over DDS. One thread takes every message, hands it to the node, publishes
//! what it produced and ticks at `tick_rate_hz`; a saver thread writes the database when it
//! changed. Why a second thread: a save syncs the file and its directory, which took 2.6 s on
//! a loaded machine, and meanwhile the `/lwr/world` reports of a demonstration (100 Hz of
//! simulated time, a depth-100 queue) overflowed — a whole NOA was never segmented. The saver
//! always writes the newest copy it was given; saves finish in order.

use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::Result;
use cowork_manager::Stamp;
use cowork_msgs::msg::{ActionCommand, Gesture, MotionStatus, WorldState};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::String as RosString;
use cowork_msgs::topics;
use cowork_ros::{DdsSource, Event, InputSource, RosNode, RunOptions, Warnings};

use crate::node::{Outbox, RobotManagerNode, write_database};

/// What the node takes in.
#[derive(Debug, Clone)]
pub enum Input {
    /// `/motion/status`.
    MotionStatus(MotionStatus),
    /// `/supervisor/action`.
    Action(ActionCommand),
    /// `/speech_command`.
    Speech(RosString),
    /// `/human/gesture`.
    Gesture(Gesture),
    /// `/lwr/world`.
    World(WorldState),
    /// `/joint_states` (only when the manager previews motions).
    JointState(JointState),
}

/// Hands every input of `source` to `rm` and ticks it at `tick_rate_hz` (source clock) until
/// the source ends; after every input or tick, `after(rm, outbox)` publishes what was
/// produced (the outbox is cleared before the next one). `unix_s` stamps learned data.
pub fn run_loop<S: InputSource<Input>>(
    source: &mut S,
    rm: &mut RobotManagerNode,
    tick_rate_hz: f64,
    unix_s: &dyn Fn() -> u64,
    after: &mut dyn FnMut(&mut RobotManagerNode, &mut Outbox) -> Result<()>,
) -> Result<()> {
    let period = 1.0 / tick_rate_hz;
    let mut next_tick = f64::NEG_INFINITY;
    let mut out = Outbox::default();
    let mut told_world = false;
    loop {
        let event = source.next(next_tick.max(source.now_s()));
        let stamp = Stamp { t: source.now_s(), unix_s: unix_s() };
        out.clear();
        match event {
            Event::End => break,
            Event::Input(Input::MotionStatus(m)) => rm.on_motion_status(&m, stamp, &mut out),
            Event::Input(Input::Action(m)) => rm.on_action(&m, stamp, &mut out),
            Event::Input(Input::Speech(m)) => {
                tracing::info!("speech: {:?}", cowork_ros::quote(&m.data));
                rm.on_speech(&m, stamp, &mut out);
            }
            Event::Input(Input::Gesture(m)) => rm.on_gesture(&m, stamp, &mut out),
            Event::Input(Input::JointState(m)) => rm.on_joint_state(&m, stamp, &mut out),
            Event::Input(Input::World(m)) => {
                if !told_world {
                    told_world = true;
                    tracing::info!("first {} report: {} objects", topics::WORLD.name, m.objects.len());
                }
                rm.on_world(&m, stamp, &mut out);
            }
            Event::Deadline => {}
        }
        // Ticks at the rate, and again at once when the clock went back (a new simulation).
        if stamp.t >= next_tick || stamp.t + 2.0 * period < next_tick {
            next_tick = stamp.t + period;
            rm.tick(stamp, &mut out);
        }
        rm.take_warnings(&mut out.warnings);
        after(rm, &mut out)?;
    }
    Ok(())
}

/// Wall clock, s since the Unix epoch.
pub fn unix_s() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs())
}

/// Runs the node until Ctrl-C, `options.stop` or `options.duration_s`; returns it (with its
/// database) for tests.
pub fn run(node: RosNode, mut rm: RobotManagerNode, tick_rate_hz: f64, options: &RunOptions) -> Result<RobotManagerNode> {
    let mut source = DdsSource::new(node, options.start())?;
    // Controller status and supervisor commands first, then the world that followed them.
    source.add(&topics::MOTION_STATUS, Input::MotionStatus)?;
    source.add(&topics::SUPERVISOR_ACTION, Input::Action)?;
    source.add(&topics::SPEECH_COMMAND, Input::Speech)?;
    source.add(&topics::GESTURE, Input::Gesture)?;
    source.add(&topics::WORLD, Input::World)?;
    if rm.previews() {
        source.add(&topics::JOINT_STATES, Input::JointState)?;
    }
    let motion_pub = source.node().advertise(&topics::MOTION_COMMAND)?;
    let gripper_pub = source.node().advertise(&topics::GRIPPER_COMMAND)?;
    let robot_pub = source.node().advertise(&topics::ROBOT_STREAM)?;
    let objects_pub = source.node().advertise(&topics::OBJECT_STREAM)?;
    let manipulated_pub = source.node().advertise(&topics::MANIPULATED_OBJECTS)?;
    let mut warnings = Warnings::new(rm.params().warning_period_s);
    tracing::info!(
        "robot_manager running: {} primitives in {}, waiting for {}",
        rm.manager().database().primitives.len(),
        rm.database_path().display(),
        topics::WORLD.name
    );
    let mut save_retry: Option<Instant> = None;
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
    run_loop(&mut source, &mut rm, tick_rate_hz, &unix_s, &mut |rm, out| {
        let now = cowork_ros::monotonic_s();
        let sent = out
            .motion
            .drain(..)
            .map(|m| motion_pub.send(m))
            .chain(out.gripper.drain(..).map(|m| gripper_pub.send(m)))
            .chain(out.robot_stream.drain(..).map(|m| robot_pub.send(m)))
            .chain(out.object_stream.drain(..).map(|m| objects_pub.send(m)))
            .chain(out.manipulated.drain(..).map(|m| manipulated_pub.send(m)));
        for w in sent.flatten().chain(out.warnings.drain(..)) {
            warnings.warn(now, &w);
        }
        while let Ok(r) = done_rx.try_recv() {
            report(rm, r, &mut save_retry);
        }
        if rm.database_dirty() && save_retry.is_none_or(|t| t.elapsed() >= Duration::from_secs(1)) {
            save_retry = None;
            if let Some(db) = rm.take_changes()
                && save_tx.send(db).is_err()
            {
                anyhow::bail!("the primitive database saver stopped");
            }
        }
        Ok(())
    })?;
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
