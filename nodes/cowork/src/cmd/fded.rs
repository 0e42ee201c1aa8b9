//! `cowork fded run` (distances for every depth frame of a bag, to CSV) and `cowork bench fded`
//! (thesis Tables 5.1 and 5.2 and the comparison with Flacco et al., Sec. 5.1.2–5.1.3).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Subcommand, ValueEnum};
use cowork_bag::BagReader;
use cowork_depth::{DepthImage, Intrinsics};
use cowork_fded::bench::{self, BenchScene, TimeStats};
use cowork_fded::gpu::{BackendRequest, FdedEngine};
use cowork_fded::{FdedParams, Frame};
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState};
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_robot::RobotModel;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};

const DEFAULT_URDF: &str = "config/robot/lwr4plus.urdf";

/// fDED commands.
#[derive(Debug, Subcommand)]
pub enum FdedCommand {
    /// Robot–obstacle distances for every depth frame of a bag, one CSV row per frame and link.
    Run(RunArgs),
}

/// Which implementation computes the distances.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BackendArg {
    /// The CPU reference.
    Cpu,
    /// The wgpu compute path (an error when no adapter exists).
    Gpu,
}

/// Arguments of `cowork fded run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// MCAP bag with depth images, camera info and joint states.
    pub bag: PathBuf,
    /// Robot lattice tile side T_s, px.
    #[arg(long, default_value_t = 32)]
    pub ts: u32,
    /// Object lattice step S_x = S_y, px.
    #[arg(long, default_value_t = 16)]
    pub step: u32,
    /// Implementation.
    #[arg(long, value_enum, default_value_t = BackendArg::Cpu)]
    pub backend: BackendArg,
    /// CPU worker threads.
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
    /// Output CSV.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Scene YAML (config/scenes/*.yaml) whose camera pose is used when the bag has no
    /// /tf_static chain from the robot base to the depth frame.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Robot description.
    #[arg(long, default_value = DEFAULT_URDF)]
    pub urdf: PathBuf,
    /// fDED parameter file (`fded_distance: ros__parameters:` YAML); --ts/--step/--threads
    /// override it.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Depth image topic.
    #[arg(long, default_value = "/camera/depth/image_raw")]
    pub depth_topic: String,
    /// Camera info topic.
    #[arg(long, default_value = "/camera/depth/camera_info")]
    pub info_topic: String,
    /// Joint state topic.
    #[arg(long, default_value = "/joint_states")]
    pub joints_topic: String,
}

/// Arguments of `cowork bench fded`.
#[derive(Debug, clap::Args)]
pub struct BenchFdedArgs {
    /// Depth frames from this bag (e.g. the `static-scene` bag of `cowork bag synth`) instead
    /// of the built-in synthetic static scene.
    #[arg(long)]
    pub bag: Option<PathBuf>,
    /// Scene YAML for the camera pose when the bag has no /tf_static.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Frames of the static scene (the thesis averaged 100).
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    /// Timed repetitions per frame and parameter set.
    #[arg(long, default_value_t = 5)]
    pub reps: usize,
    /// Threads of the multi-thread rows.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Wall-clock budget per parameter set, s (slow sets measure fewer frames).
    #[arg(long, default_value_t = 3.0)]
    pub budget: f64,
    /// Only the thesis parameter set, the worst case and Flacco (no T_s × S grid).
    #[arg(long)]
    pub quick: bool,
    /// Robot description.
    #[arg(long, default_value = DEFAULT_URDF)]
    pub urdf: PathBuf,
    /// Noise seed of the synthetic frames.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// Runs an `fded` subcommand.
pub fn run(cmd: FdedCommand) -> Result<()> {
    match cmd {
        FdedCommand::Run(a) => run_bag(a),
    }
}

/// One usable depth frame of a bag.
struct BagFrame {
    stamp: f64,
    depth: DepthImage,
    intrinsics: Intrinsics,
    camera_pose: Isometry3<f64>,
    joints: [f64; 7],
}

/// Topic names and fallbacks for reading frames from a bag.
struct BagSource<'a> {
    depth_topic: &'a str,
    info_topic: &'a str,
    joints_topic: &'a str,
    scene_pose: Option<Isometry3<f64>>,
}

