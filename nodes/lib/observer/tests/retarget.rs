//! Retargeting (thesis Sec. 4.2, eq. 4.7) measured on synthetic demonstrators whose arm lengths
//! are known (`cowork_people` bodies of 1.55, 1.72 and 1.90 m): reaches and sweeps over the
//! workspace in front of them, sampled at the Xsens rate (120 Hz), streamed through one
//! [`Retargeter`] each as the robot would follow them live.
//!
//! Measured per frame, on the robot arm the joint targets give (forward kinematics, not the
//! eq. 4.7 targets): the angle between the human's and the robot's upper arm, forearm, and
//! shoulder → hand direction (the human's turned into the robot frame by the sternum, as eq. 4.7
//! does); the joint targets against the URDF position limits; the largest joint step between two
//! frames against the URDF speed limits.

use cowork_observer::{RetargetConfig, Retargeter};
use cowork_people::{Action, BodySize, Performer, Segment, Side, Stance};
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use nalgebra::{Point3, Vector3};

fn model() -> RobotModel {
    let urdf = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../config/robot/lwr4plus.urdf");
    RobotModel::from_urdf_file(urdf).expect("model")
}

fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.normalize().dot(&b.normalize()).clamp(-1.0, 1.0).acos().to_degrees()
}

fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

/// A demonstrator of `body` facing +x: reaches with the right hand to `targets` (relative to
/// the right shoulder at the start, m), then one sweep.
fn demonstrator(body: BodySize, targets: &[[f64; 3]]) -> Performer {
    let p = Performer::new(1, body, Stance::new(-1.0, 0.0, 0.0), 7).expect("performer");
    let shoulder = p.pose(0.0).position(Segment::arm(Side::Right)[0]);
    let mut p = p;
    for t in targets {
        p.push(Action::Reach { side: Side::Right, target: shoulder + Vector3::from(*t), duration: 1.2, hold: 0.3 }).expect("reach");
    }
    p.push(Action::Sweep {
        side: Side::Right,
        from: shoulder + Vector3::new(0.45, -0.25, -0.25),
        to: shoulder + Vector3::new(0.45, 0.15, -0.25),
        duration: 1.5,
    })
    .expect("sweep");
    p
}

/// What one pass over the three demonstrators measured.
struct Figures {
    frames: usize,
    behind_base: usize,
    outside_limits: usize,
    too_fast: usize,
    worst_speed_ratio: f64,
    /// Angles human vs robot per scored frame (deg).
    upper: Vec<f64>,
    fore: Vec<f64>,
    hand: Vec<f64>,
}

impl Figures {
    /// Median, p95 and max of each of upper arm, forearm, shoulder → hand (deg).
    fn quantiles(&mut self) -> [[f64; 3]; 3] {
        [&mut self.upper, &mut self.fore, &mut self.hand].map(|v| [percentile(v, 0.5), percentile(v, 0.95), percentile(v, 1.0)])
    }
}

