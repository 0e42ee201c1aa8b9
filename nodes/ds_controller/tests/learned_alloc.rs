//! The learned primitives' real-time path allocates nothing: 5 × 2000 controller steps with a
//! GMR, C-GMR, DMP and HMM field, and an HMM with a null-space (elbow) HMM (models decoded
//! beforehand, as the ROS side does; the HMMs' paths are generated there).

use std::path::PathBuf;

use cowork_ds::{
    ControlInput, ControlOutput, Distances, DsController, HumanInput, HumanState, LearnedField,
};
use cowork_motion::model::{FitOptions, Model, ModelKind};
use cowork_motion::{Components, Demonstration};
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::MotionCommand as MotionCommandMsg;
use cowork_robot::{JointVector, RobotModel};
use ds_controller::{Adapter, Params};

#[global_allocator]
static GLOBAL: cowork_testkit::CountingAllocator = cowork_testkit::CountingAllocator;

#[test]
fn learned_steps_allocate_nothing() {
    let urdf = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/robot/lwr4plus.urdf");
    let model = RobotModel::from_urdf_file(urdf).expect("URDF");
    let adapter = Adapter::new(&model, &Params::default());
    let t: Vec<f64> = (0..101).map(|i| i as f64 * 0.02).collect();
    let demos: Vec<Demonstration> = (0..3)
        .map(|i| {
            let a = 0.15 + 0.03 * i as f64;
            let pos = t.iter().flat_map(|t| {
                let s = (1.0 - t / 2.0).powi(2);
                [a * s, 0.1 * s, 0.05 * s]
            });
            Demonstration::new(3, t.clone(), pos.collect(), None).expect("demo")
        })
        .collect();
    let opts = FitOptions { components: Components::Fixed(2), ..FitOptions::default() };
    let mut q = JointVector::from_row_slice(&[0.0, 0.5, 0.0, -1.3, 0.0, 0.8, 0.0]);
    let x0 = model.link_pose(&q, model.tip_link()).translation.vector;
    let mut runs = Vec::new();
    for (id, (kind, msg_kind)) in [
        (ModelKind::Gmr, MotionCommandMsg::KIND_GMR),
        (ModelKind::Cgmr, MotionCommandMsg::KIND_CGMR),
        (ModelKind::Dmp, MotionCommandMsg::KIND_DMP),
        (ModelKind::Hmm, MotionCommandMsg::KIND_HMM),
    ]
    .into_iter()
    .enumerate()
    {
        let data = if kind == ModelKind::Dmp { &demos[..1] } else { &demos[..] };
        let json = serde_json::to_string(&Model::fit(kind, data, &opts).expect("fit")).expect("json");
        let goal = x0 - nalgebra::Vector3::new(0.15, 0.1, 0.05);
        let msg = MotionCommandMsg {
            id: id as u32 + 1,
            kind: msg_kind,
            parameters_json: json,
            goal: Pose { position: Point { x: goal.x, y: goal.y, z: goal.z }, orientation: Quaternion { w: 1.0, ..Default::default() } },
            hold_orientation: true,
            ..Default::default()
        };
        let (cmd, field) = adapter.command(&msg).expect("accepted");
        runs.push((cmd, field.expect("model")));
    }
    // The HMM again, with an elbow HMM on lwr_link_4 (a path 3 cm off the elbow's start).
    let elbow = model.link_pose(&q, model.link_index("lwr_link_4").expect("elbow")).translation.vector;
    let elbow_demos: Vec<Demonstration> = (0..3)
        .map(|i| {
            let pos = t.iter().flat_map(|t| [elbow.x, elbow.y + 0.03 * t / 2.0 + 0.001 * i as f64, elbow.z]);
            Demonstration::new(3, t.clone(), pos.collect(), None).expect("elbow demo")
        })
        .collect();
    let mut v = serde_json::to_value(Model::fit(ModelKind::Hmm, &demos, &opts).expect("fit")).expect("json");
    v["null_space"] = serde_json::json!({"link": "lwr_link_4", "model": Model::fit(ModelKind::Hmm, &elbow_demos, &opts).expect("elbow fit")});
    let msg = MotionCommandMsg {
        id: 5,
        kind: MotionCommandMsg::KIND_HMM,
        parameters_json: v.to_string(),
        goal: Pose { position: Point { x: x0.x, y: x0.y, z: x0.z }, orientation: Quaternion { w: 1.0, ..Default::default() } },
        hold_orientation: true,
        ..Default::default()
    };
    let (cmd, field) = adapter.command(&msg).expect("accepted");
    assert!(field.as_ref().is_some_and(|f| f.null_space_link().is_some()));
    runs.push((cmd, field.expect("model")));
    let mut ctl = DsController::new(model.clone(), Params::default().controller).expect("controller");
    let mut out = ControlOutput::default();
    let before = cowork_testkit::allocations();
    let mut k = 0;
    for (cmd, field) in &mut runs {
        for _ in 0..2000 {
            let t = k as f64 * 1e-3;
            let input = ControlInput {
                time: t,
                q,
                command: *cmd,
                distances: Distances::clear(t),
                human: HumanInput { stamp: t, state: HumanState::default() },
            };
            ctl.step_with_field(&input, Some(field as &mut dyn LearnedField), &mut out).expect("step");
            q += out.qdot * 1e-3;
            k += 1;
        }
    }
    let allocated = cowork_testkit::allocations() - before;
    assert_eq!(allocated, 0, "{allocated} allocations in 10000 learned steps");
    assert!(out.diagnostics.goal_error_m.is_finite());
}
