//! Median time of one `DsController::step` on the LWR with obstacles near the end effector and
//! a link (modulation, escape check, null-space task, saturation all active).

use cowork_ds::primitive::ConstantSpeed;
use cowork_ds::{
    ControlInput, ControlOutput, ControllerConfig, Distances, DsController, HumanInput, HumanState,
    LearnedField, LinkDistance, MotionCommand, Primitive,
};
use cowork_robot::{JointVector, RobotModel};
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Point3, Vector3};
use std::hint::black_box;
use std::path::PathBuf;

fn input(model: &RobotModel) -> ControlInput {
    let mut distances = Distances::clear(0.0);
    distances.count = model.link_count();
    let tip = model.tip_link();
    distances.links[tip] = LinkDistance {
        valid: true,
        distance: 0.08,
        robot_point: Point3::new(0.4, 0.0, 0.5),
        obstacle_point: Point3::new(0.48, 0.0, 0.5),
        normal: Vector3::new(-1.0, 0.0, 0.0),
        obstacle_velocity: Vector3::new(0.0, 0.3, 0.0),
    };
    distances.links[4] = LinkDistance {
        valid: true,
        distance: 0.12,
        robot_point: Point3::new(0.1, 0.05, 0.6),
        obstacle_point: Point3::new(0.1, 0.17, 0.6),
        normal: Vector3::new(0.0, -1.0, 0.0),
        obstacle_velocity: Vector3::zeros(),
    };
    ControlInput {
        time: 0.0,
        q: JointVector::from_row_slice(&[0.1, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0]),
        command: MotionCommand {
            id: 1,
            primitive: Primitive::ConstantSpeed(ConstantSpeed::new(0.3)),
            goal: Vector3::new(0.5, 0.3, 0.4),
            orientation: None,
            end_effector_avoidance: true,
        },
        distances,
        human: HumanInput {
            stamp: 0.0,
            state: HumanState::default(),
        },
    }
}

fn bench(c: &mut Criterion) {
    let urdf =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config/robot/lwr4plus.urdf");
    let model = RobotModel::from_urdf_file(urdf).expect("LWR URDF loads");
    let input = input(&model);
    let mut ctl = DsController::new(model, ControllerConfig::default()).expect("default config");
    let mut out = ControlOutput::default();
    c.bench_function("ds_step_obstacles", |b| {
        b.iter(|| {
            ctl.step(black_box(&input), &mut out).expect("valid input");
            black_box(&out);
        })
    });
    // The same step with the link-distance damper off: its cost, side by side.
    let mut cfg = ControllerConfig::default();
    cfg.safety.enabled = false;
    let mut plain = DsController::new(ctl.model().clone(), cfg).expect("config");
    c.bench_function("ds_step_obstacles_no_damper", |b| {
        b.iter(|| {
            plain.step(black_box(&input), &mut out).expect("valid input");
            black_box(&out);
        })
    });
    let mut free = input;
    free.distances = Distances::clear(0.0);
    c.bench_function("ds_step_free", |b| {
        b.iter(|| {
            ctl.step(black_box(&free), &mut out).expect("valid input");
            black_box(&out);
        })
    });
    // The controller step with task transition control active: `ds_step_obstacles`'s inputs
    // plus a 20 N push on the elbow (three stacks blended after the DS, damper, saturation).
    let mut cfg = ControllerConfig::default();
    cfg.ttc.enabled = true;
    let mut guided = DsController::new(ctl.model().clone(), cfg).expect("config");
    let wrench = cowork_ds::ExternalWrench {
        stamp: 0.0,
        link: guided.model().joint_link(3),
        force: Vector3::new(0.0, 20.0, 0.0),
    };
    c.bench_function("ds_step_obstacles_ttc_contact", |b| {
        b.iter(|| {
            guided
                .step_with_contact(black_box(&input), None, Some(&wrench), &mut out)
                .expect("valid input");
            black_box(&out);
        })
    });
}

/// A learned field with a null-space (elbow) primitive: a constant tool velocity and a constant
/// velocity asked of the elbow (`lwr_link_4`'s origin).
#[derive(Debug)]
struct WithElbow {
    elbow: usize,
}

impl LearnedField for WithElbow {
    fn reset(&mut self, _x0: &Vector3<f64>, _goal: &Vector3<f64>) {}

    fn velocity(&mut self, _x: &Vector3<f64>, _goal: &Vector3<f64>, _dt: f64) -> Vector3<f64> {
        Vector3::new(0.05, 0.02, 0.0)
    }

    fn null_space_link(&self) -> Option<usize> {
        Some(self.elbow)
    }

    fn null_space_velocity(&mut self, _x: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(0.0, 0.04, 0.01)
    }
}

/// `ds_step_obstacles`'s inputs with a learned primitive that carries an elbow path (Sec.
/// 4.1.1): the null-space point task instead of the posture task.
fn bench_null_space(c: &mut Criterion) {
    let urdf = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config/robot/lwr4plus.urdf");
    let model = RobotModel::from_urdf_file(urdf).expect("LWR URDF loads");
    let mut input = input(&model);
    input.command.primitive = Primitive::Learned;
    let mut field = WithElbow { elbow: model.link_index("lwr_link_4").expect("elbow") };
    let mut ctl = DsController::new(model, ControllerConfig::default()).expect("default config");
    let mut out = ControlOutput::default();
    c.bench_function("ds_step_obstacles_null_space_primitive", |b| {
        b.iter(|| {
            ctl.step_with_field(black_box(&input), Some(&mut field), &mut out).expect("valid input");
            black_box(&out);
        })
    });
}

/// One task transition control step (Sec. 4.1.2) with a 20 N push on the elbow: the three
/// stacks' task-priority IK and the weight update, to compare with the DS step above.
fn bench_ttc(c: &mut Criterion) {
    use cowork_ds::ttc::contact_point_at_link_end;
    use cowork_ds::{Contact, Ttc, TtcConfig, TtcReport};
    let urdf =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config/robot/lwr4plus.urdf");
    let model = RobotModel::from_urdf_file(urdf).expect("LWR URDF loads");
    let q = JointVector::from_row_slice(&[0.0, 0.6, 0.0, -1.3, 0.0, 0.7, 0.0]);
    let mut poses = cowork_robot::LinkPoses::new();
    model.forward_kinematics(&q, &mut poses);
    let link = model.joint_link(3);
    let contact = Contact {
        link,
        point: contact_point_at_link_end(&model, &poses, link),
        force: Vector3::new(0.0, 20.0, 0.0),
    };
    let mut twist = cowork_ds::ik::Twist::zeros();
    twist[1] = 0.1;
    let mut ttc = Ttc::new(TtcConfig::default()).expect("config");
    let mut report = TtcReport::default();
    c.bench_function("ttc_step_contact", |b| {
        b.iter(|| {
            black_box(ttc.step(&model, &poses, model.tip_link(), black_box(&twist), Some(&contact), 1e-3, &mut report));
        })
    });
}

criterion_group!(benches, bench, bench_ttc, bench_null_space);
criterion_main!(benches);
