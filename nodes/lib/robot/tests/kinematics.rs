//! FK, Jacobian, pseudo-inverse and projector on the LWR IV+ and on a second, unrelated 7-DoF URDF.

mod common;

use common::{lwr, other, random_q, rng};
use cowork_robot::{
    DOF, Jacobian, JointVector, LinkPoses, PositionJacobian, RobotModel, damped_pseudo_inverse,
    damped_pseudo_inverse_3, null_space_projector,
};
use nalgebra::{Point3, Vector3};
use rand::Rng;

#[test]
fn lwr_description_matches_the_thesis() {
    let m = lwr();
    assert_eq!(m.name(), "lwr4plus");
    let links: Vec<&str> = m.link_names().iter().map(String::as_str).collect();
    assert_eq!(
        links,
        [
            "lwr_base_link",
            "lwr_link_1",
            "lwr_link_2",
            "lwr_link_3",
            "lwr_link_4",
            "lwr_link_5",
            "lwr_link_6",
            "lwr_link_7",
            "lwr_ee_link"
        ]
    );
    assert_eq!(m.tip_link(), 8);
    assert_eq!(m.link_index("lwr_link_7"), Some(7));
    assert_eq!(m.link_index("nope"), None);
    let limits_deg = [170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 170.0];
    let speeds_deg = [100.0, 110.0, 100.0, 130.0, 130.0, 180.0, 180.0];
    for (i, l) in m.joint_limits().iter().enumerate() {
        assert!((l.upper - f64::to_radians(limits_deg[i])).abs() < 1e-12);
        assert!((l.lower + f64::to_radians(limits_deg[i])).abs() < 1e-12);
        assert!((l.velocity - f64::to_radians(speeds_deg[i])).abs() < 1e-12);
    }
    assert_eq!(m.joint_names()[0], "lwr_joint_1");
    assert_eq!(m.joint_link(0), 1);
    assert_eq!(m.joints_moving_link(0), 0);
    assert_eq!(m.joints_moving_link(4), 4);
    assert_eq!(m.joints_moving_link(8), 7);
    // "A few thousand vertices" (the thesis's mesh has 4861); every link has one.
    let n = m.mesh_vertex_count();
    assert!((3000..=6000).contains(&n), "{n} vertices");
    for l in 0..m.link_count() {
        assert!(
            m.link_mesh(l).is_some_and(|mesh| !mesh.is_empty()),
            "link {l} has no mesh"
        );
    }
}

#[test]
fn lwr_meshes_are_closed_arm_segments_of_6_to_7_cm_radius() {
    let m = lwr();
    for l in 1..=6 {
        let mesh = m.link_mesh(l).unwrap();
        let (lo, hi) = mesh.aabb().unwrap();
        let r = (hi.x - lo.x) / 2.0;
        assert!((0.059..=0.071).contains(&r), "link {l} radius {r}");
        assert!(mesh.signed_volume() > 0.0, "link {l} is not outward-wound");
    }
}

#[test]
fn zero_configuration_stacks_the_offsets() {
    let m = lwr();
    let mut poses = LinkPoses::new();
    m.forward_kinematics(&JointVector::zeros(), &mut poses);
    assert_eq!(poses.len(), m.link_count());
    let z = |name: &str| poses.get(m.link_index(name).unwrap()).translation.vector;
    let shoulder = 0.31;
    let elbow = shoulder + 0.4;
    let wrist = elbow + 0.39;
    let flange = wrist + 0.078;
    let tool = flange + 0.1;
    for (name, h) in [
        ("lwr_link_2", shoulder),
        ("lwr_link_4", elbow),
        ("lwr_link_6", wrist),
        ("lwr_link_7", flange),
        ("lwr_ee_link", tool),
    ] {
        assert!(
            (z(name) - Vector3::new(0.0, 0.0, h)).norm() < 1e-12,
            "{name} at {}",
            z(name)
        );
    }
    assert!(poses.get(m.tip_link()).rotation.angle() < 1e-12);
}

