//! The per-call kinematics never touch the heap: 10 000 rounds of FK + Jacobian + damped
//! pseudo-inverse (+ position Jacobian, its pseudo-inverse and the projector) allocate nothing.

mod common;

use cowork_robot::{
    Jacobian, LinkPoses, PositionJacobian, damped_pseudo_inverse, damped_pseudo_inverse_3,
    null_space_projector,
};
use nalgebra::Point3;
use std::hint::black_box;

#[global_allocator]
static GLOBAL: cowork_testkit::CountingAllocator = cowork_testkit::CountingAllocator;

use cowork_testkit::allocations;

#[test]
fn kinematics_per_call_allocate_nothing() {
    let model = common::lwr();
    let mut rng = common::rng(9);
    let mut qs: Vec<_> = (0..10_000)
        .map(|_| common::random_q(&model, &mut rng))
        .collect();
    // Singular configurations take the eigen-decomposition path of the undamped inverse.
    qs[1] = cowork_robot::JointVector::zeros();
    qs[3][3] = 0.0;
    let tip = model.tip_link();
    let mut poses = LinkPoses::new();
    let mut jac = Jacobian::zeros();
    let mut pj = PositionJacobian::zeros();
    let mut checksum = 0.0;

    // The counter itself must see allocations, or the test could never fail.
    let before = allocations();
    black_box(vec![1u8; 16]);
    assert_eq!(allocations(), before + 1);

    let before = allocations();
    for (i, q) in qs.iter().enumerate() {
        model.forward_kinematics(q, &mut poses);
        model.jacobian(&poses, tip, &Point3::origin(), &mut jac);
        let pinv = damped_pseudo_inverse(&jac, if i % 2 == 0 { 0.01 } else { 0.0 });
        model.position_jacobian(&poses, 4, &Point3::new(0.0, 0.07, 0.1), &mut pj);
        let ppinv = damped_pseudo_inverse_3(&pj, 0.01);
        let n = null_space_projector(&pj, &ppinv);
        checksum += pinv[(0, 0)] + n[(0, 0)] + model.link_pose(q, 3).translation.x;
    }
    let after = allocations();
    black_box(checksum);
    assert_eq!(after - before, 0, "allocations in 10 000 kinematics rounds");
}
