//! The fuzz targets: every parser a peer, a file or a user reaches, each with a seed corpus of
//! real inputs (the bundled bags, parameter files, task schemas, gesture model, supervisor event
//! scripts) and the product's own decode + validate path as the check.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use cowork_bag::BagReader;
use cowork_ds::LearnedField;
use cowork_motion::demo::Demonstration;
use cowork_motion::model::{FitOptions, Model, ModelKind};
use cowork_msgs::sensor_msgs::Image;
use cowork_msgs::{RosMessage, from_cdr, known_types, to_cdr, with_message_type};
use nalgebra::Vector3;

use crate::{Target, Verdict};

/// Text tokens for the mutator: numbers that break ranges, structure that breaks parsers.
const TEXT_TOKENS: &[&[u8]] = &[
    b"NaN", b".nan", b"-.inf", b"inf", b"-1", b"0", b"1e308", b"-1e308", b"1e-320", b"18446744073709551616",
    b"4294967295", b"null", b"true", b"\"\"", b"[]", b"{}", b"[", b"]", b"{", b"}", b"(", b")", b",", b":",
    b"\"", b"\\", b"\n", b"  ", b"#", b"%", b"&a ", b"*a", b"!!binary ", b"- ", b"\xff\xfe", b"\xe2\x82\xac",
    b"schema(", b"subtask(", b"arm", b"[]string", b"uint8[]", b"float64[3] ", b"=", b"MSG: ",
];

/// Bytes of a binary message are mostly numbers: no text tokens, only the mutator's integers.
const NO_TOKENS: &[&[u8]] = &[];

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("cannot read seed {}", path.display()))
}

fn verdict<T, E>(r: std::result::Result<T, E>) -> Verdict {
    if r.is_ok() { Verdict::Accepted } else { Verdict::Refused }
}

/// Every target, seeds loaded from the repository.
pub fn all() -> Result<Vec<Target>> {
    let root = workspace_root();
    let bag_seeds = bag_messages(&root)?;
    let mut out = cdr_targets(&bag_seeds);
    out.extend(schema_targets());
    out.push(mcap_target(&root)?);
    out.push(depth_image_target(&bag_seeds));
    out.push(ltm_target(&root)?);
    out.push(term_target());
    out.push(events_target(&root)?);
    out.push(learned_model_target()?);
    out.push(gesture_model_target(&root)?);
    out.extend(params_targets(&root)?);
    out.extend(crate::streams::targets(&root, &bag_seeds)?);
    Ok(out)
}

/// (type name, payload) of up to 4 messages per channel of the bundled bags (payloads ≤ 2 MB).
fn bag_messages(root: &Path) -> Result<Vec<(String, Vec<u8>)>> {
    let mut out: Vec<(String, Vec<u8>)> = Vec::new();
    for name in ["gestures.mcap", "kinesthetic-pour.mcap", "static-scene.mcap"] {
        let path = root.join("bags").join(name);
        let reader = BagReader::open(&path).with_context(|| format!("seed bag {}", path.display()))?;
        let mut per_topic: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
        for m in reader.messages().flatten() {
            let n = per_topic.entry(m.topic.to_string()).or_default();
            if *n < 4 && m.data.len() <= 2 << 20 {
                *n += 1;
                out.push((m.type_name.to_string(), m.data));
            }
        }
    }
    Ok(out)
}

/// One target per message type: CDR payload → typed message → JSON, as `cowork bag` and every
/// subscription decode it.
fn cdr_targets(bag: &[(String, Vec<u8>)]) -> Vec<Target> {
    known_types()
        .iter()
        .map(|info| {
            let type_name = info.type_name();
            let mut seeds: Vec<Vec<u8>> =
                with_message_type!(&type_name, T => to_cdr(&T::default())).into_iter().collect();
            seeds.extend(bag.iter().filter(|(t, _)| info.matches(t)).map(|(_, d)| d.clone()));
            let decode = info.cdr_to_json;
            let big = seeds.iter().any(|s| s.len() > 100_000);
            Target {
                name: format!("cdr {type_name}"),
                family: "CDR message decoding (every type)",
                seeds,
                dictionary: NO_TOKENS,
                max_len: 4 << 20,
                cost: if big { 20 } else { 1 },
                check: Box::new(move |b| verdict(decode(b))),
            }
        })
        .collect()
}