#[test]
fn elbow_bent_90_degrees_moves_the_forearm_along_x() {
    let m = lwr();
    let mut q = JointVector::zeros();
    q[3] = std::f64::consts::FRAC_PI_2; // A4 about +y: z turns towards +x.
    let tip = m.link_pose(&q, m.tip_link()).translation.vector;
    let expected = Vector3::new(0.39 + 0.078 + 0.1, 0.0, 0.31 + 0.4);
    assert!((tip - expected).norm() < 1e-12, "{tip}");
}

#[test]
fn link_pose_equals_forward_kinematics() {
    for m in [lwr(), other()] {
        let mut r = rng(1);
        let mut poses = LinkPoses::new();
        for _ in 0..50 {
            let q = random_q(&m, &mut r);
            m.forward_kinematics(&q, &mut poses);
            for l in 0..m.link_count() {
                let a = m.link_pose(&q, l);
                assert!(
                    (a.to_homogeneous() - poses.get(l).to_homogeneous())
                        .abs()
                        .max()
                        < 1e-12
                );
            }
        }
    }
}

/// Central finite differences of the pose of a point on a link: position rows from the point,
/// angular rows from the rotation difference `log(R(q+h) R(q−h)ᵀ) / 2h`.
fn finite_difference_jacobian(
    m: &RobotModel,
    q: &JointVector,
    link: usize,
    p: &Point3<f64>,
) -> Jacobian {
    let h = 1e-6;
    let mut jac = Jacobian::zeros();
    for j in 0..DOF {
        let (mut qp, mut qm) = (*q, *q);
        qp[j] += h;
        qm[j] -= h;
        let (tp, tm) = (m.link_pose(&qp, link), m.link_pose(&qm, link));
        let v = ((tp * p) - (tm * p)) / (2.0 * h);
        let w = (tp.rotation * tm.rotation.inverse()).scaled_axis() / (2.0 * h);
        jac.fixed_view_mut::<3, 1>(0, j).copy_from(&v);
        jac.fixed_view_mut::<3, 1>(3, j).copy_from(&w);
    }
    jac
}

#[test]
fn jacobian_matches_finite_differences_at_any_point_of_any_link() {
    for m in [lwr(), other()] {
        let mut r = rng(2);
        let mut poses = LinkPoses::new();
        let mut jac = Jacobian::zeros();
        let mut worst: f64 = 0.0;
        for _ in 0..300 {
            let q = random_q(&m, &mut r);
            let link = r.random_range(0..m.link_count());
            let p = Point3::new(
                r.random_range(-0.2..0.2),
                r.random_range(-0.2..0.2),
                r.random_range(-0.2..0.3),
            );
            m.forward_kinematics(&q, &mut poses);
            m.jacobian(&poses, link, &p, &mut jac);
            let fd = finite_difference_jacobian(&m, &q, link, &p);
            worst = worst.max((jac - fd).abs().max());
            // Joints after the link do not move it.
            for j in m.joints_moving_link(link)..DOF {
                assert_eq!(jac.column(j).norm(), 0.0);
            }
            let mut pj = PositionJacobian::zeros();
            m.position_jacobian(&poses, link, &p, &mut pj);
            assert_eq!(pj, jac.fixed_rows::<3>(0).into_owned());
        }
        assert!(worst < 1e-8, "{}: max |J − J_fd| = {worst:e}", m.name());
    }
}

