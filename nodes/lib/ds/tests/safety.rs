//! Link-distance safety (`cowork_ds::safety`): what eq. 5.13 alone cannot do with the
//! orientation held (one redundant DoF) — a sphere on the forearm's path, and a "hand" that
//! moves into the forearm and holds there — the damper does: the arm holds at the stop
//! distance instead of pushing in, retreats from an approaching obstacle, and resumes when it
//! leaves. The end-effector links are left to the DS modulation (and never damped while a
//! command turns end-effector avoidance off, the handover).

mod common;

use cowork_ds::{ControlOutput, ControllerConfig, DsController, LinkDistance, Status};
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use nalgebra::{Point3, Vector3};

struct Run {
    /// Smallest distance of any non end-effector link point to the sphere surface (m).
    min_distance: f64,
    reached: bool,
    /// When the goal was first reached (s).
    reached_at: Option<f64>,
    safety_steps: usize,
    /// Steps where the damper gave up the end-effector task (not met in its null space alone).
    overriding_steps: usize,
    elbow_path: Vec<Vector3<f64>>,
    tool_path: Vec<Vector3<f64>>,
}

/// Sphere centre (m) and radius at time t (s).
type Obstacle<'a> = &'a dyn Fn(f64) -> (Point3<f64>, f64, Vector3<f64>);

/// `scene`: the obstacle is a known scene object (`Distances::scene_object`).
fn run(model: &RobotModel, safety: bool, obstacle: Option<Obstacle<'_>>, seconds: f64, reach_y: f64) -> Run {
    run_with(model, safety, obstacle, seconds, reach_y, false)
}

fn run_with(model: &RobotModel, safety: bool, obstacle: Option<Obstacle<'_>>, seconds: f64, reach_y: f64, scene: bool) -> Run {
    let mut cfg = ControllerConfig::default();
    cfg.safety.enabled = safety;
    run_cfg(model, cfg, obstacle, seconds, Vector3::new(0.0, reach_y, 0.0), scene)
}

/// The tool moves by `reach` (m, base frame) from the start pose.
fn run_cfg(model: &RobotModel, cfg: ControllerConfig, obstacle: Option<Obstacle<'_>>, seconds: f64, reach: Vector3<f64>, scene: bool) -> Run {
    let points = common::link_points(model, 1);
    let q0 = JointVector::from_row_slice(&[0.0, 0.6, 0.0, -1.3, 0.0, 0.7, 0.0]);
    let x0 = common::tip_position(model, &q0);
    let goal = x0 + reach;
    // The thesis's layers stay on: end-effector modulation and null-space link avoidance.
    let mut ctl = DsController::new(model.clone(), cfg).expect("config");
    let ee_first = ctl.end_effector_first_link();
    let elbow = model.joint_link(3);
    let mut cmd = common::command(common::constant_speed(0.3), goal);
    cmd.orientation = Some(model.link_pose(&q0, model.tip_link()).rotation);
    let mut q = q0;
    let mut poses = LinkPoses::new();
    let mut out = ControlOutput::default();
    let mut r = Run {
        min_distance: f64::INFINITY,
        reached: false,
        reached_at: None,
        safety_steps: 0,
        overriding_steps: 0,
        elbow_path: Vec::new(),
        tool_path: Vec::new(),
    };
    let arm: Vec<_> = points[..ee_first].to_vec();
    for k in 0..(seconds * 1000.0) as usize {
        let t = k as f64 * 1e-3;
        model.forward_kinematics(&q, &mut poses);
        r.elbow_path.push(poses.get(elbow).translation.vector);
        r.tool_path.push(common::tip_position(model, &q));
        let mut input = common::input(q, cmd, t);
        if let Some(obstacle) = obstacle {
            let (c, rad, v) = obstacle(t);
            r.min_distance = r.min_distance.min(common::min_sphere_distance(&poses, &arm, &c, rad));
            // Distances measured 33 ms ago (one camera frame), as fDED delivers them.
            input.distances = common::sphere_distances(&poses, &points, &c, rad, &v, t);
            input.distances.stamp = t - 0.033;
            input.distances.scene_object = [scene; cowork_robot::MAX_LINKS];
        }
        ctl.step(&input, &mut out).expect("step");
        r.safety_steps += usize::from(out.diagnostics.safety.active);
        r.overriding_steps += usize::from(out.diagnostics.safety.link.is_some());
        r.reached |= out.status == Status::Converged;
        if r.reached && r.reached_at.is_none() {
            r.reached_at = Some(t);
        }
        q += out.qdot * 1e-3;
    }
    r
}