/// One target per message type: a bag's `ros2msg` schema text compared with ours by layout.
fn schema_targets() -> Vec<Target> {
    known_types()
        .iter()
        .map(|info| {
            let type_name = info.type_name();
            let ours = (info.definition)();
            let name = type_name.clone();
            Target {
                name: format!("ros2msg {type_name}"),
                family: "ros2msg schema layout comparison",
                seeds: vec![ours.clone().into_bytes()],
                dictionary: TEXT_TOKENS,
                max_len: 64 << 10,
                cost: 4,
                check: Box::new(move |b| {
                    let text = String::from_utf8_lossy(b);
                    match cowork_bag::schema::first_difference(&name, &ours, &text) {
                        None => Verdict::Accepted,
                        Some(_) => Verdict::Refused,
                    }
                }),
            }
        })
        .collect()
}

/// A whole MCAP file, read as `cowork bag info|play` do: recoverable open, topic check, every
/// message decoded.
fn mcap_target(root: &Path) -> Result<Target> {
    let dir = tempfile::tempdir().context("temporary directory for MCAP inputs")?;
    let small = dir.path().join("seed.mcap");
    write_seed_bag(&small)?;
    let mut pour = read(&root.join("bags/kinesthetic-pour.mcap"))?;
    pour.truncate(96 << 10); // a truncated recording: recoverable up to the last whole chunk
    let seeds = vec![read(&small)?, pour];
    let input = dir.path().join("input.mcap");
    Ok(Target {
        name: "mcap bag".into(),
        family: "MCAP bag reading (recoverable) + decode",
        seeds,
        dictionary: NO_TOKENS,
        max_len: 1 << 20,
        cost: 50,
        check: Box::new(move |b| {
            let _keep = &dir;
            if std::fs::write(&input, b).is_err() {
                return Verdict::Refused;
            }
            let Ok(reader) = BagReader::open_recoverable(&input) else {
                return Verdict::Refused;
            };
            let _ = reader.info();
            let _ = cowork_bag::check_bag(&reader);
            let mut ok = reader.damage().is_none();
            for m in reader.messages().take(5000) {
                match m {
                    Ok(m) => ok &= m.decode_json().is_ok(),
                    Err(_) => ok = false,
                }
            }
            if ok { Verdict::Accepted } else { Verdict::Refused }
        }),
    })
}

/// A small bag with the graph's main types, chunked and compressed as the recorder writes it.
fn write_seed_bag(path: &Path) -> Result<()> {
    use cowork_msgs::sensor_msgs::JointState;
    use cowork_msgs::std_msgs::String as RosString;
    let mut w = cowork_bag::BagWriter::create(path)?;
    let js = w.add_channel::<JointState>("/joint_states")?;
    let img = w.add_channel::<Image>("/camera/depth/image_raw")?;
    let speech = w.add_channel::<RosString>("/speech_command")?;
    for k in 0..3u64 {
        let mut j = JointState::default();
        j.name = (1..=7).map(|i| format!("lwr_joint_{i}")).collect();
        j.position = vec![0.1 * k as f64; 7];
        w.write(js, k * 1_000_000, k * 1_000_000, &j)?;
    }
    w.write(img, 2_000_000, 2_000_000, &small_depth_image("32FC1", 4))?;
    w.write(speech, 3_000_000, 3_000_000, &RosString { data: "teach".into() })?;
    w.finish()?;
    Ok(())
}

fn small_depth_image(encoding: &str, bpp: u32) -> Image {
    let (width, height) = (8u32, 6u32);
    let mut msg = Image::default();
    msg.width = width;
    msg.height = height;
    msg.encoding = encoding.into();
    msg.step = width * bpp;
    msg.data = (0..width * height * bpp).map(|i| (i * 37 % 251) as u8).collect();
    msg
}

/// A depth `sensor_msgs/Image` payload → message → depth image, as fded_distance reads frames.
fn depth_image_target(bag: &[(String, Vec<u8>)]) -> Target {
    let mut seeds = vec![to_cdr(&small_depth_image("32FC1", 4)), to_cdr(&small_depth_image("16UC1", 2))];
    let is_image = |t: &str| cowork_msgs::type_name_matches(Image::PACKAGE, Image::NAME, t);
    seeds.extend(bag.iter().filter(|(t, _)| is_image(t)).take(1).map(|(_, d)| d.clone()));
    let mut image = cowork_depth::DepthImage::default();
    Target {
        name: "depth image".into(),
        family: "depth image decoding (fded_distance)",
        seeds,
        dictionary: NO_TOKENS,
        max_len: 4 << 20,
        cost: 10,
        check: Box::new(move |b| {
            let Ok(msg) = from_cdr::<Image>(b) else { return Verdict::Refused };
            verdict(image.read_image_msg(&msg))
        }),
    }
}

