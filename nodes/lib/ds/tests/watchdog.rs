//! Watchdog: when the distance (or human) stream stops mid-motion the robot brakes to rest
//! within the staleness bound plus the braking time, reports a held fault, and resumes when
//! fresh data returns.

mod common;

use cowork_ds::{ControlOutput, ControllerConfig, DsController, Fault, HoldReason, Status, Stream};
use nalgebra::Vector3;

fn stream_loss(stream: Stream) {
    let model = common::lwr();
    let cfg = ControllerConfig::default();
    let mut ctl = DsController::new(model.clone(), cfg).expect("config");
    let dt = cfg.period_s;
    let mut q = common::q_start();
    let goal = common::tip_position(&model, &q) + Vector3::new(0.0, 0.4, -0.1);
    let cmd = common::command(common::constant_speed(0.3), goal);
    let mut out = ControlOutput::default();
    let lost_at = 0.5;
    let back_at = 1.5;
    let mut speed_at_stale = None;
    let mut stopped_at = None;
    let mut resumed_at = None;
    let mut converged = false;
    for k in 0..8000 {
        let t = k as f64 * dt;
        let mut input = common::input(q, cmd, t);
        let fresh = !(lost_at..back_at).contains(&t);
        let stamp = if fresh { t } else { lost_at - dt };
        match stream {
            Stream::Distances => input.distances.stamp = stamp,
            Stream::Human => input.human.stamp = stamp,
            // Joint-state staleness is judged by the node adapter (`DsController::hold`).
            Stream::JointStates => unreachable!("not a controller input stream"),
        }
        let res = ctl.step(&input, &mut out);
        let age = t - stamp;
        if age <= cfg.stale_after_s {
            assert!(res.is_ok(), "t {t}: {res:?}");
            if !fresh {
                // Still moving on the last data inside the bound.
                assert!(out.qdot.norm() > 0.0);
            }
        } else {
            let fault = res.expect_err("stale input must fault");
            assert!(
                matches!(fault, Fault::Stale { stream: s, .. } if s == stream),
                "{fault:?}"
            );
            assert!(matches!(out.status, Status::Held(HoldReason::Fault(_))));
            let speed = out.qdot.amax();
            let v0 = *speed_at_stale.get_or_insert(speed + cfg.brake_deceleration * dt);
            if speed == 0.0 && stopped_at.is_none() {
                stopped_at = Some(t);
                let bound = lost_at + cfg.stale_after_s + v0 / cfg.brake_deceleration + 2.0 * dt;
                assert!(t <= bound, "stopped at {t} s, bound {bound} s");
            }
        }
        if t >= back_at && resumed_at.is_none() && out.qdot.norm() > 0.0 {
            resumed_at = Some(t);
        }
        converged |= t > back_at && out.status == Status::Converged;
        q += out.qdot * dt;
    }
    let stopped_at = stopped_at.expect("robot stopped");
    let resumed_at = resumed_at.expect("robot resumed");
    eprintln!(
        "{stream}: lost at {lost_at} s, braking from {:.3} rad/s, at rest at {stopped_at:.3} s, resumed at {resumed_at:.3} s",
        speed_at_stale.unwrap_or(0.0)
    );
    assert!(resumed_at - back_at < 0.01);
    assert!(converged, "goal reached after the data returned");
}

#[test]
fn distance_stream_loss_stops_then_resumes() {
    stream_loss(Stream::Distances);
}

#[test]
fn human_stream_loss_stops_then_resumes() {
    stream_loss(Stream::Human);
}

#[test]
fn never_received_data_is_stale() {
    let model = common::lwr();
    let mut ctl = DsController::new(model, ControllerConfig::default()).expect("config");
    let mut input = common::input(
        common::q_start(),
        common::command(common::linear(1.0), Vector3::new(0.4, 0.0, 0.5)),
        3.0,
    );
    input.distances = cowork_ds::Distances::NEVER;
    let mut out = ControlOutput::default();
    let err = ctl.step(&input, &mut out).expect_err("no distances yet");
    assert!(
        matches!(
            err,
            Fault::Stale {
                stream: Stream::Distances,
                ..
            }
        ),
        "{err}"
    );
    assert_eq!(out.qdot.norm(), 0.0);
}

/// A clock that went back (lwr_sim restarted, a looped `/clock`) makes the last data look
/// "fresh" by a plain `age <= bound` check (negative age): it must hold the robot instead,
/// for both streams, and name the cause.
#[test]
fn data_stamped_in_the_future_is_stale() {
    let model = common::lwr();
    let cfg = ControllerConfig::default();
    let q = common::q_start();
    let goal = common::tip_position(&model, &q) + Vector3::new(0.0, 0.2, 0.0);
    for stream in [Stream::Distances, Stream::Human] {
        let mut ctl = DsController::new(model.clone(), cfg).expect("config");
        let mut out = ControlOutput::default();
        // Within the tolerance (a clock a tick behind its sender): fine.
        let mut input = common::input(q, common::command(common::linear(1.0), goal), 3.0);
        let ahead = |s: &mut cowork_ds::ControlInput, by: f64| match stream {
            Stream::Distances => s.distances.stamp = s.time + by,
            _ => s.human.stamp = s.time + by,
        };
        ahead(&mut input, 0.5 * cfg.future_tolerance_s);
        ctl.step(&input, &mut out).expect("a stamp a little ahead is accepted");
        // The clock jumped back 5 s: the data is 5 s in the future.
        ahead(&mut input, 5.0);
        let err = ctl.step(&input, &mut out).expect_err("data from the future");
        assert!(matches!(err, Fault::Stale { stream: s, age_s, .. } if s == stream && age_s < 0.0), "{err:?}");
        assert!(err.to_string().contains("negative"), "{err}");
        assert!(matches!(out.status, Status::Held(HoldReason::Fault(_))));
    }
}