/// A sphere on the elbow's path with the orientation held: eq. 5.13's single redundant DoF
/// lets the arm come within a few cm; the damper holds it at the stop distance (the goal then
/// stays out of reach while the sphere is there — holding is the point).
#[test]
fn forearm_holds_before_a_static_obstacle() {
    let model = common::lwr();
    let free = run(&model, false, None, 4.0, 0.45);
    let first = free.elbow_path[0];
    // On the elbow's path, 0.25 m from where it starts.
    let on_path = free.elbow_path.iter().find(|p| (*p - first).norm() >= 0.25).copied().expect("the elbow moves 0.25 m");
    let radius = 0.06;
    let c = Point3::from(on_path);
    let sphere = move |_t: f64| (c, radius, Vector3::zeros());
    let blind = run(&model, false, Some(&sphere), 4.0, 0.45);
    let safe = run(&model, true, Some(&sphere), 4.0, 0.45);
    let stop = ControllerConfig::default().safety.stop_distance;
    eprintln!(
        "static sphere on the forearm's path: eq. 5.13 alone min {:.4} m; with the damper {:.4} m \
         (stop distance {stop} m, damper active {} steps, goal reached {})",
        blind.min_distance, safe.min_distance, safe.safety_steps, safe.reached
    );
    // Eq. 5.13 alone (one redundant DoF) lets the arm well inside the stop distance here.
    assert!(blind.min_distance < stop - 0.03, "the scene must come close without the damper: {}", blind.min_distance);
    assert!(safe.safety_steps > 0);
    // Sampled link points (the damper sees the closest vertex of each link): a few mm of slack.
    assert!(safe.min_distance > stop - 0.01, "damper let the arm close to {} m", safe.min_distance);
}

/// The same sphere as a known scene object (the coffee jar beside the cup): the task works
/// next to it, so the damper lets the forearm come to the scene stop distance — closer than to
/// a person, never into it.
#[test]
fn forearm_comes_closer_to_a_known_scene_object_but_not_into_it() {
    let model = common::lwr();
    let free = run(&model, false, None, 4.0, 0.45);
    let first = free.elbow_path[0];
    let on_path = free.elbow_path.iter().find(|p| (*p - first).norm() >= 0.25).copied().expect("the elbow moves 0.25 m");
    let c = Point3::from(on_path);
    // Larger than the first test's sphere, so that eq. 5.13 alone comes within the scene
    // stop distance.
    let sphere = move |_t: f64| (c, 0.10, Vector3::zeros());
    let blind = run(&model, false, Some(&sphere), 4.0, 0.45);
    let person = run_with(&model, true, Some(&sphere), 4.0, 0.45, false);
    let object = run_with(&model, true, Some(&sphere), 4.0, 0.45, true);
    let s = ControllerConfig::default().safety;
    eprintln!(
        "static sphere (r 0.10 m) on the forearm's path: eq. 5.13 alone min {:.4} m; damper, as an unknown obstacle {:.4} m, \
         as a scene object {:.4} m (stop distances {} / {} m, active {} / {} steps)",
        blind.min_distance,
        person.min_distance, object.min_distance, s.stop_distance, s.scene_stop_distance, person.safety_steps, object.safety_steps
    );
    assert!(blind.min_distance < s.scene_stop_distance, "must come close without the damper: {}", blind.min_distance);
    // Sampled link points on a larger sphere: 1.5 cm of slack.
    assert!(person.min_distance > s.stop_distance - 0.015, "{}", person.min_distance);
    assert!(object.safety_steps > 0, "the damper still acts on a scene object");
    assert!(object.min_distance > s.scene_stop_distance - 0.01, "pushed into the object: {} m", object.min_distance);
    assert!(object.min_distance < s.stop_distance - 0.03, "held as far as from a person: {} m", object.min_distance);
}