/// Streams the three demonstrators through a retargeter with `speed_limit_fraction`.
fn measure(model: &RobotModel, speed_limit_fraction: f64) -> Figures {
    let limits = *model.joint_limits();
    let targets = [
        [0.55, 0.0, 0.0],
        [0.45, -0.30, -0.20],
        [0.40, 0.20, -0.25],
        [0.30, -0.10, -0.45],
        [0.50, -0.15, 0.20],
        [0.35, 0.10, -0.10],
    ];
    let dt = 1.0 / 120.0;
    let mut f = Figures { frames: 0, behind_base: 0, outside_limits: 0, too_fast: 0, worst_speed_ratio: 0.0, upper: Vec::new(), fore: Vec::new(), hand: Vec::new() };
    let mut poses = LinkPoses::new();
    let links = [model.joint_link(1), model.joint_link(3), model.joint_link(5)];
    // The arm on the demonstrator's right shoulder, as RoDyMan's (thesis Fig. 4.9): its base z
    // axis points out of the right shoulder (the sternum's −y), x forward.
    let mount = [-std::f64::consts::FRAC_PI_2, 0.0, 0.0];
    let mount_rotation = nalgebra::UnitQuaternion::from_euler_angles(mount[0], mount[1], mount[2]);
    for body in [BodySize::SMALL, BodySize::MEDIUM, BodySize::TALL] {
        let person = demonstrator(body, &targets);
        let q0 = JointVector::from_row_slice(&[0.0, 0.3, 0.0, 0.6, 0.0, 0.3, 0.0]);
        let config = RetargetConfig { mount_rpy: mount, speed_limit_fraction, ..RetargetConfig::default() };
        let mut r = Retargeter::new(model.clone(), config, q0).expect("retargeter");
        let mut last: Option<JointVector> = None;
        let steps = (person.duration() / dt) as usize;
        for k in 0..steps {
            let pose = person.pose(k as f64 * dt);
            let out = r.retarget(&pose).expect("retarget");
            f.frames += 1;
            let q = out.joints;
            f.outside_limits += usize::from(q.iter().zip(&limits).any(|(v, l)| *v < l.lower - 1e-9 || *v > l.upper + 1e-9));
            if let Some(prev) = last {
                let ratio = (q - prev).iter().zip(&limits).map(|(d, l)| d.abs() / dt / l.velocity).fold(0.0, f64::max);
                f.worst_speed_ratio = f.worst_speed_ratio.max(ratio);
                f.too_fast += usize::from(ratio > 1.0 + 1e-9);
            }
            last = Some(q);
            // Eq. 4.7 maps directions: one the arm's base plane cuts off puts the robot's elbow
            // or hand behind it, where the arm cannot go; such frames are counted, not scored.
            // (Mounted upright as on a table, `mount_rpy` = 0, that is every hanging arm: 79 %
            // of these frames. Hence the shoulder mount.)
            if out.elbow_target.z < 0.0 || out.wrist_target.z < 0.0 {
                f.behind_base += 1;
                continue;
            }
            model.forward_kinematics(&q, &mut poses);
            let at = |l: usize| Point3::from(poses.get(l).translation.vector);
            let (rs, re, rw) = (at(links[0]), at(links[1]), at(links[2]));
            let [sh, el, wr, _] = Segment::arm(Side::Right);
            let body_frame = mount_rotation * pose.segment(Segment::Sternum).orientation.inverse();
            let human = |a: Segment, b: Segment| body_frame * (pose.position(b) - pose.position(a));
            f.upper.push(angle(&human(sh, el), &(re - rs)));
            f.fore.push(angle(&human(el, wr), &(rw - re)));
            f.hand.push(angle(&human(sh, wr), &(rw - rs)));
        }
    }
    f
}

#[test]
fn a_shoulder_mounted_arm_follows_demonstrators_of_three_sizes() {
    let model = model();
    for fraction in [0.0, 1.0] {
        let mut f = measure(&model, fraction);
        let [[u50, u95, umax], [f50, f95, fmax], [h50, h95, hmax]] = f.quantiles();
        eprintln!(
            "retargeting, speed limit fraction {fraction} (0: none): {} frames at 120 Hz (3 demonstrators, 6 reaches + 1 \
             sweep each), {} with an eq. 4.7 target behind the arm's base plane; angle human vs robot, median / p95 / max: \
             upper arm {u50:.2} / {u95:.2} / {umax:.2} deg, forearm {f50:.2} / {f95:.2} / {fmax:.2} deg, shoulder -> hand \
             {h50:.2} / {h95:.2} / {hmax:.2} deg; frames outside the joint limits {}; joint steps faster than the URDF \
             limit {} (largest {:.2} x the limit)",
            f.frames, f.behind_base, f.outside_limits, f.too_fast, f.worst_speed_ratio
        );
        assert_eq!(f.outside_limits, 0);
        assert_eq!(f.behind_base, 0, "a shoulder-mounted arm reaches every direction of these demonstrations");
        // The shoulder -> hand direction differs by the arms' proportions (the robot's 0.40 /
        // 0.39 m against the person's upper arm / forearm) whenever the elbow is bent.
        assert!(h50 < 4.0, "hand direction {h50} deg");
        if fraction == 0.0 {
            // Eq. 4.7 keeps the segments' directions: the robot's upper arm and forearm point
            // where the demonstrator's do.
            assert!(umax < 0.5 && fmax < 0.5, "arm directions off by {umax} / {fmax} deg");
            assert!(hmax < 15.0, "hand direction {hmax} deg");
            assert!(f.too_fast > 0, "these demonstrations are faster than the arm");
        } else {
            // Held to the arm's speed limits the robot lags in the fastest frames only.
            assert_eq!(f.too_fast, 0);
            assert!(u50 < 0.5 && f50 < 0.5 && u95 < 25.0 && f95 < 25.0, "lag {u50} / {f50}, p95 {u95} / {f95} deg");
        }
    }
}
