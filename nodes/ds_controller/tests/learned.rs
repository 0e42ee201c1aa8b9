//! DMP / GMR / C-GMR commands: a model learned with `cowork_motion` travels in
//! `MotionCommand.parameters_json` (or as a file named there), the adapter decodes it, and the
//! controller runs it through `DsController::step_with_field` on the LWR (kinematic closed
//! loop, no DDS) to a goal that is not the demonstrated one (goal adaptation, eq. 5.2).
//! Malformed models are rejected with a reason.

use std::path::PathBuf;

use cowork_ds::{
    ControlInput, ControlOutput, Distances, DsController, HumanInput, HumanState, LearnedField,
    Primitive,
};
use cowork_motion::model::{FitOptions, Model, ModelKind};
use cowork_motion::{Components, Demonstration};
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::MotionCommand as MotionCommandMsg;
use cowork_robot::{JointVector, RobotModel};
use ds_controller::{Adapter, Params};
use nalgebra::Vector3;

fn lwr() -> RobotModel {
    let urdf = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/robot/lwr4plus.urdf");
    RobotModel::from_urdf_file(urdf).expect("URDF")
}

fn q_start() -> JointVector {
    JointVector::from_row_slice(&[0.0, 0.5, 0.0, -1.3, 0.0, 0.8, 0.0])
}

/// Three demonstrations in the TCP frame of motion, curved, ending at the origin, 2 s at 100 Hz
/// (positions m relative to the target).
fn demos() -> Vec<Demonstration> {
    [(0.20, 0.10, 0.05), (0.22, 0.06, 0.08), (0.18, 0.12, 0.02)]
        .iter()
        .map(|&(a, b, c)| {
            let n = 201;
            let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
            let pos = t
                .iter()
                .flat_map(|&t| {
                    let s = (1.0 - t / 2.0).powi(2);
                    // A bend: the y part decays later than x.
                    let y = b * s * (1.0 + 0.5 * (std::f64::consts::PI * t / 2.0).sin());
                    [a * s, y, c * s]
                })
                .collect();
            Demonstration::new(3, t, pos, None).expect("demo")
        })
        .collect()
}

fn fit(kind: ModelKind) -> Model {
    let d = demos();
    let opts = FitOptions { components: Components::Fixed(3), ..FitOptions::default() };
    let data = if kind == ModelKind::Dmp { &d[..1] } else { &d[..] };
    Model::fit(kind, data, &opts).expect("fit")
}

fn command(id: u32, kind: u8, goal: Vector3<f64>, json: String) -> MotionCommandMsg {
    MotionCommandMsg {
        id,
        kind,
        parameters_json: json,
        goal: Pose {
            position: Point { x: goal.x, y: goal.y, z: goal.z },
            orientation: Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 },
        },
        hold_orientation: true,
        ..Default::default()
    }
}

/// Runs the command in a kinematic loop (q += q̇ dt) for `seconds`; returns the final and the
/// smallest TCP error (m) and the largest commanded TCP speed (m/s).
fn run(model: &RobotModel, msg: &MotionCommandMsg, seconds: f64) -> (f64, f64, f64) {
    run_with(model, &Params::default(), msg, seconds)
}

fn run_with(model: &RobotModel, params: &Params, msg: &MotionCommandMsg, seconds: f64) -> (f64, f64, f64) {
    let adapter = Adapter::new(model, params);
    let (cmd, learned) = adapter.command(msg).expect("command accepted");
    assert_eq!(cmd.primitive, Primitive::Learned);
    let mut field = learned.expect("a decoded model");
    let mut ctl = DsController::new(model.clone(), Params::default().controller).expect("controller");
    let mut out = ControlOutput::default();
    let mut q = q_start();
    let dt = ctl.config().period_s;
    let mut max_speed: f64 = 0.0;
    let mut min_err = f64::INFINITY;
    let steps = (seconds / dt) as usize;
    for k in 0..steps {
        let t = k as f64 * dt;
        let input = ControlInput {
            time: t,
            q,
            command: cmd,
            distances: Distances::clear(t),
            human: HumanInput { stamp: t, state: HumanState::default() },
        };
        ctl.step_with_field(&input, Some(&mut field as &mut dyn LearnedField), &mut out)
            .expect("valid step");
        max_speed = max_speed.max(out.diagnostics.ee_velocity.norm());
        min_err = min_err.min(out.diagnostics.goal_error_m);
        q += out.qdot * dt;
        if std::env::var_os("LEARNED_DEBUG").is_some() && k % 500 == 0 {
            eprintln!("t {t:.1} err {:.4} f {:?} status {:?}", out.diagnostics.goal_error_m, out.diagnostics.ee_velocity.as_slice(), out.status);
        }
    }
    let x = model.link_pose(&q, model.tip_link()).translation.vector;
    ((x - cmd.goal).norm(), min_err, max_speed)
}