/// The pour's stall, reduced: the tool holds its pose while a known scene object stands 1.5 cm
/// beside the elbow, inside the scene stop distance, on the side the swivel can turn away from
/// (the put-back bottle beside the jar poured over the cup). Met in the end-effector task's
/// null space first, the elbow swivels off to the stop distance and the tool stays where it is;
/// with the damper overriding the task at once (as before), the retreat drags the tool along.
#[test]
fn a_scene_object_beside_the_elbow_is_cleared_by_the_swivel_and_the_tool_stays() {
    let model = common::lwr();
    let points = common::link_points(&model, 1);
    let q0 = common::q_start();
    let mut poses = LinkPoses::new();
    model.forward_kinematics(&q0, &mut poses);
    let elbow = model.joint_link(3);
    let ee_first = DsController::new(model.clone(), ControllerConfig::default()).expect("config").end_effector_first_link();
    let arm: Vec<_> = points[..ee_first].to_vec();
    // The swivel moves the elbow across the arm's plane: the sphere sits on that side, its
    // surface 1.5 cm from the closest arm point (bisection on the offset).
    let radius = 0.05;
    let side = {
        let (shoulder, wrist) = (poses.get(model.joint_link(1)).translation.vector, poses.get(model.joint_link(5)).translation.vector);
        let e = poses.get(elbow).translation.vector;
        let axis = (wrist - shoulder).normalize();
        axis.cross(&(e - shoulder)).normalize()
    };
    let at = |k: f64| Point3::from(poses.get(elbow).translation.vector + side * k);
    let (mut lo, mut hi) = (0.0, 0.5);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if common::min_sphere_distance(&poses, &arm, &at(mid), radius) < 0.015 { lo = mid } else { hi = mid }
    }
    let c = at(hi);
    let hold = common::tip_position(&model, &q0);
    let run = |null_space_first: bool| {
        let mut cfg = ControllerConfig::default();
        cfg.safety.null_space_first = null_space_first;
        let mut ctl = DsController::new(model.clone(), cfg).expect("config");
        let mut cmd = common::command(common::linear(2.0), hold);
        cmd.orientation = Some(model.link_pose(&q0, model.tip_link()).rotation);
        let (mut q, mut out, mut poses) = (q0, ControlOutput::default(), LinkPoses::new());
        let (mut tool_off, mut overriding) = (0.0_f64, 0usize);
        for k in 0..2000 {
            let t = k as f64 * 1e-3;
            model.forward_kinematics(&q, &mut poses);
            let mut input = common::input(q, cmd, t);
            input.distances = common::sphere_distances(&poses, &points, &c, radius, &Vector3::zeros(), t);
            input.distances.scene_object = [true; cowork_robot::MAX_LINKS];
            ctl.step(&input, &mut out).expect("step");
            overriding += usize::from(out.diagnostics.safety.link.is_some());
            q += out.qdot * 1e-3;
            tool_off = tool_off.max((common::tip_position(&model, &q) - hold).norm());
        }
        model.forward_kinematics(&q, &mut poses);
        (common::min_sphere_distance(&poses, &arm, &c, radius), tool_off, overriding)
    };
    let (swivel_d, swivel_off, swivel_overriding) = run(true);
    let (override_d, override_off, override_overriding) = run(false);
    let s = ControllerConfig::default().safety;
    eprintln!(
        "scene sphere 1.5 cm beside the elbow, tool holding: null space first: arm at {:.4} m after 2 s, tool moved \
         {:.2} mm, {} steps overriding the tool; overriding at once: arm at {:.4} m, tool moved {:.2} mm, {} steps \
         (scene stop distance {} m)",
        swivel_d, swivel_off * 1e3, swivel_overriding, override_d, override_off * 1e3, override_overriding, s.scene_stop_distance
    );
    assert!(swivel_d > s.scene_stop_distance - 0.005, "the elbow did not clear the object: {swivel_d} m");
    assert!(swivel_off < 1e-3, "the tool moved {swivel_off} m");
    assert!(override_off > 5.0 * swivel_off.max(1e-4), "overriding at once keeps the tool too: {override_off} m");
    // The old damper overrode the task (`approach limited`) at every step.
    assert!(swivel_overriding * 10 < override_overriding, "{swivel_overriding} vs {override_overriding} steps");
}