/// Why frames were skipped.
#[derive(Debug, Default)]
struct Skipped {
    no_info: usize,
    no_joints: usize,
    no_pose: usize,
    bad_message: usize,
}

impl Skipped {
    fn report(&self) {
        if self.no_info + self.no_joints + self.no_pose + self.bad_message > 0 {
            eprintln!(
                "skipped frames: {} before any camera info, {} before any joint state, {} without a camera pose, {} undecodable messages",
                self.no_info, self.no_joints, self.no_pose, self.bad_message
            );
        }
    }
}

fn stamp_s(t: &cowork_msgs::builtin_interfaces::Time) -> f64 {
    f64::from(t.sec) + f64::from(t.nanosec) * 1e-9
}

fn strip(frame: &str) -> &str {
    frame.trim_start_matches('/')
}

type TfMap = HashMap<String, (String, Isometry3<f64>)>;

/// Base ← `frame` by chaining transforms (parent ← child) up to `base`; /tf_static entries
/// win over /tf ones.
fn chain(tf_static: &TfMap, tf: &TfMap, base: &str, frame: &str) -> Option<Isometry3<f64>> {
    let mut pose = Isometry3::identity();
    let mut f = strip(frame).to_owned();
    for _ in 0..64 {
        if f == base {
            return Some(pose);
        }
        let (parent, t) = tf_static.get(&f).or_else(|| tf.get(&f))?;
        pose = t * pose;
        f = parent.clone();
    }
    None
}

/// Calls `each` for every depth frame with camera info, joint state and camera pose known;
/// stops when it returns `false`. Frames missing one of those are skipped and counted.
fn for_each_frame(
    path: &Path,
    model: &RobotModel,
    src: &BagSource<'_>,
    mut each: impl FnMut(BagFrame) -> Result<bool>,
) -> Result<Skipped> {
    let reader = BagReader::open(path).with_context(|| format!("opening bag {}", path.display()))?;
    let base = model.link_names()[0].clone();
    let (mut tf_static, mut tf) = (TfMap::new(), TfMap::new());
    let mut intrinsics: Option<Intrinsics> = None;
    let mut joints: Option<[f64; 7]> = None;
    let mut skipped = Skipped::default();
    for message in reader.messages() {
        let message = message.with_context(|| format!("reading {}", path.display()))?;
        let topic = &*message.topic;
        if topic == "/tf_static" || topic == "/tf" {
            let Ok(m) = message.decode::<TFMessage>() else {
                skipped.bad_message += 1;
                continue;
            };
            for t in m.transforms {
                let tr = &t.transform;
                let q = UnitQuaternion::from_quaternion(Quaternion::new(tr.rotation.w, tr.rotation.x, tr.rotation.y, tr.rotation.z));
                let pose = Isometry3::from_parts(Translation3::new(tr.translation.x, tr.translation.y, tr.translation.z), q);
                let map = if topic == "/tf_static" { &mut tf_static } else { &mut tf };
                map.insert(strip(&t.child_frame_id).to_owned(), (strip(&t.header.frame_id).to_owned(), pose));
            }
        } else if topic == src.info_topic {
            match message.decode::<CameraInfo>().map_err(anyhow::Error::from).and_then(|i| Ok(Intrinsics::from_camera_info(&i)?)) {
                Ok(k) => intrinsics = Some(k),
                Err(e) => {
                    tracing::warn!("{topic}: {e:#}");
                    skipped.bad_message += 1;
                }
            }
        } else if topic == src.joints_topic {
            let Ok(js) = message.decode::<JointState>() else {
                skipped.bad_message += 1;
                continue;
            };
            let mut q = [0.0; 7];
            let mut ok = js.position.len() >= 7;
            for (j, name) in model.joint_names().iter().enumerate() {
                match js.name.iter().position(|n| n == name) {
                    Some(i) if i < js.position.len() => q[j] = js.position[i],
                    _ if js.name.is_empty() && j < js.position.len() => q[j] = js.position[j],
                    _ => ok = false,
                }
            }
            if ok {
                joints = Some(q);
            } else {
                skipped.bad_message += 1;
            }
        } else if topic == src.depth_topic {
            let img = match message.decode::<Image>() {
                Ok(i) => i,
                Err(e) => {
                    tracing::warn!("{topic}: {e}");
                    skipped.bad_message += 1;
                    continue;
                }
            };
            let Some(k) = intrinsics else {
                skipped.no_info += 1;
                continue;
            };
            let Some(q) = joints else {
                skipped.no_joints += 1;
                continue;
            };
            let Some(camera_pose) = chain(&tf_static, &tf, &base, &img.header.frame_id).or(src.scene_pose) else {
                skipped.no_pose += 1;
                continue;
            };
            let depth = match DepthImage::from_image_msg(&img) {
                Ok(d) => d,
                Err(e) => {
                    tracing::warn!("{topic}: {e}");
                    skipped.bad_message += 1;
                    continue;
                }
            };
            let go = each(BagFrame { stamp: stamp_s(&img.header.stamp), depth, intrinsics: k, camera_pose, joints: q })?;
            if !go {
                break;
            }
        }
    }
    Ok(skipped)
}

