//! Kinematics cost for the 7-DoF LWR IV+: FK of all links, the tip Jacobian, the damped
//! pseudo-inverse, and the three together (one control-cycle's worth).
//!
//! ```text
//! CARGO_TARGET_DIR=target/h-robot cargo bench -p cowork_robot --bench kinematics
//! ```
//! The URDF is `config/robot/lwr4plus.urdf`, or `$COWORK_URDF` when set.

use cowork_robot::{Jacobian, JointVector, LinkPoses, RobotModel, damped_pseudo_inverse};
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Point3;
use rand::{Rng, SeedableRng};
use std::hint::black_box;
use std::path::PathBuf;

fn urdf_path() -> PathBuf {
    std::env::var_os("COWORK_URDF")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config/robot/lwr4plus.urdf")
        })
}

fn configs(model: &RobotModel, n: usize) -> Vec<JointVector> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    (0..n)
        .map(|_| {
            JointVector::from_fn(|i, _| {
                let l = model.joint_limits()[i];
                rng.random_range(l.lower..l.upper)
            })
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let model = RobotModel::from_urdf_file(urdf_path()).expect("load the LWR URDF");
    let qs = configs(&model, 256);
    let tip = model.tip_link();
    let point = Point3::origin();
    let mut poses = LinkPoses::new();
    let mut jac = Jacobian::zeros();
    let mut i = 0;
    let mut next = || {
        i = (i + 1) % qs.len();
        &qs[i]
    };

    let mut g = c.benchmark_group("lwr_7dof");
    g.bench_function("forward_kinematics_all_links", |b| {
        b.iter(|| model.forward_kinematics(black_box(next()), &mut poses))
    });
    model.forward_kinematics(&qs[0], &mut poses);
    g.bench_function("jacobian_tip", |b| {
        b.iter(|| model.jacobian(black_box(&poses), tip, &point, &mut jac))
    });
    model.jacobian(&poses, tip, &point, &mut jac);
    g.bench_function("damped_pseudo_inverse", |b| {
        b.iter(|| damped_pseudo_inverse(black_box(&jac), 0.01))
    });
    g.bench_function("pseudo_inverse_undamped", |b| {
        b.iter(|| damped_pseudo_inverse(black_box(&jac), 0.0))
    });
    g.bench_function("fk_jacobian_damped_pinv", |b| {
        b.iter(|| {
            model.forward_kinematics(black_box(next()), &mut poses);
            model.jacobian(&poses, tip, &point, &mut jac);
            damped_pseudo_inverse(&jac, 0.01)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