/// A hand that reaches into the forearm at 1 m/s, holds inside the arm's path for 1 s, and
/// leaves: the arm retreats, never touches it, and reaches the goal after it left.
#[test]
fn forearm_retreats_from_a_reaching_hand_and_resumes() {
    let model = common::lwr();
    let free = run(&model, false, None, 3.0, 0.35);
    let target = Point3::from(free.elbow_path[free.elbow_path.len() / 4] + Vector3::new(0.0, 0.0, 0.0));
    let start = target + Vector3::new(-0.5, 0.0, 0.1);
    let radius = 0.04;
    let speed = 1.0;
    let travel = (target - start).norm() / speed;
    let dir = (target - start).normalize();
    let hand = move |t: f64| {
        let (t_in, t_hold) = (0.2, 0.2 + travel);
        let t_out = t_hold + 1.0;
        if t < t_in {
            (start, radius, Vector3::zeros())
        } else if t < t_hold {
            (start + dir * speed * (t - t_in), radius, dir * speed)
        } else if t < t_out {
            (target, radius, Vector3::zeros())
        } else {
            let s = (speed * (t - t_out)).min(1.0);
            (target - dir * s, radius, if s < 1.0 { -dir * speed } else { Vector3::zeros() })
        }
    };
    let blind = run(&model, false, Some(&hand), 6.0, 0.35);
    let safe = run(&model, true, Some(&hand), 6.0, 0.35);
    eprintln!(
        "hand reaching into the forearm at {speed} m/s: eq. 5.13 alone min {:.4} m; with the damper {:.4} m \
         (active {} steps, goal reached {})",
        blind.min_distance, safe.min_distance, safe.safety_steps, safe.reached
    );
    assert!(blind.min_distance < 0.0, "the hand must hit the arm without the damper: {}", blind.min_distance);
    assert!(safe.min_distance > 0.03, "the arm did not get out of the way: {} m", safe.min_distance);
    assert!(safe.reached, "goal reached after the hand left");
}

