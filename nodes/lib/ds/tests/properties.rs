//! Property tests of the modulation (eq. 5.5–5.7) and the saturation of the controller.
// Joint loops index q, q̇ and the limits together.
#![allow(clippy::needless_range_loop)]

mod common;

use cowork_ds::modulation::{EPSILON, eigenvalues, modulate, modulation_matrix};
use cowork_ds::{ControlOutput, ControllerConfig, DsController, LinkDistance};
use cowork_robot::{JointVector, LinkPoses};
use nalgebra::{Point3, Unit, Vector3};
use proptest::prelude::*;

fn vec3(range: f64) -> impl Strategy<Value = Vector3<f64>> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

fn unit() -> impl Strategy<Value = Unit<Vector3<f64>>> {
    vec3(1.0)
        .prop_filter("non-zero", |v| v.norm() > 1e-3)
        .prop_map(Unit::new_normalize)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn modulation_is_symmetric_positive_definite(n in unit(), d in -0.1f64..10.0, eps in 1e-8f64..0.5) {
        let m = modulation_matrix(&n, d, eps);
        prop_assert!((m - m.transpose()).amax() < 1e-12);
        let mut eig = m.symmetric_eigen().eigenvalues;
        eig.as_mut_slice().sort_by(f64::total_cmp);
        let mut want = eigenvalues(d, eps);
        want.as_mut_slice().sort_by(f64::total_cmp);
        prop_assert!(eig[0] > 0.0, "eigenvalues {eig}");
        prop_assert!((eig - want).amax() < 1e-9, "{eig} vs {want}");
    }

    #[test]
    fn modulation_keeps_the_equilibria(n in unit(), d in 0.0f64..5.0, g in vec3(1.0), x in vec3(1.0), k in 0.1f64..5.0) {
        let m = modulation_matrix(&n, d, EPSILON);
        let f = (g - x) * k;
        let v = modulate(&m, &f, &Vector3::zeros());
        // M f = 0 exactly where f = 0 ...
        let at_goal = modulate(&m, &((g - g) * k), &Vector3::zeros());
        prop_assert_eq!(at_goal, Vector3::zeros());
        // ... and nowhere else: ‖M f‖ ≥ λ_min ‖f‖ > 0.
        let lmin = eigenvalues(d, EPSILON).min();
        prop_assert!(v.norm() >= lmin * f.norm() * (1.0 - 1e-9));
        if f.norm() > 0.0 {
            prop_assert!(v.norm() > 0.0);
        }
    }

    #[test]
    fn approach_speed_vanishes_at_contact(n in unit(), f in vec3(2.0), d in 0.0f64..0.1) {
        let m = modulation_matrix(&n, d, EPSILON);
        let v = modulate(&m, &f, &Vector3::zeros());
        // The normal component is λ₁ n·f with λ₁ = (D + ε)/(D + 1) ≤ D + ε.
        prop_assert!(n.dot(&v).abs() <= (d + EPSILON) * n.dot(&f).abs() + 1e-15);
        let m0 = modulation_matrix(&n, 0.0, EPSILON);
        let v0 = modulate(&m0, &f, &Vector3::zeros());
        prop_assert!(n.dot(&v0).abs() <= EPSILON * f.norm() + 1e-15);
        // Monotone in D: closer means slower towards the obstacle.
        let m2 = modulation_matrix(&n, d + 0.05, EPSILON);
        prop_assert!(n.dot(&v).abs() <= n.dot(&(m2 * f)).abs() + 1e-15);
    }
}

fn joint_fraction() -> impl Strategy<Value = [f64; 7]> {
    // Fractions of the range; many near or at the limits.
    proptest::array::uniform7(prop_oneof![
        -1.0f64..1.0,
        Just(1.0),
        Just(-1.0),
        0.98f64..1.0,
        -1.0f64..-0.98
    ])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn joints_never_exceed_position_or_velocity_limits(
        frac in joint_fraction(),
        goal in vec3(0.6),
        centre in vec3(0.7),
        obstacle_velocity in vec3(2.0),
        gain in 0.5f64..10.0,
    ) {
        let model = common::lwr();
        let limits = *model.joint_limits();
        let mut q = JointVector::from_fn(|i, _| frac[i] * limits[i].upper);
        let goal = goal + Vector3::new(0.0, 0.0, 0.5);
        let centre = Point3::from(centre + Vector3::new(0.0, 0.0, 0.4));
        let mut ctl = DsController::new(model.clone(), ControllerConfig::default()).expect("config");
        let points = common::link_points(&model, 16);
        let mut poses = LinkPoses::new();
        let mut out = ControlOutput::default();
        let dt = ctl.config().period_s;
        for k in 0..60 {
            let t = k as f64 * dt;
            model.forward_kinematics(&q, &mut poses);
            let mut input = common::input(q, common::command(common::linear(gain), goal), t);
            input.distances = common::sphere_distances(&poses, &points, &centre, 0.1, &obstacle_velocity, t);
            if k % 7 == 3 {
                // A close obstacle at the hand too.
                let tip = model.tip_link();
                input.distances.links[tip] = LinkDistance { distance: 0.001, ..input.distances.links[tip] };
            }
            let _ = ctl.step(&input, &mut out);
            for (i, l) in limits.iter().enumerate() {
                prop_assert!(out.qdot[i].abs() <= l.velocity * (1.0 + 1e-12),
                    "joint {} speed {} > {}", i, out.qdot[i], l.velocity);
            }
            q += out.qdot * dt;
            for i in 0..7 {
                prop_assert!(q[i] >= limits[i].lower - 1e-12 && q[i] <= limits[i].upper + 1e-12,
                    "joint {} at {} outside [{}, {}]", i, q[i], limits[i].lower, limits[i].upper);
            }
        }
    }
}