#[test]
fn learned_primitives_reach_a_new_goal() {
    let model = lwr();
    let x0 = model.link_pose(&q_start(), model.tip_link()).translation.vector;
    // The demonstrations start ≈ 0.23 m from their target; the goal here is elsewhere.
    let goal = x0 + Vector3::new(-0.15, -0.12, -0.08);
    for (kind, msg_kind) in [
        (ModelKind::Gmr, MotionCommandMsg::KIND_GMR),
        (ModelKind::Cgmr, MotionCommandMsg::KIND_CGMR),
        (ModelKind::Dmp, MotionCommandMsg::KIND_DMP),
    ] {
        let json = serde_json::to_string(&fit(kind)).expect("model JSON");
        let (err, min_err, vmax) = run(&model, &command(1, msg_kind, goal, json), 8.0);
        eprintln!("{kind:?}: final TCP error {err:.4} m (closest {min_err:.4} m), max commanded speed {vmax:.3} m/s");
        assert!(vmax > 0.02 && vmax.is_finite(), "{kind:?}: {vmax}");
        if kind == ModelKind::Gmr {
            // Plain GMR-DS has no stability guarantee away from the demonstrations (the reason
            // for C-GMR, Sec. 3.1.3): it must bring the TCP near the goal, not keep it there.
            assert!(min_err < 0.05, "{kind:?}: never within 5 cm of the goal ({min_err} m)");
        } else {
            assert!(err < 0.01, "{kind:?}: {err} m from the goal");
        }
    }
}

fn primitive_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ds_controller_learned_{tag}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    dir
}

