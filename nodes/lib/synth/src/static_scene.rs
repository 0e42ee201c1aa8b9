//! `static-scene`: the robot and the boxes only (stacking scene), the robot held still in a few
//! joint configurations, one per segment, for the fDED tables (thesis Sec. 5.1.2, Tables
//! 5.1–5.2). Each segment starts with a 1 s joint-space move (minimum jerk) to its
//! configuration; the rest of the segment is still.

use cowork_robot::{DOF, JointVector};

use crate::depth::DepthRig;
use crate::plan::min_jerk;
use crate::runner::Runner;
use crate::{Result, SynthError};

/// Joint configurations held in turn, deg (the first is the scene's ready pose). All keep the
/// arm above the table and in the camera's view.
pub const CONFIGURATIONS_DEG: [[f64; DOF]; 5] = [
    [0.0, 30.0, 0.0, 90.0, 0.0, 60.0, 0.0],
    [35.0, 45.0, 0.0, 60.0, 0.0, 75.0, 0.0],
    [-40.0, 50.0, 20.0, 75.0, -10.0, 55.0, 30.0],
    [10.0, 60.0, 0.0, 40.0, 0.0, 80.0, 0.0],
    [-20.0, 20.0, -30.0, 100.0, 20.0, 60.0, 45.0],
];

/// Length of each segment when no duration is given, s.
pub const SEGMENT_S: f64 = 2.0;
/// Time of the move at the start of a segment, s.
pub const MOVE_S: f64 = 1.0;

/// Runs the scenario; the bag's duration is split evenly over the configurations.
pub(crate) fn run_static(run: &mut Runner<'_>, depth: &mut Option<DepthRig>) -> Result<()> {
    let segment_ns = (run.duration_s() / CONFIGURATIONS_DEG.len() as f64 * 1e9).round() as i64;
    if segment_ns < ((MOVE_S + 0.1) * 1e9) as i64 {
        return Err(SynthError::BadOption {
            option: "--duration",
            value: run.duration_s().to_string(),
            reason: format!(
                "static-scene needs at least {:.1} s ({} segments of a {MOVE_S} s move and a still part)",
                (MOVE_S + 0.1) * CONFIGURATIONS_DEG.len() as f64,
                CONFIGURATIONS_DEG.len()
            ),
        });
    }
    let targets: Vec<JointVector> = CONFIGURATIONS_DEG
        .iter()
        .map(|c| JointVector::from_iterator(c.iter().map(|d| d.to_radians())))
        .collect();
    let mut from = *run.sim.joint_positions();
    let mut segment = usize::MAX;
    while !run.done() {
        let now = run.now();
        let k = usize::try_from(now / segment_ns).unwrap_or(0).min(targets.len() - 1);
        if k != segment {
            segment = k;
            from = *run.sim.joint_positions();
        }
        let into = (now - k as i64 * segment_ns) as f64 * 1e-9;
        if into < MOVE_S {
            let (s, ds) = min_jerk(into / MOVE_S);
            let delta = targets[k] - from;
            let desired = from + delta * s;
            let qd = delta * (ds / MOVE_S) + (desired - run.sim.joint_positions()) * 20.0;
            run.sim
                .set_velocity_command(qd.as_slice())
                .map_err(|source| SynthError::Command { what: "a joint velocity command", source })?;
        } else {
            run.sim.hold();
        }
        run.step()?;
        if let Some(rig) = depth.as_mut() {
            while let Some(t) = rig.due(run.now()) {
                rig.write_frame(&mut run.streams, t, &run.sim, &[])?;
            }
        }
    }
    Ok(())
}