fn load_params(path: Option<&Path>) -> Result<FdedParams> {
    let Some(path) = path else {
        return Ok(FdedParams::default());
    };
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    #[derive(serde::Deserialize)]
    struct Node {
        #[serde(rename = "ros__parameters")]
        params: FdedParams,
    }
    let mut doc: HashMap<String, Node> = serde_yaml_ng::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    let node = doc.remove("fded_distance").with_context(|| format!("{}: no `fded_distance:` section", path.display()))?;
    node.params.validate().with_context(|| format!("{}", path.display()))?;
    Ok(node.params)
}

fn scene_pose(path: Option<&Path>) -> Result<Option<Isometry3<f64>>> {
    path.map(|p| {
        cowork_sim::Scene::from_file(p)
            .map(|s| s.camera.pose.isometry())
            .with_context(|| format!("reading scene {}", p.display()))
    })
    .transpose()
}

fn run_bag(a: RunArgs) -> Result<()> {
    let model = RobotModel::from_urdf_file(cowork_ros::config::resolve(&a.urdf)).with_context(|| format!("loading {}", a.urdf.display()))?;
    let mut params = load_params(a.params.as_deref())?;
    params.tile_size = a.ts;
    params.step_x = a.step;
    params.step_y = a.step;
    params.threads = a.threads;
    params.validate().context("fDED parameters")?;
    let request = match a.backend {
        BackendArg::Cpu => BackendRequest::Cpu,
        BackendArg::Gpu => BackendRequest::Gpu,
    };
    let src = BagSource {
        depth_topic: &a.depth_topic,
        info_topic: &a.info_topic,
        joints_topic: &a.joints_topic,
        scene_pose: scene_pose(a.scene.as_deref())?,
    };
    let mut csv = super::output::csv(&a.out)?;
    csv.write_record([
        "stamp", "link", "distance", "robot_x", "robot_y", "robot_z", "obstacle_x", "obstacle_y", "obstacle_z", "normal_x",
        "normal_y", "normal_z", "time_us",
    ])?;
    let mut engine: Option<(Intrinsics, FdedEngine)> = None;
    let mut out = None;
    let (mut frames, mut times) = (0usize, Vec::new());
    let depth_frames = BagReader::open(&a.bag)
        .map(|r| r.info().topics.iter().filter(|t| t.topic == a.depth_topic).map(|t| t.message_count).sum())
        .unwrap_or(0);
    let bar = super::observe::progress(depth_frames, "fded");
    let skipped = for_each_frame(&a.bag, &model, &src, |f| {
        bar.inc(1);
        if engine.as_ref().is_none_or(|(k, _)| *k != f.intrinsics) {
            let e = FdedEngine::new(&model, &f.intrinsics, params.clone(), request).context("starting fDED")?;
            bar.suspend(|| eprintln!("fDED backend: {}", e.backend_name()));
            out = Some(e.new_output());
            engine = Some((f.intrinsics, e));
        }
        let (Some((_, e)), Some(o)) = (engine.as_mut(), out.as_mut()) else {
            bail!("fDED engine missing");
        };
        let frame = Frame { stamp: f.stamp, depth: &f.depth, camera_pose: &f.camera_pose, joints: Some(&f.joints) };
        if let Err(err) = e.process(&frame, o) {
            tracing::warn!("frame at {:.3} s skipped: {err}", f.stamp);
            return Ok(true);
        }
        frames += 1;
        times.push(o.times.total_us);
        for l in &o.links {
            if model.link_mesh(l.link).is_none() {
                continue;
            }
            let v = |x: f64| if l.valid { format!("{x:.6}") } else { "nan".into() };
            csv.write_record([
                format!("{:.6}", f.stamp),
                model.link_names()[l.link].clone(),
                if l.valid { format!("{:.6}", l.distance) } else { "inf".into() },
                v(l.robot_point.x),
                v(l.robot_point.y),
                v(l.robot_point.z),
                v(l.obstacle_point.x),
                v(l.obstacle_point.y),
                v(l.obstacle_point.z),
                v(l.normal.x),
                v(l.normal.y),
                v(l.normal.z),
                format!("{:.1}", o.times.total_us),
            ])?;
        }
        Ok(true)
    })?;
    bar.finish_and_clear();
    skipped.report();
    if frames == 0 {
        bail!("{}: no usable depth frame on {} (need camera info, joint state and a camera pose)", a.bag.display(), a.depth_topic);
    }
    super::output::commit_csv(csv).with_context(|| format!("writing {}", a.out.display()))?;
    let t = TimeStats::of(&mut times);
    eprintln!(
        "{frames} frames → {}; time per frame median {:.3} ms, p90 {:.3} ms",
        a.out.display(),
        t.median_us / 1e3,
        t.p90_us / 1e3
    );
    Ok(())
}