#[test]
fn a_model_file_can_be_named_inside_the_primitive_directory() {
    let model = lwr();
    let dir = primitive_dir("named");
    fit(ModelKind::Cgmr).save(&dir.join("cgmr.json")).expect("save");
    let params = Params { primitive_dir: dir.display().to_string(), ..Params::default() };
    let x0 = model.link_pose(&q_start(), model.tip_link()).translation.vector;
    let json = serde_json::json!({ "model_file": "cgmr.json" }).to_string();
    let (err, _, _) =
        run_with(&model, &params, &command(2, MotionCommandMsg::KIND_CGMR, x0 + Vector3::new(0.1, 0.05, 0.03), json), 8.0);
    assert!(err < 0.01, "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A peer must not make the node open files outside the primitive directory, devices, FIFOs
/// (which would block the ROS thread) or huge files, nor learn whether a path exists.
#[test]
fn model_files_outside_the_directory_or_not_plain_small_files_are_refused() {
    let model = lwr();
    let dir = primitive_dir("refused");
    let outside = primitive_dir("outside");
    fit(ModelKind::Cgmr).save(&outside.join("secret.json")).expect("save");
    std::os::unix::fs::symlink(outside.join("secret.json"), dir.join("link.json")).expect("symlink");
    std::fs::create_dir_all(dir.join("sub")).expect("subdir");
    let fifo = dir.join("fifo.json");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success());
    std::fs::write(dir.join("big.json"), vec![b' '; 2048]).expect("big");
    let params = Params { primitive_dir: dir.display().to_string(), max_model_file_bytes: 1024, ..Params::default() };
    let adapter = Adapter::new(&model, &params);
    let x0 = model.link_pose(&q_start(), model.tip_link()).translation.vector;
    let secret = outside.join("secret.json").display().to_string();
    let mut names = vec![
        (secret.clone(), "relative path"),
        ("../ds_controller_learned_outside/secret.json".to_owned(), "relative path"),
        ("link.json".to_owned(), "no readable model file"),
        ("sub".to_owned(), "no readable model file"),
        ("big.json".to_owned(), "no readable model file"),
        ("missing.json".to_owned(), "no readable model file"),
        ("/dev/zero".to_owned(), "relative path"),
    ];
    if made {
        names.push(("fifo.json".to_owned(), "no readable model file"));
    }
    let (mut reasons, t0) = (Vec::new(), std::time::Instant::now());
    for (name, expected) in names {
        let json = serde_json::json!({ "model_file": name }).to_string();
        let r = adapter.command(&command(5, MotionCommandMsg::KIND_CGMR, x0, json)).expect_err("refused");
        assert!(r.reason.contains(expected), "{name}: {:?} does not contain {expected:?}", r.reason);
        reasons.push(r.reason);
    }
    assert!(t0.elapsed() < std::time::Duration::from_secs(30), "a refusal blocked");
    // The reason for a missing file equals the one for an existing file behind a link.
    let generic = |r: &str| r.rsplit(": ").next().map(str::to_owned);
    assert_eq!(generic(&reasons[2]), generic(&reasons[5]), "{reasons:?}");
    // Without a directory every model file is refused.
    let none = Adapter::new(&model, &Params { primitive_dir: String::new(), ..Params::default() });
    let json = serde_json::json!({ "model_file": "cgmr.json" }).to_string();
    let r = none.command(&command(6, MotionCommandMsg::KIND_CGMR, x0, json)).expect_err("refused");
    assert!(r.reason.contains("disabled"), "{}", r.reason);
    std::fs::remove_dir_all(&dir).ok();
    std::fs::remove_dir_all(&outside).ok();
}

/// A learned model whose arrays disagree with its dimension or basis used to pass the decoder
/// and index out of bounds in the 1 kHz step (the real-time thread panicked): every such model
/// is refused when it is read.
#[test]
fn models_with_inconsistent_arrays_are_refused_before_they_run() {
    let model = lwr();
    let adapter = Adapter::new(&model, &Params::default());
    let x0 = model.link_pose(&q_start(), model.tip_link()).translation.vector;
    let edit = |kind: ModelKind, f: &dyn Fn(&mut serde_json::Value)| {
        let mut v = serde_json::to_value(fit(kind)).expect("json");
        f(&mut v);
        v.to_string()
    };
    let cases: Vec<(u8, String, &str)> = vec![
        (MotionCommandMsg::KIND_DMP, edit(ModelKind::Dmp, &|v| { v["weights"].as_array_mut().expect("w").truncate(5); }), "weights"),
        (MotionCommandMsg::KIND_DMP, edit(ModelKind::Dmp, &|v| { v["basis"]["widths"].as_array_mut().expect("w").pop(); }), "widths"),
        (MotionCommandMsg::KIND_DMP, edit(ModelKind::Dmp, &|v| { v["basis"]["centers"] = serde_json::json!([]); }), "basis"),
        (MotionCommandMsg::KIND_DMP, edit(ModelKind::Dmp, &|v| { v["goal"] = serde_json::json!([0.1]); }), "goal"),
        (MotionCommandMsg::KIND_DMP, edit(ModelKind::Dmp, &|v| { v["stiffness"] = serde_json::json!(-1.0); }), "stiffness"),
        (MotionCommandMsg::KIND_CGMR, edit(ModelKind::Cgmr, &|v| { v["u"].as_array_mut().expect("u").pop(); }), "u"),
        (MotionCommandMsg::KIND_CGMR, edit(ModelKind::Cgmr, &|v| { v["u"][0].as_array_mut().expect("u0").pop(); }), "u[0]"),
        (MotionCommandMsg::KIND_CGMR, edit(ModelKind::Cgmr, &|v| { v["ln_delta"] = serde_json::json!([0.0]); }), "ln_delta"),
        (MotionCommandMsg::KIND_GMR, edit(ModelKind::Gmr, &|v| { v["target"] = serde_json::json!(vec![0.0; 40]); }), "target"),
    ];
    for (kind, json, field) in cases {
        let r = adapter.command(&command(7, kind, x0, json)).expect_err("refused");
        assert!(r.reason.contains(field), "{field}: {}", r.reason);
    }
}

#[test]
fn malformed_models_are_rejected_with_a_reason() {
    let model = lwr();
    let adapter = Adapter::new(&model, &Params::default());
    let x0 = model.link_pose(&q_start(), model.tip_link()).translation.vector;
    let gmr = serde_json::to_string(&fit(ModelKind::Gmr)).expect("json");
    let two_d = {
        let d: Vec<Demonstration> = (0..2)
            .map(|i| {
                let t: Vec<f64> = (0..50).map(|k| k as f64 * 0.02).collect();
                let pos = t.iter().flat_map(|t| [(1.0 - t) * (1.0 + i as f64), 1.0 - t]).collect();
                Demonstration::new(2, t, pos, None).expect("demo")
            })
            .collect();
        let opts = FitOptions { components: Components::Fixed(1), ..FitOptions::default() };
        serde_json::to_string(&Model::fit(ModelKind::Gmr, &d, &opts).expect("fit")).expect("json")
    };
    for (kind, json, expected) in [
        (MotionCommandMsg::KIND_GMR, String::new(), "without a model"),
        (MotionCommandMsg::KIND_GMR, "{not json".to_owned(), "not JSON"),
        (MotionCommandMsg::KIND_DMP, gmr.clone(), "the model is a gmr model"),
        (MotionCommandMsg::KIND_GMR, two_d, "2-D"),
        (MotionCommandMsg::KIND_CGMR, r#"{"model_file": "/nonexistent/m.json"}"#.to_owned(), "relative path"),
    ] {
        let r = adapter.command(&command(3, kind, x0, json)).expect_err("rejected");
        assert!(r.reason.contains(expected), "{:?} does not contain {expected:?}", r.reason);
    }
    // Without its field a learned command holds the robot with a reason.
    let (cmd, _) = adapter.command(&command(4, MotionCommandMsg::KIND_GMR, x0, gmr)).expect("ok");
    let mut ctl = DsController::new(model.clone(), Params::default().controller).expect("controller");
    let mut out = ControlOutput::default();
    let input = ControlInput {
        time: 0.0,
        q: q_start(),
        command: cmd,
        distances: Distances::clear(0.0),
        human: HumanInput { stamp: 0.0, state: HumanState::default() },
    };
    let e = ctl.step(&input, &mut out).expect_err("no field");
    assert!(e.to_string().contains("learned model"), "{e}");
    assert!(matches!(out.status, cowork_ds::Status::Held(_)));
}

/// An HMM primitive (Algorithm 3, Sec. 4.1.3) runs as its generated path, translated to the
/// tool's start and tracked: the tool ends where the demonstrations' displacement takes it from
/// there, whatever the command's goal (which only says when the motion counts as converged).
#[test]
fn an_hmm_primitive_runs_its_generated_path_from_the_start() {
    let model = lwr();
    let x0 = model.link_pose(&q_start(), model.tip_link()).translation.vector;
    let d = demos();
    let hmm = Model::fit(ModelKind::Hmm, &d, &FitOptions::default()).expect("fit");
    let Model::Hmm(h) = &hmm else { unreachable!("an HMM was fitted") };
    let tr = h.generate(None, 0.01).expect("generate");
    let n = tr.pos.len();
    let displacement = Vector3::new(tr.pos[n - 3] - tr.pos[0], tr.pos[n - 2] - tr.pos[1], tr.pos[n - 1] - tr.pos[2]);
    let end = x0 + displacement;
    let json = serde_json::to_string(&hmm).expect("json");
    // The goal sent is the path's end: the status converges there.
    let (err, _, vmax) = run(&model, &command(8, MotionCommandMsg::KIND_HMM, end, json), 4.0);
    eprintln!("HMM: {:.1} mm from the end of its path ({:.3} m away), max commanded speed {vmax:.3} m/s", err * 1e3, displacement.norm());
    assert!(displacement.norm() > 0.2, "the demonstrations move {displacement:?}");
    assert!(err < 0.005, "the tool ended {err} m from the HMM path's end");
}

/// HMMs a peer could send to stall or crash the node: refused with the field named, before a
/// path is generated.
#[test]
fn bad_hmm_models_are_refused_before_they_run() {
    let model = lwr();
    let adapter = Adapter::new(&model, &Params::default());
    let x0 = model.link_pose(&q_start(), model.tip_link()).translation.vector;
    let edit = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut v = serde_json::to_value(Model::fit(ModelKind::Hmm, &demos(), &FitOptions::default()).expect("fit")).expect("json");
        f(&mut v);
        v.to_string()
    };
    let cases: Vec<(String, &str)> = vec![
        // A state that never ends (a_ii = 1) with a duration of 10⁹ samples: 10⁷ s of path.
        (
            edit(&|v| {
                let l = v["states"].as_array().expect("states").len();
                v["trans"][0] = serde_json::json!(1.0);
                v["durations"][0] = serde_json::json!(1e9);
                assert!(l > 1);
            }),
            "expected state durations",
        ),
        (edit(&|v| { v["trans"].as_array_mut().expect("trans").pop(); }), "trans"),
        (edit(&|v| { v["states"][2]["mean"] = serde_json::json!([0.1, 0.2]); }), "states[2].mean"),
        (edit(&|v| { v["dt"] = serde_json::json!(0.0); }), "dt"),
        (edit(&|v| { v["states"][1]["t_var"] = serde_json::json!(-1.0); }), "states[1]"),
    ];
    for (json, field) in cases {
        let r = adapter.command(&command(9, MotionCommandMsg::KIND_HMM, x0, json)).expect_err("refused");
        assert!(r.reason.contains(field), "{field}: {}", r.reason);
    }
    // An HMM sent as another kind is refused too.
    let json = edit(&|_| {});
    let r = adapter.command(&command(10, MotionCommandMsg::KIND_GMR, x0, json)).expect_err("refused");
    assert!(r.reason.contains("hmm model"), "{}", r.reason);
}

/// Runs `msg` in the kinematic loop for `seconds`; the tool's and `link`'s origin positions
/// every 10 ms (m, base frame).
fn run_paths(model: &RobotModel, msg: &MotionCommandMsg, link: usize, seconds: f64) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    let adapter = Adapter::new(model, &Params::default());
    let (cmd, learned) = adapter.command(msg).expect("command accepted");
    let mut field = learned.expect("a decoded model");
    let mut ctl = DsController::new(model.clone(), Params::default().controller).expect("controller");
    let mut out = ControlOutput::default();
    let mut q = q_start();
    let dt = ctl.config().period_s;
    let (mut tool, mut elbow) = (Vec::new(), Vec::new());
    for k in 0..(seconds / dt).round() as usize {
        if k % 10 == 0 {
            tool.push(model.link_pose(&q, model.tip_link()).translation.vector);
            elbow.push(model.link_pose(&q, link).translation.vector);
        }
        let t = k as f64 * dt;
        let input = ControlInput {
            time: t,
            q,
            command: cmd,
            distances: Distances::clear(t),
            human: HumanInput { stamp: t, state: HumanState::default() },
        };
        ctl.step_with_field(&input, Some(&mut field as &mut dyn LearnedField), &mut out).expect("valid step");
        q += out.qdot * dt;
    }
    (tool, elbow)
}