/// The damper only removes approach: a receding obstacle's velocity gives no credit, motion
/// away from or along the obstacle is untouched, and the end-effector links are not damped by
/// default nor ever when a command turns end-effector avoidance off.
#[test]
fn damper_limits_only_the_approach() {
    let model = common::lwr();
    let q = common::q_start();
    let goal = common::tip_position(&model, &q) + Vector3::new(0.0, 0.3, 0.0);
    let mut poses = LinkPoses::new();
    model.forward_kinematics(&q, &mut poses);
    let link = model.joint_link(3);
    let p = Point3::from(poses.get(link).translation.vector);
    let step = |cfg: ControllerConfig, link: usize, d: f64, n: Vector3<f64>, v: Vector3<f64>, ee_avoid: bool| {
        let mut ctl = DsController::new(model.clone(), cfg).expect("config");
        let mut cmd = common::command(common::constant_speed(0.3), goal);
        cmd.end_effector_avoidance = ee_avoid;
        let mut input = common::input(q, cmd, 1.0);
        input.distances.count = model.link_count();
        input.distances.links[link] = LinkDistance {
            valid: true,
            distance: d,
            robot_point: p,
            obstacle_point: p - n * d,
            normal: n,
            obstacle_velocity: v,
        };
        let mut out = ControlOutput::default();
        // Past the resume ramp.
        for _ in 0..300 {
            ctl.step(&input, &mut out).expect("step");
        }
        out
    };
    let cfg = ControllerConfig::default();
    let mut ctl_free = DsController::new(model.clone(), cfg).expect("config");
    let mut out_free = ControlOutput::default();
    let free_in = common::input(q, common::command(common::constant_speed(0.3), goal), 1.0);
    for _ in 0..300 {
        ctl_free.step(&free_in, &mut out_free).expect("step");
    }
    let mut pj = cowork_robot::PositionJacobian::zeros();
    let in_link = poses.get(link).inverse_transform_point(&p);
    model.position_jacobian(&poses, link, &in_link, &mut pj);
    let rate = |qd: &JointVector, n: &Vector3<f64>| n.dot(&(pj * qd));
    // The free motion's elbow velocity; put an obstacle right in front of it.
    let v_free = pj * out_free.qdot;
    assert!(v_free.norm() > 1e-3, "the elbow moves in the free motion");
    let n = -v_free.normalize();
    // At the stop distance: no approach left.
    let out = step(cfg, link, cfg.safety.stop_distance, n, Vector3::zeros(), true);
    assert!(out.diagnostics.safety.active);
    assert!(rate(&out.qdot, &n) > -1e-3, "approach at the stop distance: {}", rate(&out.qdot, &n));
    // A receding obstacle (moving away at 1 m/s) gives no credit.
    let out_r = step(cfg, link, cfg.safety.stop_distance, n, -n * 1.0, true);
    assert!(rate(&out_r.qdot, &n) > -1e-3);
    // Beyond the slow distance: untouched.
    let out = step(cfg, link, cfg.safety.slow_distance + 0.05, n, Vector3::zeros(), true);
    assert!(!out.diagnostics.safety.active);
    // Obstacle behind the motion (the elbow moves away from it): untouched.
    let out = step(cfg, link, cfg.safety.stop_distance + 0.02, -n, Vector3::zeros(), true);
    assert!(!out.diagnostics.safety.active);
    // End-effector links: modulation's job by default; damped when configured, but never with
    // end-effector avoidance off.
    let tip = model.tip_link();
    let out = step(cfg, tip, 0.05, n, Vector3::zeros(), true);
    assert!(!out.diagnostics.safety.active);
    let mut ee_cfg = cfg;
    ee_cfg.safety.end_effector = true;
    ee_cfg.modulation.end_effector = true;
    let out = step(ee_cfg, tip, 0.05, -goal_dir(&model, &q, &goal), Vector3::zeros(), true);
    assert!(out.diagnostics.safety.active, "end-effector damper when configured");
    let out = step(ee_cfg, tip, 0.05, -goal_dir(&model, &q, &goal), Vector3::zeros(), false);
    assert!(!out.diagnostics.safety.active, "never during a handover");
}

fn goal_dir(model: &RobotModel, q: &JointVector, goal: &Vector3<f64>) -> Vector3<f64> {
    (goal - common::tip_position(model, q)).normalize()
}