#[test]
fn pseudo_inverse_properties() {
    let m = lwr();
    let mut r = rng(3);
    let mut poses = LinkPoses::new();
    let mut jac = Jacobian::zeros();
    for _ in 0..200 {
        let q = random_q(&m, &mut r);
        m.forward_kinematics(&q, &mut poses);
        m.jacobian(&poses, m.tip_link(), &Point3::origin(), &mut jac);
        let pinv = damped_pseudo_inverse(&jac, 0.0);
        // Moore–Penrose conditions, relative to the size of J† (random configurations can be
        // close to a singularity, where J† is large and rounding grows with it).
        let s = pinv.norm().max(1.0);
        assert!((jac * pinv * jac - jac).abs().max() < 1e-9 * s);
        assert!((pinv * jac * pinv - pinv).abs().max() < 1e-9 * s * s);
        assert!(((jac * pinv).transpose() - jac * pinv).abs().max() < 1e-9 * s);
        assert!(((pinv * jac).transpose() - pinv * jac).abs().max() < 1e-9 * s);
        // Null-space projector: J N = 0, N idempotent and symmetric, rank 1 (7 − 6).
        let n = null_space_projector(&jac, &pinv);
        assert!((jac * n).abs().max() < 1e-9 * s);
        assert!((n * n - n).abs().max() < 1e-9 * s);
        assert!((n.trace() - 1.0).abs() < 1e-9 * s);
        // Damping shrinks the solution and tends to the plain inverse.
        let damped = damped_pseudo_inverse(&jac, 0.1);
        let small = damped_pseudo_inverse(&jac, 1e-7);
        assert!(damped.norm() < pinv.norm());
        // J†_λ − J† = O(λ² |J†|³).
        assert!((small - pinv).abs().max() < 1e-9 + 1e-13 * s.powi(3));
        // The explicit formula.
        let a = (jac * jac.transpose() + nalgebra::Matrix6::identity() * 0.01)
            .try_inverse()
            .unwrap();
        assert!((damped - jac.transpose() * a).abs().max() < 1e-10);

        // The 3-row variant for link points.
        let mut pj = PositionJacobian::zeros();
        m.position_jacobian(&poses, 4, &Point3::new(0.0, 0.05, 0.1), &mut pj);
        let pp = damped_pseudo_inverse_3(&pj, 0.0);
        let sp = pp.norm().max(1.0);
        assert!((pj * pp * pj - pj).abs().max() < 1e-9 * sp);
        let np = null_space_projector(&pj, &pp);
        assert!((pj * np).abs().max() < 1e-9 * sp);
    }
}

#[test]
fn undamped_pseudo_inverse_of_a_singular_jacobian_falls_back_to_eigen() {
    let m = lwr();
    let mut poses = LinkPoses::new();
    let mut jac = Jacobian::zeros();
    // Stretched arm: A1, A3, A5, A7 share an axis, so the tip Jacobian has rank 4.
    m.forward_kinematics(&JointVector::zeros(), &mut poses);
    m.jacobian(&poses, m.tip_link(), &Point3::origin(), &mut jac);
    assert!(jac.rank(1e-9) < 6);
    let pinv = damped_pseudo_inverse(&jac, 0.0);
    assert!(pinv.iter().all(|x| x.is_finite()));
    assert!((jac * pinv * jac - jac).abs().max() < 1e-9);
    assert!((pinv * jac * pinv - pinv).abs().max() < 1e-9);
    let reference = jac.pseudo_inverse(1e-9).unwrap();
    assert!((pinv - reference).abs().max() < 1e-9);
    // With damping the joint rates stay bounded.
    let damped = damped_pseudo_inverse(&jac, 0.05);
    assert!(damped.norm() < 1.0 / 0.05 * 6.0);
    // The position Jacobian of link 1 (only A1 moves it) is rank 1 at most.
    let mut pj = PositionJacobian::zeros();
    m.position_jacobian(&poses, 1, &Point3::new(0.1, 0.0, 0.0), &mut pj);
    let pp = damped_pseudo_inverse_3(&pj, 0.0);
    assert!((pj * pp * pj - pj).abs().max() < 1e-12);
}

#[test]
fn undamped_pseudo_inverse_at_a_numerically_singular_jacobian_is_the_svd_one() {
    // A4 = 0 stretches the elbow: rank 5 whatever the other joints, but rounding makes
    // J Jᵀ only numerically singular, which a plain Cholesky may "succeed" on.
    let m = lwr();
    let mut r = rng(4);
    let mut poses = LinkPoses::new();
    let mut jac = Jacobian::zeros();
    for _ in 0..100 {
        let mut q = random_q(&m, &mut r);
        q[3] = 0.0;
        m.forward_kinematics(&q, &mut poses);
        m.jacobian(&poses, m.tip_link(), &Point3::origin(), &mut jac);
        let pinv = damped_pseudo_inverse(&jac, 0.0);
        let reference = jac.pseudo_inverse(1e-7).unwrap();
        assert!(
            (pinv - reference).abs().max() < 1e-6,
            "{} sv {} pinv {} ref {}",
            (pinv - reference).abs().max(),
            jac.singular_values(),
            pinv.norm(),
            reference.norm()
        );
        assert!((jac * pinv * jac - jac).abs().max() < 1e-9);
    }
}

