//! Time of one simulator step (1 kHz loop): integration, limits, FK, held object, admittance.

use std::hint::black_box;

use cowork_robot::RobotModel;
use cowork_sim::{Scene, SimParams, Simulator, Wrench};
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

fn simulator() -> Simulator {
    let model = RobotModel::from_urdf_file(&root().join("config/robot/lwr4plus.urdf")).expect("URDF");
    let scene = Scene::from_file(&root().join("config/scenes/kitchen.yaml")).expect("scene");
    Simulator::new(model, scene, SimParams::default()).expect("simulator")
}

fn bench(c: &mut Criterion) {
    let mut sim = simulator();
    sim.set_velocity_command(&[0.1, -0.1, 0.1, -0.1, 0.1, -0.1, 0.1]).expect("command");
    c.bench_function("sim_step_velocity_command", |b| {
        b.iter(|| {
            // Re-arm the command so it never times out during the measurement.
            sim.set_velocity_command(black_box(&[0.1, -0.1, 0.1, -0.1, 0.1, -0.1, 0.1])).expect("command");
            sim.step();
        })
    });
    let mut sim = simulator();
    c.bench_function("sim_step_admittance", |b| {
        b.iter(|| {
            sim.set_wrench(Wrench { force: Vector3::new(5.0, 0.0, 0.0), torque: Vector3::zeros() }, None)
                .expect("wrench");
            sim.step();
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
