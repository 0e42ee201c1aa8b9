//! Property tests over arbitrary joint configurations (also outside the limits) and dampings.

mod common;

use cowork_robot::{Jacobian, JointVector, LinkPoses, damped_pseudo_inverse, null_space_projector};
use nalgebra::Point3;
use proptest::prelude::*;

fn any_q() -> impl Strategy<Value = JointVector> {
    proptest::array::uniform7(-7.0..7.0f64).prop_map(|a| JointVector::from_row_slice(&a))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Damped least squares bounds the gain: every singular value of J†_λ is σ/(σ²+λ²) ≤ 1/(2λ),
    /// so commanded joint rates stay finite at any configuration, singular or not.
    #[test]
    fn damped_inverse_gain_is_bounded(q in any_q(), damping in 1e-3..1.0f64) {
        let m = common::lwr();
        let mut poses = LinkPoses::new();
        let mut jac = Jacobian::zeros();
        m.forward_kinematics(&q, &mut poses);
        m.jacobian(&poses, m.tip_link(), &Point3::origin(), &mut jac);
        let pinv = damped_pseudo_inverse(&jac, damping);
        let gain = pinv.singular_values().max();
        prop_assert!(gain <= 1.0 / (2.0 * damping) * (1.0 + 1e-9), "gain {gain} λ {damping}");
        // J J†_λ is symmetric and the projector leaves task-space motion below λ-order.
        let jp = jac * pinv;
        prop_assert!((jp - jp.transpose()).abs().max() < 1e-9);
        let n = null_space_projector(&jac, &pinv);
        prop_assert!((jac * n).abs().max() <= damping * damping * gain * jac.norm() + 1e-9);
    }

    /// Link frames stay rigid: rotations orthonormal, and the distance between consecutive
    /// link origins does not depend on the configuration.
    #[test]
    fn link_frames_are_rigid(q in any_q()) {
        for m in [common::lwr(), common::other()] {
            let mut poses = LinkPoses::new();
            let mut zero = LinkPoses::new();
            m.forward_kinematics(&q, &mut poses);
            m.forward_kinematics(&JointVector::zeros(), &mut zero);
            for l in 1..m.link_count() {
                let r = poses.get(l).rotation.to_rotation_matrix();
                prop_assert!((r.matrix().transpose() * r.matrix() - nalgebra::Matrix3::identity()).abs().max() < 1e-12);
                let d = (poses.get(l).translation.vector - poses.get(l - 1).translation.vector).norm();
                let d0 = (zero.get(l).translation.vector - zero.get(l - 1).translation.vector).norm();
                prop_assert!((d - d0).abs() < 1e-12);
            }
        }
    }
}