/// The watchdog's slow zone: distances older than `slow_after_s` scale the speed down
/// linearly, to 0 at `stale_after_s`, after which the robot is held.
#[test]
fn aging_data_slows_then_holds() {
    let model = common::lwr();
    let q = common::q_start();
    let goal = common::tip_position(&model, &q) + Vector3::new(0.0, 0.3, 0.0);
    let cfg = ControllerConfig::default();
    let speed_at = |age: f64| {
        let mut ctl = DsController::new(model.clone(), cfg).expect("config");
        let mut out = ControlOutput::default();
        let cmd = common::command(common::constant_speed(0.3), goal);
        let mut res = Ok(());
        for k in 0..400 {
            let t = 1.0 + k as f64 * 1e-3;
            let mut input = common::input(q, cmd, t);
            input.distances.stamp = t - age;
            res = ctl.step(&input, &mut out);
        }
        (out.diagnostics.ee_velocity.norm(), out.diagnostics.age_scale, res.is_ok())
    };
    let (fresh, s_fresh, ok_fresh) = speed_at(0.0);
    let (mid, s_mid, ok_mid) = speed_at(0.5 * (cfg.slow_after_s + cfg.stale_after_s));
    let (_, _, ok_stale) = speed_at(cfg.stale_after_s + 0.01);
    eprintln!("speed fresh {fresh:.3} m/s, half-way into the slow zone {mid:.3} m/s (scale {s_mid:.2})");
    assert!(ok_fresh && ok_mid && !ok_stale);
    assert_eq!(s_fresh, 1.0);
    assert!((s_mid - 0.5).abs() < 1e-9, "{s_mid}");
    assert!((mid - 0.5 * fresh).abs() < 0.02 * fresh, "fresh {fresh}, mid {mid}");
}

/// The floor (`Distances::floor`: the table top under the hand, ds_controller's
/// `keep_off_table`) holds even the hand: the end-effector links, which the damper otherwise
/// leaves to the modulation, and link points within `hand_radius` of the tool (`cowork
/// experiment pizza --arms uni` seed 2: the hand went 4 mm below the table top).
#[test]
fn the_floor_holds_the_hand_too() {
    let model = common::lwr();
    let q = common::q_start();
    let tool = common::tip_position(&model, &q);
    let mut poses = LinkPoses::new();
    model.forward_kinematics(&q, &mut poses);
    let tip = model.tip_link();
    let p = Point3::from(poses.get(tip).translation.vector);
    assert!((p - Point3::from(tool)).norm() < ControllerConfig::default().safety.hand_radius, "the tip link's point is the hand's");
    // The goal straight through the floor, 1 cm under the hand.
    let down = -Vector3::z();
    let goal = tool + down * 0.3;
    // Without the end-effector modulation, which would also stop the hand here: only the
    // damper acts.
    let mut cfg = ControllerConfig::default();
    cfg.modulation.end_effector = false;
    let run = |floor: bool| {
        let mut ctl = DsController::new(model.clone(), cfg).expect("config");
        let mut input = common::input(q, common::command(common::constant_speed(0.3), goal), 1.0);
        input.distances.count = model.link_count();
        input.distances.links[tip] =
            LinkDistance { valid: true, distance: 0.01, robot_point: p, obstacle_point: p + down * 0.01, normal: -down, obstacle_velocity: Vector3::zeros() };
        input.distances.scene_object[tip] = true;
        input.distances.floor[tip] = floor;
        let mut out = ControlOutput::default();
        for _ in 0..300 {
            ctl.step(&input, &mut out).expect("step");
        }
        let mut pj = cowork_robot::PositionJacobian::zeros();
        let in_link = poses.get(tip).inverse_transform_point(&p);
        model.position_jacobian(&poses, tip, &in_link, &mut pj);
        (out.diagnostics.safety.active, down.dot(&(pj * out.qdot)))
    };
    let (active, speed_down) = run(false);
    assert!(!active && speed_down > 0.05, "not a floor: the damper leaves the hand alone ({speed_down} m/s down)");
    let (active, speed_down) = run(true);
    assert!(active && speed_down < 1e-3, "the floor holds the hand 1 cm above it, inside the scene stop distance ({speed_down} m/s down)");
}