/// A null-space (elbow) HMM primitive beside the end-effector HMM (Sec. 4.1.1, Fig. 4.1):
/// taught an elbow path moved sideways by up to 5 cm mid-way (the swivel direction here: the
/// arm starts in the x–z plane), the elbow moves while the tool's path stays where the
/// end-effector primitive alone puts it.
#[test]
fn an_hmm_null_space_primitive_moves_the_elbow_and_leaves_the_tool_alone() {
    let model = lwr();
    let elbow_link = model.link_names().iter().position(|n| n == "lwr_link_4").expect("elbow link");
    let hmm = Model::fit(ModelKind::Hmm, &demos(), &FitOptions::default()).expect("fit");
    let json = serde_json::to_string(&hmm).expect("json");
    let Model::Hmm(h) = &hmm else { unreachable!("an HMM was fitted") };
    let duration = h.generate(None, 0.01).expect("generate").t.last().copied().expect("samples");
    let x0 = model.link_pose(&q_start(), model.tip_link()).translation.vector;
    let msg = command(11, MotionCommandMsg::KIND_HMM, x0, json.clone());
    let (tool0, elbow0) = run_paths(&model, &msg, elbow_link, duration + 1.0);
    // Elbow demonstrations: the elbow's own path, moved by a bump of 4, 5 and 6 cm along y mid-way.
    let n = elbow0.len().min((duration / 0.01) as usize + 1);
    let raised = |height: f64| {
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.01).collect();
        let pos = (0..n)
            .flat_map(|k| {
                let s = (std::f64::consts::PI * k as f64 / (n - 1) as f64).sin().powi(2);
                let p = elbow0[k] + Vector3::y() * (height * s);
                [p.x, p.y, p.z]
            })
            .collect();
        Demonstration::new(3, t, pos, None).expect("elbow demo")
    };
    let elbow_demos: Vec<_> = [0.04, 0.05, 0.06].iter().map(|&h| raised(h)).collect();
    let elbow_hmm = Model::fit(ModelKind::Hmm, &elbow_demos, &FitOptions::default()).expect("elbow fit");
    let mut v: serde_json::Value = serde_json::from_str(&json).expect("json");
    v["null_space"] = serde_json::json!({"link": "lwr_link_4", "model": elbow_hmm});
    let msg = command(12, MotionCommandMsg::KIND_HMM, x0, v.to_string());
    let (tool1, elbow1) = run_paths(&model, &msg, elbow_link, duration + 1.0);
    let tool_moved = tool0.iter().zip(&tool1).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    let mid = n / 2;
    let rise = elbow1[mid].y - elbow0[mid].y;
    let elbow_moved = elbow0.iter().zip(&elbow1).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    eprintln!("null-space elbow primitive: elbow {:.1} mm along y mid-way (moved up to {:.1} mm), tool moved {:.2} mm", rise * 1e3, elbow_moved * 1e3, tool_moved * 1e3);
    assert!(rise > 0.03, "the elbow moved only {rise} m along y");
    assert!(tool_moved < 0.002, "the tool's path moved by {tool_moved} m");

    // Refused: a link that does not exist, the fixed base, a non-HMM elbow model, a DMP with one.
    let adapter = Adapter::new(&model, &Params::default());
    let with = |ns: serde_json::Value, kind: u8, base: &str| {
        let mut v: serde_json::Value = serde_json::from_str(base).expect("json");
        v["null_space"] = ns;
        adapter.command(&command(13, kind, x0, v.to_string())).expect_err("refused").reason
    };
    let r = with(serde_json::json!({"link": "lwr_link_9", "model": elbow_hmm}), MotionCommandMsg::KIND_HMM, &json);
    assert!(r.contains("lwr_link_9") && r.contains("lwr_link_4"), "{r}");
    let r = with(serde_json::json!({"link": "lwr_base_link", "model": elbow_hmm}), MotionCommandMsg::KIND_HMM, &json);
    assert!(r.contains("not a moving link"), "{r}");
    let r = with(serde_json::json!({"link": "lwr_link_4", "model": fit(ModelKind::Gmr)}), MotionCommandMsg::KIND_HMM, &json);
    assert!(r.contains("null_space.model") && r.contains("gmr"), "{r}");
    let r = with(serde_json::json!({"link": "lwr_link_4"}), MotionCommandMsg::KIND_HMM, &json);
    assert!(r.contains("null_space.model"), "{r}");
    let dmp = serde_json::to_string(&fit(ModelKind::Dmp)).expect("json");
    let r = with(serde_json::json!({"link": "lwr_link_4", "model": elbow_hmm}), MotionCommandMsg::KIND_DMP, &dmp);
    assert!(r.contains("HMM's clock"), "{r}");
}

