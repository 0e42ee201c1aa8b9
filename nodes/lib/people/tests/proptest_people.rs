//! Property tests over body sizes, speeds, amplitudes, positions and facing angles: poses stay
//! finite, segments rigid, hands within arm's reach of the shoulders.

use cowork_people::{Action, BodySize, GestureKind, GestureStyle, Performer, Segment, Side, Stance};
use nalgebra::{Point2, Point3};
use proptest::prelude::*;

fn check(p: &Performer) -> Result<(), TestCaseError> {
    let body = p.body();
    let l = body.lengths();
    let n = 40;
    for k in 0..=n {
        let t = p.duration() * f64::from(k) / f64::from(n);
        let pose = p.pose(t);
        prop_assert!(pose.is_finite(), "NaN at t = {}", t);
        for side in [Side::Right, Side::Left] {
            let [sh, el, wr, ha] = Segment::arm(side);
            let d = (pose.position(ha) - pose.position(sh)).norm();
            prop_assert!(d <= body.arm_reach() + 1e-9, "hand {} m from the shoulder, reach {}", d, body.arm_reach());
            prop_assert!(((pose.position(el) - pose.position(sh)).norm() - l.upper_arm).abs() < 1e-9);
            prop_assert!(((pose.position(wr) - pose.position(el)).norm() - l.forearm).abs() < 1e-9);
        }
        // The head stays above the pelvis and below the standing height.
        let head = pose.position(Segment::Head).z - pose.floor_z;
        prop_assert!(head > 0.7 * body.height && head < body.height, "head at {}", head);
    }
    Ok(())
}

fn kind() -> impl Strategy<Value = GestureKind> {
    prop_oneof![Just(GestureKind::Come), Just(GestureKind::Stop), Just(GestureKind::HandoverRight)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]

    #[test]
    fn gestures_stay_plausible(
        height in 1.4f64..2.1,
        scale in 0.4f64..2.5,
        amplitude in 0.5f64..1.5,
        tilt in -0.4f64..0.4,
        reps in 1u32..6,
        x in -2.0f64..2.0,
        y in -3.0f64..-0.9,
        yaw in -3.2f64..3.2,
        kind in kind(),
        seed in any::<u64>(),
    ) {
        let style = GestureStyle { duration_scale: scale, amplitude, repetitions: reps, tilt };
        let p = Performer::new(1, BodySize::new(height).expect("height"), Stance::new(x, y, yaw), seed)
            .and_then(|p| p.then(Action::Gesture { kind, style }))
            .expect("performer");
        check(&p)?;
    }

    #[test]
    fn walks_reaches_and_sweeps_stay_plausible(
        height in 1.4f64..2.1,
        speed in 0.3f64..2.0,
        from in (-3.0f64..3.0, -4.0f64..-1.0),
        to in (-1.0f64..1.5, -1.6f64..-0.95),
        face in -3.2f64..3.2,
        target in (-0.5f64..1.2, -1.2f64..0.8, -0.3f64..0.8),
        duration in 0.3f64..2.0,
        seed in any::<u64>(),
    ) {
        let target = Point3::new(target.0, target.1, target.2);
        let p = Performer::new(1, BodySize::new(height).expect("height"), Stance::new(from.0, from.1, 0.0), seed)
            .and_then(|p| p.then(Action::Walk { to: Point2::new(to.0, to.1), speed, face_yaw: Some(face) }))
            .and_then(|p| p.then(Action::Reach { side: Side::Left, target, duration, hold: 0.3 }))
            .and_then(|p| p.then(Action::Sweep { side: Side::Right, from: target, to: Point3::new(0.5, 0.0, 0.1), duration }))
            .expect("performer");
        check(&p)?;
    }
}