fn bag_scene(path: &Path, model: &RobotModel, scene: Option<&Path>, max: usize) -> Result<BenchScene> {
    let src = BagSource {
        depth_topic: "/camera/depth/image_raw",
        info_topic: "/camera/depth/camera_info",
        joints_topic: "/joint_states",
        scene_pose: scene_pose(scene)?,
    };
    let mut frames: Vec<BagFrame> = Vec::new();
    let skipped = for_each_frame(path, model, &src, |f| {
        frames.push(f);
        Ok(frames.len() < max)
    })?;
    skipped.report();
    let Some(first) = frames.first() else {
        bail!("{}: no usable depth frame", path.display());
    };
    let (k, pose) = (first.intrinsics, first.camera_pose);
    if frames.iter().any(|f| f.intrinsics != k) {
        bail!("{}: the camera intrinsics change within the bag", path.display());
    }
    Ok(BenchScene {
        description: format!("{} ({} frames)", path.display(), frames.len()),
        intrinsics: k,
        camera_pose: pose,
        joints: frames.iter().map(|f| f.joints).collect(),
        stamps: frames.iter().map(|f| f.stamp).collect(),
        frames: frames.into_iter().map(|f| f.depth).collect(),
    })
}

/// `cowork bench fded`.
pub fn bench(a: BenchFdedArgs) -> Result<()> {
    let model = RobotModel::from_urdf_file(cowork_ros::config::resolve(&a.urdf)).with_context(|| format!("loading {}", a.urdf.display()))?;
    let scene = match &a.bag {
        Some(p) => bag_scene(p, &model, a.scene.as_deref(), a.frames.max(1))?,
        None => bench::static_scene(&model, a.frames.max(1), a.seed).context("rendering the static scene")?,
    };
    let opts = bench::TablesOptions {
        reps: a.reps,
        threads: a.threads,
        budget: cowork_ros::duration_s(a.budget.max(0.1)),
        quick: a.quick,
    };
    let mut stdout = std::io::stdout().lock();
    bench::print_tables(&model, &scene, &opts, &mut stdout).context("fDED benchmark")?;
    Ok(())
}