/// Thesis Sec. 4.1.3 (elbow refinement) without DDS: with the parameters of
/// `config/ds_controller.yaml`, a slow pick-and-place HMM runs while a person presses the upper
/// arm with 14 N (between f_i and f_s: T² = [T_ee, T_ic]) along the elbow's swivel direction;
/// the elbow gives way, the tool stays on the path it takes alone.
#[test]
fn an_elbow_push_below_f_s_moves_the_elbow_and_leaves_the_tool_on_its_path() {
    use cowork_ds::ExternalWrench;
    let model = lwr();
    let params: Params = cowork_ros::params::load(
        &PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/ds_controller.yaml"),
        "ds_controller",
    )
    .expect("params");
    let demos: Vec<Demonstration> = (0..5)
        .map(|k| {
            let bow = [0.01 * (k as f64 - 2.0) / 2.0, 0.0, 0.08 + 0.01 * k as f64];
            Demonstration::minimum_jerk(&[0.40, 0.25, 0.10], &[0.6, -0.14, 0.027], &bow, 9.5 + 0.2 * k as f64, 0.5, 0.01).expect("demo")
        })
        .collect();
    let hmm = Model::fit(ModelKind::Hmm, &demos, &FitOptions::default()).expect("fit");
    let json = serde_json::to_string(&hmm).expect("json");
    let q0 = JointVector::from_row_slice(&[33.8f64, 41.6, -2.3, 106.5, 2.9, 31.9, 29.6].map(f64::to_radians));
    let elbow = model.link_index("lwr_link_4").expect("elbow");
    let upper_arm = model.link_index("lwr_link_3").expect("upper arm");
    let run = |push: bool, json: &str| {
        let adapter = Adapter::new(&model, &params);
        let x0 = model.link_pose(&q0, model.tip_link()).translation.vector;
        let (cmd, learned) = adapter.command(&command(21, MotionCommandMsg::KIND_HMM, x0, json.to_owned())).expect("command");
        let mut field = learned.expect("model");
        let mut ctl = DsController::new(model.clone(), params.controller).expect("controller");
        let mut out = ControlOutput::default();
        let mut q = q0;
        let dt = ctl.config().period_s;
        let (mut tool, mut elbows, mut max_w3): (Vec<Vector3<f64>>, Vec<Vector3<f64>>, f64) = (Vec::new(), Vec::new(), 0.0);
        let mut u = Vector3::zeros();
        for k in 0..(11.0 / dt) as usize {
            let t = k as f64 * dt;
            if k % 10 == 0 {
                tool.push(model.link_pose(&q, model.tip_link()).translation.vector);
                elbows.push(model.link_pose(&q, elbow).translation.vector);
            }
            if k == 2500 {
                // The swivel direction now: the elbow's motion in the null space of the tool pose.
                let mut poses = cowork_robot::LinkPoses::new();
                model.forward_kinematics(&q, &mut poses);
                let mut j = cowork_robot::Jacobian::zeros();
                model.jacobian(&poses, model.tip_link(), &nalgebra::Point3::origin(), &mut j);
                let n = cowork_robot::null_space_projector(&j, &cowork_robot::damped_pseudo_inverse(&j, 1e-6));
                let v = (0..7).map(|c| n.column(c).into_owned()).max_by(|a, b| a.norm().total_cmp(&b.norm())).expect("column");
                let mut jl = cowork_robot::PositionJacobian::zeros();
                model.position_jacobian(&poses, elbow, &nalgebra::Point3::origin(), &mut jl);
                u = (jl * v).normalize();
            }
            let input = ControlInput {
                time: t,
                q,
                command: cmd,
                distances: Distances::clear(t),
                human: HumanInput { stamp: t, state: HumanState::default() },
            };
            let wrench = ExternalWrench { stamp: t, link: upper_arm, force: u * 14.0 };
            let w = (push && (2.5..7.0).contains(&t)).then_some(&wrench);
            ctl.step_with_contact(&input, Some(&mut field as &mut dyn LearnedField), w, &mut out).expect("step");
            max_w3 = max_w3.max(out.diagnostics.contact.weights[2]);
            q += out.qdot * dt;
        }
        (tool, elbows, u, max_w3)
    };
    let (tool0, elbow0, _, _) = run(false, &json);
    // With an elbow primitive too: the elbow's own path taught back as a null-space HMM.
    let t: Vec<f64> = (0..elbow0.len()).map(|k| k as f64 * 0.01).collect();
    let elbow_demo = |dz: f64| {
        let pos = elbow0.iter().flat_map(|p| [p.x, p.y, p.z + dz]).collect();
        Demonstration::new(3, t.clone(), pos, None).expect("elbow demo")
    };
    let elbow_hmm = Model::fit(ModelKind::Hmm, &[elbow_demo(-0.002), elbow_demo(0.0), elbow_demo(0.002)], &FitOptions::default()).expect("elbow fit");
    let mut v: serde_json::Value = serde_json::from_str(&json).expect("json");
    v["null_space"] = serde_json::json!({"link": "lwr_link_4", "model": elbow_hmm});
    let with_elbow = v.to_string();
    let (tool_e, _, _, _) = run(false, &with_elbow);
    let elbow_primitive_moved_tool = tool0.iter().zip(&tool_e).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    eprintln!("the elbow primitive alone moves the tool by {:.2} mm", elbow_primitive_moved_tool * 1e3);
    let (tool1, elbow1, u, w3) = run(true, &with_elbow);
    let tool_moved = tool0.iter().zip(&tool1).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    let along: Vec<f64> = elbow0.iter().zip(&elbow1).map(|(a, b)| (b - a).dot(&u)).collect();
    let elbow_moved = along.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    eprintln!("elbow push 14 N: elbow moved up to {:.1} mm along the push, tool moved {:.2} mm, w3 up to {w3:.3}", elbow_moved * 1e3, tool_moved * 1e3);
    assert!(elbow_moved > 0.05, "the elbow moved {elbow_moved} m");
    assert!(tool_moved < 0.003, "the tool moved {tool_moved} m");
    assert!(w3 == 0.0, "T³ got weight {w3}");
    assert!(elbow_primitive_moved_tool < 0.003, "{elbow_primitive_moved_tool}");
}