/// Task schemas (the supervisor's LTM, thesis notation), as the node and `cowork` load them.
fn ltm_target(root: &Path) -> Result<Target> {
    let seeds = vec![read(&root.join("config/tasks/kitchen.schema"))?, read(&root.join("config/tasks/pizza.schema"))?];
    Ok(Target {
        name: "ltm".into(),
        family: "LTM task schemas",
        seeds,
        dictionary: TEXT_TOKENS,
        max_len: 256 << 10,
        cost: 2,
        check: Box::new(|b| verdict(cowork_supervisor::Ltm::parse(&String::from_utf8_lossy(b)))),
    })
}

/// Terms from speech (`human add(water)`) and `--task` arguments.
fn term_target() -> Target {
    let seeds = ["add(water)", "prepareCoffee", "take(Obj)", "put(dough, central_area)", "human use(spoon)"]
        .iter()
        .map(|s| s.as_bytes().to_vec())
        .collect();
    Target {
        name: "term".into(),
        family: "speech / task terms",
        seeds,
        dictionary: TEXT_TOKENS,
        max_len: 4 << 10,
        cost: 1,
        check: Box::new(|b| verdict(cowork_supervisor::Term::parse(&String::from_utf8_lossy(b)))),
    }
}

/// Supervisor event scripts (JSONL), as `cowork supervisor run` reads them.
fn events_target(root: &Path) -> Result<Target> {
    let dir = root.join("nodes/lib/supervisor/tests/data");
    let mut seeds = Vec::new();
    for name in ["coffee_cooperative.jsonl", "pizza_teach_left.jsonl", "pour_execute.jsonl"] {
        seeds.push(read(&dir.join(name))?);
    }
    Ok(Target {
        name: "events".into(),
        family: "supervisor event scripts (JSONL)",
        seeds,
        dictionary: TEXT_TOKENS,
        max_len: 256 << 10,
        cost: 4,
        check: Box::new(|b| verdict(cowork_supervisor::parse_jsonl(&String::from_utf8_lossy(b)))),
    })
}

/// Learned models in `/motion/command` (DMP, GMR-DS, C-GMR JSON), decoded as ds_controller does,
/// then run for 50 control steps as the 1 kHz loop would.
fn learned_model_target() -> Result<Target> {
    let n = 60;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.05).collect();
    let pos: Vec<f64> = t
        .iter()
        .flat_map(|&s| {
            let a = s / t[n - 1] * std::f64::consts::FRAC_PI_2;
            [0.5 + 0.2 * a.cos(), 0.2 * a.sin(), 0.3 - 0.1 * a / std::f64::consts::FRAC_PI_2]
        })
        .collect();
    let demo = Demonstration::new(3, t, pos, None).context("seed demonstration")?;
    let mut seeds = Vec::new();
    for kind in [ModelKind::Dmp, ModelKind::Gmr, ModelKind::Cgmr] {
        let model = Model::fit(kind, std::slice::from_ref(&demo), &FitOptions::default())
            .with_context(|| format!("fitting the seed {kind:?} model"))?;
        seeds.push(serde_json::to_vec(&model).context("seed model JSON")?);
    }
    seeds.push(br#"{"model_file": "../../etc/passwd"}"#.to_vec());
    // An HMM with a null-space (elbow) HMM, as refine-elbow sends it.
    let hmm = Model::fit(ModelKind::Hmm, std::slice::from_ref(&demo), &FitOptions::default()).context("fitting the seed HMM")?;
    let mut with_elbow = serde_json::to_value(&hmm).context("seed HMM JSON")?;
    with_elbow["null_space"] = serde_json::json!({"link": "lwr_link_4", "model": &hmm});
    seeds.push(serde_json::to_vec(&with_elbow).context("seed HMM JSON")?);
    let links: Vec<String> = (0..8).map(|i| if i == 0 { "lwr_base_link".to_owned() } else { format!("lwr_link_{i}") }).collect();
    Ok(Target {
        name: "learned model".into(),
        family: "learned models in /motion/command (ds_controller)",
        seeds,
        dictionary: TEXT_TOKENS,
        max_len: 256 << 10,
        cost: 4,
        check: Box::new(move |b| {
            let text = String::from_utf8_lossy(b);
            let mut accepted = false;
            for kind in ["dmp", "gmr", "cgmr", "hmm"] {
                if let Ok(mut field) = ds_controller::learned::decode(kind, &text, &ds_controller::learned::ModelFiles::NONE, &links) {
                    accepted = true;
                    let goal = Vector3::new(0.5, 0.1, 0.3);
                    let mut x = Vector3::new(0.6, 0.0, 0.4);
                    let mut elbow = Vector3::new(0.1, 0.0, 0.7);
                    field.reset(&x, &goal);
                    for _ in 0..50 {
                        let v = field.velocity(&x, &goal, 1e-3);
                        x += v * 1e-3;
                        if field.null_space_link().is_some() {
                            elbow += field.null_space_velocity(&elbow) * 1e-3;
                        }
                    }
                }
            }
            if accepted { Verdict::Accepted } else { Verdict::Refused }
        }),
    })
}