#[test]
fn another_seven_dof_urdf_loads_with_its_own_structure() {
    let m = other();
    let links: Vec<&str> = m.link_names().iter().map(String::as_str).collect();
    // The camera branch is off the chain; fixed links stay as frames.
    assert_eq!(
        links,
        [
            "world", "base", "a", "b", "c", "c_mount", "d", "e", "f", "g", "tool"
        ]
    );
    assert_eq!(
        m.joint_names().as_slice(),
        ["j1", "j2", "j3", "j4", "j5", "j6", "j7"]
    );
    let l3 = m.joint_limits()[2];
    assert!(l3.lower == f64::NEG_INFINITY && l3.upper == f64::INFINITY && l3.velocity == 3.0);
    assert!(l3.contains(1e9));
    // Meshes: box, cylinder (visual only), sphere, cylinder with origin, mirrored ASCII STL.
    for name in ["base", "a", "b", "c", "d"] {
        assert!(m.link_mesh(m.link_index(name).unwrap()).is_some(), "{name}");
    }
    assert!(m.link_mesh(m.link_index("e").unwrap()).is_none());
    let d = m.link_mesh(m.link_index("d").unwrap()).unwrap();
    assert_eq!(d.vertices.len(), 4);
    assert!(d.signed_volume() > 0.0);
    assert!(
        d.vertices.iter().any(|v| (v.y + 0.1).abs() < 1e-7),
        "scale y = -1 mirrors the wedge"
    );
    let (lo, hi) = m
        .link_mesh(m.link_index("c").unwrap())
        .unwrap()
        .aabb()
        .unwrap();
    assert!(
        (lo.x - 0.0).abs() < 1e-9 && (hi.x - 0.3).abs() < 1e-9,
        "{lo} {hi}"
    );

    // Zero pose: product of the origins (checked against a hand computation of the first two).
    let mut poses = LinkPoses::new();
    m.forward_kinematics(&JointVector::zeros(), &mut poses);
    let base = poses.get(1);
    assert!((base.translation.vector - Vector3::new(0.1, -0.2, 0.05)).norm() < 1e-15);
    let a = poses.get(2);
    let expected = base
        * nalgebra::Isometry3::from_parts(
            nalgebra::Translation3::new(0.0, 0.0, 0.05),
            nalgebra::UnitQuaternion::from_euler_angles(0.1, 0.0, 0.0),
        );
    assert!((a.to_homogeneous() - expected.to_homogeneous()).abs().max() < 1e-15);
}

#[test]
fn a_named_tip_shortens_the_chain() {
    let m = RobotModel::from_urdf_file_with_tip(common::other_urdf(), "g").unwrap();
    assert_eq!(m.link_names().last().map(String::as_str), Some("g"));
    assert_eq!(m.tip_link(), m.link_count() - 1);
}

#[test]
fn clamp_to_limits_respects_each_joint() {
    let m = lwr();
    let q = JointVector::from_element(10.0);
    let c = m.clamp_to_limits(&q);
    for i in 0..DOF {
        assert_eq!(c[i], m.joint_limits()[i].upper);
    }
}

#[test]
fn non_finite_jacobians_give_nan_not_a_hang() {
    for bad in [f64::NAN, f64::INFINITY] {
        let mut jac = Jacobian::from_element(0.3);
        jac[(2, 4)] = bad;
        for damping in [0.0, 1e-9, 0.05, f64::NAN] {
            let p = damped_pseudo_inverse(&jac, damping);
            assert!(p.iter().all(|x| x.is_nan()), "{bad} λ {damping}");
            let mut pj = PositionJacobian::from_element(0.3);
            pj[(1, 1)] = bad;
            assert!(
                damped_pseudo_inverse_3(&pj, damping)
                    .iter()
                    .all(|x| x.is_nan())
            );
        }
    }
    // NaN joint positions propagate into the poses of the links they move, not before.
    let m = lwr();
    let mut q = JointVector::zeros();
    q[2] = f64::NAN;
    let mut poses = LinkPoses::new();
    m.forward_kinematics(&q, &mut poses);
    assert!(
        poses
            .get(2)
            .translation
            .vector
            .iter()
            .all(|x| x.is_finite())
    );
    assert!(poses.get(3).rotation.coords.iter().any(|x| x.is_nan()));
}