/// The gesture model file (`cowork learn gestures` output), as human_observer loads it.
fn gesture_model_target(root: &Path) -> Result<Target> {
    let text = std::fs::read_to_string(root.join("config/gestures.json")).context("config/gestures.json")?;
    let mut model: cowork_observer::GestureModel = serde_json::from_str(&text).context("config/gestures.json")?;
    // Two templates per label keep each input small; the structure is the same.
    let mut kept = std::collections::HashMap::<String, usize>::new();
    model.templates.retain(|t| {
        let n = kept.entry(t.label.clone()).or_default();
        *n += 1;
        *n <= 2
    });
    let seed = serde_json::to_vec(&model).context("seed gesture model")?;
    Ok(Target {
        name: "gesture model".into(),
        family: "gesture model files (human_observer)",
        seeds: vec![seed],
        dictionary: TEXT_TOKENS,
        max_len: 1 << 20,
        cost: 8,
        check: Box::new(|b| {
            // What `GestureModel::from_file` does after reading the file.
            let ok = serde_json::from_slice::<cowork_observer::GestureModel>(b).is_ok_and(|m| m.validate(None).is_ok());
            if ok { Verdict::Accepted } else { Verdict::Refused }
        }),
    })
}

/// Every node's parameter file: YAML → typed parameters → `validate()`, as each `main` does.
fn params_targets(root: &Path) -> Result<Vec<Target>> {
    fn target(root: &Path, node: &'static str, check: fn(&str) -> bool) -> Result<Target> {
        let path = root.join(format!("config/{node}.yaml"));
        let seed = read(&path)?;
        // The same document as JSON (which YAML reads too), so the mutator can change its values
        // structurally: extreme numbers, wrong types, missing keys, resized lists.
        let value: serde_json::Value =
            serde_yaml_ng::from_slice(&seed).with_context(|| format!("seed {}", path.display()))?;
        let as_json = serde_json::to_vec(&value).context("seed parameters as JSON")?;
        Ok(Target {
            name: format!("params {node}"),
            family: "node parameter files (YAML)",
            seeds: vec![seed, as_json],
            dictionary: TEXT_TOKENS,
            max_len: 64 << 10,
            cost: 2,
            check: Box::new(move |b| if check(&String::from_utf8_lossy(b)) { Verdict::Accepted } else { Verdict::Refused }),
        })
    }
    use cowork_ros::params::from_str;
    Ok(vec![
        target(root, "ds_controller", |t| {
            from_str::<ds_controller::Params>(t, "ds_controller", "fuzz").is_ok_and(|p| p.validate("fuzz").is_ok())
        })?,
        target(root, "fded_distance", |t| {
            from_str::<fded_distance::Params>(t, "fded_distance", "fuzz").is_ok_and(|p| p.validate("fuzz").is_ok())
        })?,
        target(root, "human_observer", |t| {
            from_str::<human_observer::Params>(t, "human_observer", "fuzz").is_ok_and(|p| p.validate("fuzz").is_ok())
        })?,
        target(root, "robot_manager", |t| {
            from_str::<robot_manager::Params>(t, "robot_manager", "fuzz").is_ok_and(|p| p.validate("fuzz").is_ok())
        })?,
        target(root, "attentional_supervisor", |t| {
            from_str::<attentional_supervisor::Params>(t, "attentional_supervisor", "fuzz")
                .is_ok_and(|p| p.validate("fuzz").is_ok())
        })?,
        target(root, "lwr_sim", |t| {
            from_str::<lwr_sim::LwrSimConfig>(t, "lwr_sim", "fuzz").is_ok_and(|p| p.validate("fuzz").is_ok())
        })?,
    ])
}
