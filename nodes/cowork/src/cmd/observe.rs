//! `cowork observe` (the human observer offline on a bag), `cowork learn gestures` (gesture
//! templates from labelled bags) and `cowork bench gestures` (recognition on unseen people).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use cowork_bag::BagReader;
use cowork_msgs::msg::Skeleton;
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::String as RosString;
use cowork_observer::eval::{Evaluation, Stream, gesture_stream, kalman_track, learn, non_gesture_stream, recognise, track_rmse};
use cowork_observer::{GestureModel, KalmanConfig, Label, LearnConfig};
use cowork_people::SensorConfig;
use cowork_robot::RobotModel;
use human_observer::{ObserverNode, Params};
use indicatif::{ProgressBar, ProgressStyle};

/// `cowork learn gestures`.
#[derive(Debug, clap::Args)]
pub struct LearnGesturesArgs {
    /// Bags with `/human/skeleton` and `/human/gesture_label` (JSON `label`, `start`, `end` in
    /// bag seconds, optional `person_id`); bags without labels give negative windows only
    /// (walking, reaching, idle), which tune the rejection threshold.
    #[arg(long = "bag", required = true, num_args = 1..)]
    bags: Vec<PathBuf>,
    /// Output model (JSON).
    #[arg(short, long)]
    output: PathBuf,
    /// Skeleton topic.
    #[arg(long, default_value = "/human/skeleton")]
    skeleton_topic: String,
    /// Label topic.
    #[arg(long, default_value = "/human/gesture_label")]
    label_topic: String,
    /// Learning parameters (JSON of `cowork_observer::LearnConfig`; defaults: 50 frames at
    /// 30 Hz, templates at 0 / 0.3 / 0.6 s before each end, k = 3).
    #[arg(long)]
    config: Option<PathBuf>,
}

/// `cowork observe`.
#[derive(Debug, clap::Args)]
pub struct ObserveArgs {
    /// The bag (`/human/skeleton`, `/joint_states`, `/speech_command`).
    bag: PathBuf,
    /// Gesture model (overrides `gestures` of the parameter file; `""` for none).
    #[arg(long)]
    gestures: Option<String>,
    /// The node's parameter file (same parameters as the node).
    #[arg(long, default_value = "config/human_observer.yaml", value_parser = cowork_ros::config::path_arg)]
    params: PathBuf,
    /// Robot description (overrides `urdf`).
    #[arg(long)]
    urdf: Option<PathBuf>,
    /// Recognised gestures: `stamp_s,person_id,label,confidence,dtw_distance`.
    #[arg(short, long)]
    output: PathBuf,
    /// Every `/human/state` the node would publish: `stamp_s,present,mode,distance,
    /// closest_link,hand_x,hand_y,hand_z,hand_vx,hand_vy,hand_vz,speed_scale,stopped`.
    #[arg(long)]
    state_csv: Option<PathBuf>,
    /// Imitation teaching (thesis eq. 4.7): the demonstrator's right arm retargeted to robot
    /// joint targets per skeleton frame: `stamp_s,person_id,q1..q7,elbow_x..z,wrist_x..z,residual_m`.
    #[arg(long)]
    retarget_csv: Option<PathBuf>,
    /// Whose arm is retargeted (default: the first person seen).
    #[arg(long)]
    retarget_person: Option<u32>,
}

/// `cowork bench gestures`.
#[derive(Debug, clap::Args)]
pub struct BenchGesturesArgs {
    /// Seeds of the training gesture sets (30 Hz depth tracker, Kinect-like noise).
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    train_seeds: Vec<u64>,
    /// Seeds of the test sets (people never seen in training).
    #[arg(long, value_delimiter = ',', default_value = "101,102,103")]
    test_seeds: Vec<u64>,
    /// Gestures per set (split over come / stop / handover right).
    #[arg(long, default_value_t = 30)]
    count: usize,
    /// Seconds of non-gesture motion (walking, standing, reaching, sweeping) per test rate.
    #[arg(long, default_value_t = 600.0)]
    non_gesture_s: f64,
    /// Seconds of non-gesture motion in the training data (tunes the threshold).
    #[arg(long, default_value_t = 120.0)]
    train_non_gesture_s: f64,
    /// Use this model instead of learning one.
    #[arg(long)]
    model: Option<PathBuf>,
}

/// A progress bar of `len` steps on stderr, drawn only when stderr is a terminal (indicatif
/// hides it otherwise, so logs and pipes stay clean). Shared by the commands that take more
/// than a few seconds.
pub(crate) fn progress(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    if let Ok(style) = ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed_precise} (eta {eta})") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what.to_owned());
    bar
}

/// A spinner for work of unknown length (`what`, elapsed time, a message the caller updates),
/// ticking on its own; hidden when stderr is not a terminal, as [`progress`].
pub(crate) fn spinner(what: &str) -> ProgressBar {
    let bar = ProgressBar::new_spinner();
    if let Ok(style) = ProgressStyle::with_template("{spinner} {prefix} {elapsed_precise} {msg}") {
        bar.set_style(style);
    }
    bar.set_prefix(what.to_owned());
    bar.enable_steady_tick(std::time::Duration::from_millis(120));
    bar
}

/// Reads the skeletons and gesture labels of a bag.
pub fn read_stream(path: &Path, skeleton_topic: &str, label_topic: &str) -> Result<Stream> {
    let reader = BagReader::open(path).with_context(|| format!("opening bag {}", path.display()))?;
    let mut s = Stream::default();
    let (mut bad, mut last) = (0usize, f64::NEG_INFINITY);
    let mut first = f64::INFINITY;
    for m in reader.messages() {
        let m = m.with_context(|| format!("reading {}", path.display()))?;
        if &*m.topic == skeleton_topic {
            match m.decode::<Skeleton>() {
                Ok(k) => {
                    let t = k.header.stamp.to_secs_f64();
                    first = first.min(t);
                    last = last.max(t);
                    s.frames.push(k);
                }
                Err(e) => {
                    bad += 1;
                    if bad <= 3 {
                        tracing::warn!("{}: {skeleton_topic} at {} ns: {e}", path.display(), m.log_time_ns);
                    }
                }
            }
        } else if &*m.topic == label_topic {
            let text = m.decode::<RosString>().with_context(|| format!("{}: {label_topic} at {} ns", path.display(), m.log_time_ns))?;
            s.labels.push(Label::from_json(&text.data).with_context(|| format!("{}: {label_topic} at {} ns", path.display(), m.log_time_ns))?);
        }
    }
    if s.frames.is_empty() {
        bail!("{}: no {skeleton_topic} messages", path.display());
    }
    s.duration_s = (last - first.min(0.0)).max(0.0);
    if bad > 0 {
        tracing::warn!("{}: {bad} {skeleton_topic} messages could not be decoded", path.display());
    }
    Ok(s)
}

/// Runs `cowork learn gestures`.
pub fn learn_gestures(a: LearnGesturesArgs) -> Result<()> {
    let config: LearnConfig = match &a.config {
        Some(p) => serde_json::from_str(&std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?)
            .with_context(|| format!("{}: not a learning configuration", p.display()))?,
        None => LearnConfig::default(),
    };
    let mut streams = Vec::new();
    for b in &a.bags {
        let s = read_stream(b, &a.skeleton_topic, &a.label_topic)?;
        eprintln!("{}: {} skeletons, {} labels, {:.1} s", b.display(), s.frames.len(), s.labels.len(), s.duration_s);
        streams.push(s);
    }
    if streams.iter().all(|s| s.labels.is_empty()) {
        bail!("no {} labels in any bag: nothing to learn", a.label_topic);
    }
    let refs: Vec<&Stream> = streams.iter().collect();
    let bar = spinner("learning gesture templates");
    let model = learn(&refs, config).context("learning the gesture templates");
    bar.finish_and_clear();
    let mut model = model?;
    model.training.sources = a.bags.iter().map(|b| b.display().to_string()).collect();
    model.to_file(&a.output).with_context(|| format!("writing {}", a.output.display()))?;
    let t = &model.training;
    println!(
        "{}: {} templates of {:?}, threshold {:.3}; training: {:.1} % of the template windows recognised by the other performances, {:.2} % of {} negative windows accepted (nearest {:.3})",
        a.output.display(),
        model.templates.len(),
        t.instances,
        model.threshold,
        100.0 * t.positive_accepted,
        100.0 * t.negative_accepted,
        t.negative_windows,
        t.negative_min_distance.unwrap_or(f64::NAN)
    );
    Ok(())
}

/// Runs `cowork observe`.
pub fn observe(a: ObserveArgs) -> Result<()> {
    let place = a.params.display().to_string();
    let mut params: Params = cowork_ros::params::load(&a.params, "human_observer")?;
    if let Some(u) = &a.urdf {
        params.urdf = u.display().to_string();
    }
    if let Some(g) = &a.gestures {
        params.gestures.clone_from(g);
    }
    params.validate(&place)?;
    let model = RobotModel::from_urdf_file(cowork_ros::config::resolve(&params.urdf)).with_context(|| format!("loading {}", params.urdf))?;
    let gestures = if params.gestures.is_empty() { None } else { Some(GestureModel::from_file(&cowork_ros::config::resolve(&params.gestures))?) };
    if gestures.is_none() {
        eprintln!("no gesture model: gestures are not recognised");
    }
    let mut retarget = match &a.retarget_csv {
        Some(p) => {
            let q0 = cowork_robot::JointVector::from_row_slice(&[0.0, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0]);
            let r = cowork_observer::Retargeter::new(model.clone(), cowork_observer::RetargetConfig::default(), q0)?;
            let mut w = super::output::csv(p)?;
            let mut header = vec!["stamp_s".to_owned(), "person_id".to_owned()];
            header.extend((1..=7).map(|i| format!("q{i}")));
            header.extend(["elbow_x", "elbow_y", "elbow_z", "wrist_x", "wrist_y", "wrist_z", "residual_m"].map(String::from));
            w.write_record(&header)?;
            Some((r, w, a.retarget_person))
        }
        None => None,
    };
    let base_frame = params.observer.base_frame.clone();
    let mut node = ObserverNode::new(model, params, gestures)?;
    let reader = BagReader::open(&a.bag).with_context(|| format!("opening bag {}", a.bag.display()))?;
    let create = |p: &Path| super::output::csv(p);
    let mut gestures_csv = create(&a.output)?;
    gestures_csv.write_record(["stamp_s", "person_id", "label", "confidence", "dtw_distance"])?;
    let mut state_csv = a.state_csv.as_deref().map(create).transpose()?;
    if let Some(w) = state_csv.as_mut() {
        w.write_record([
            "stamp_s", "present", "mode", "distance", "closest_link", "hand_x", "hand_y", "hand_z", "hand_vx", "hand_vy", "hand_vz", "speed_scale", "stopped",
        ])?;
    }
    let bar = progress(reader.info().message_count, "observe");
    let (mut frames, mut gestures, mut warnings) = (0u64, 0u64, 0u64);
    // Labels in the bag (a synthesised gesture bag) score the run.
    let mut scored = Stream::default();
    let mut reports = Vec::new();
    let (mut first, mut last) = (f64::INFINITY, f64::NEG_INFINITY);
    let write_state = |node: &ObserverNode, w: &mut Option<csv::Writer<super::output::Output>>| -> Result<()> {
        if let (Some(w), Some(s)) = (w.as_mut(), node.last_state()) {
            w.write_record([
                format!("{:.6}", s.stamp),
                s.present.to_string(),
                s.mode.as_str().to_owned(),
                format!("{:.4}", s.distance),
                s.closest_link.clone(),
                format!("{:.4}", s.hand_position.x),
                format!("{:.4}", s.hand_position.y),
                format!("{:.4}", s.hand_position.z),
                format!("{:.4}", s.hand_velocity.x),
                format!("{:.4}", s.hand_velocity.y),
                format!("{:.4}", s.hand_velocity.z),
                format!("{}", s.speed_scale),
                s.stopped.to_string(),
            ])?;
        }
        Ok(())
    };
    for m in reader.messages() {
        bar.inc(1);
        let m = m.with_context(|| format!("reading {}", a.bag.display()))?;
        // The node's steady-rate tick on the bag clock, before the message is handled.
        if node.on_tick(m.log_time_ns as f64 * 1e-9).is_some() {
            write_state(&node, &mut state_csv)?;
        }
        match &*m.topic {
            n if n == cowork_msgs::topics::SKELETON.name => {
                let Ok(k) = m.decode::<Skeleton>() else {
                    warnings += 1;
                    continue;
                };
                if let Some((r, w, person)) = retarget.as_mut() {
                    let who = *person.get_or_insert(k.person_id);
                    if who == k.person_id
                        && let Ok(t) = r.retarget_message(&k, &base_frame)
                    {
                        let mut row = vec![format!("{:.6}", k.header.stamp.to_secs_f64()), k.person_id.to_string()];
                        row.extend(t.joints.iter().map(|q| format!("{q:.5}")));
                        row.extend([t.elbow_target, t.wrist_target].iter().flat_map(|p| [p.x, p.y, p.z]).map(|v| format!("{v:.4}")));
                        row.push(format!("{:.4}", t.residual_m));
                        w.write_record(&row)?;
                    }
                }
                let out = node.on_skeleton(&k);
                frames += 1;
                first = first.min(k.header.stamp.to_secs_f64());
                last = last.max(k.header.stamp.to_secs_f64());
                warnings += out.warnings.len() as u64;
                for w in out.warnings.iter().take(1) {
                    if warnings <= 5 {
                        bar.suspend(|| tracing::warn!("{}", w.message));
                    }
                }
                write_state(&node, &mut state_csv)?;
                if let Some(g) = out.gesture {
                    gestures += 1;
                    reports.push(cowork_observer::eval::Report {
                        person_id: k.person_id,
                        label: g.label.clone(),
                        stamp: g.header.stamp.to_secs_f64(),
                        distance: g.dtw_distance,
                        confidence: g.confidence,
                    });
                    gestures_csv.write_record([
                        format!("{:.6}", g.header.stamp.to_secs_f64()),
                        k.person_id.to_string(),
                        g.label.clone(),
                        format!("{:.4}", g.confidence),
                        format!("{:.4}", g.dtw_distance),
                    ])?;
                }
            }
            n if n == cowork_msgs::topics::JOINT_STATES.name => {
                if let Ok(js) = m.decode::<JointState>()
                    && node.on_joint_state(&js).is_err()
                {
                    warnings += 1;
                }
            }
            "/human/gesture_label" => {
                if let Ok(l) = m.decode::<RosString>().map_err(anyhow::Error::from).and_then(|t| Ok(Label::from_json(&t.data)?)) {
                    scored.labels.push(l);
                }
            }
            n if n == cowork_msgs::topics::SPEECH_COMMAND.name => {
                if let Ok(s) = m.decode::<RosString>() {
                    node.on_speech(&s);
                }
            }
            _ => {}
        }
    }
    bar.finish_and_clear();
    super::output::commit_csv(gestures_csv).with_context(|| format!("writing {}", a.output.display()))?;
    if let Some(w) = state_csv {
        super::output::commit_csv(w).context("writing the state CSV")?;
    }
    if let Some((_, w, _)) = retarget {
        super::output::commit_csv(w).context("writing the retargeting CSV")?;
    }
    println!("{}: {frames} skeleton frames, {} states, {gestures} gestures, {warnings} warnings", a.bag.display(), node.states());
    if !scored.labels.is_empty()
        && let Some(c) = node.observer().classifier()
    {
        scored.duration_s = (last - first).max(0.0);
        let e = Evaluation::score(&c.model().labels, &scored, &reports, 1.0, 0);
        println!("against the bag's /human/gesture_label labels:\n{}duplicates {}", e.table(), e.duplicates);
    }
    Ok(())
}

/// Runs `cowork bench gestures`.
pub fn bench(a: BenchGesturesArgs) -> Result<()> {
    let depth = SensorConfig::depth_tracker();
    let started = std::time::Instant::now();
    let model = match &a.model {
        Some(p) => GestureModel::from_file(p)?,
        None => {
            let mut streams = Vec::new();
            for s in &a.train_seeds {
                streams.push(gesture_stream(*s, a.count, &depth, false)?);
            }
            if a.train_non_gesture_s > 0.0 {
                streams.push(non_gesture_stream(a.train_seeds.first().copied().unwrap_or(1), a.train_non_gesture_s, &depth)?);
            }
            let refs: Vec<&Stream> = streams.iter().collect();
            learn(&refs, LearnConfig::default())?
        }
    };
    println!(
        "model: {} templates of {:?}, threshold {:.3} (learned in {:.1} s on seeds {:?}, 30 Hz depth tracker)\n",
        model.templates.len(),
        model.training.instances,
        model.threshold,
        started.elapsed().as_secs_f64(),
        a.train_seeds
    );
    for (name, sensor) in [("30 Hz depth tracker (Kinect-like noise, 3 % lost frames)", SensorConfig::depth_tracker()), ("120 Hz Xsens", SensorConfig::xsens())] {
        let t0 = std::time::Instant::now();
        let mut total = Evaluation::default();
        for s in &a.test_seeds {
            let test = gesture_stream(*s, a.count, &sensor, false)?;
            let (reports, evals) = recognise(&model, &test)?;
            total.add(&Evaluation::score(&model.labels, &test, &reports, 1.0, evals));
        }
        let neg = non_gesture_stream(a.test_seeds.first().copied().unwrap_or(101) + 1000, a.non_gesture_s, &sensor)?;
        let (reports, evals) = recognise(&model, &neg)?;
        let n = Evaluation::score(&model.labels, &neg, &reports, 1.0, evals);
        println!("{name}, test seeds {:?} ({} windows, {:.1} s):\n{}duplicate reports inside a performance: {}", a.test_seeds, total.evaluations, t0.elapsed().as_secs_f64(), total.table(), total.duplicates);
        println!(
            "non-gesture motion (walk in, stand, reach, sweep, walk out): {:.0} s, {} windows, {} false gestures = {:.2} per 10 min {:?}\n",
            n.duration_s,
            n.evaluations,
            n.false_reports(),
            n.false_per_10_min(),
            reports.iter().map(|r| format!("{}@{:.1}s d={:.2}", r.label, r.stamp, r.distance)).collect::<Vec<_>>()
        );
    }
    // A fourth class taught from labels only.
    let train: Vec<Stream> = a.train_seeds.iter().map(|s| gesture_stream(*s, a.count, &depth, true)).collect::<cowork_observer::Result<_>>()?;
    let refs: Vec<&Stream> = train.iter().collect();
    let model4 = learn(&refs, LearnConfig::default())?;
    let mut total = Evaluation::default();
    for s in &a.test_seeds {
        let test = gesture_stream(*s, a.count, &depth, true)?;
        let (reports, evals) = recognise(&model4, &test)?;
        total.add(&Evaluation::score(&model4.labels, &test, &reports, 1.0, evals));
    }
    println!("four classes (raise_hand taught from labels), 30 Hz, test seeds {:?}:\n{}", a.test_seeds, total.table());
    // Kalman filter of the hand against the noise-free truth.
    println!("hand Kalman filter (config/human_observer.yaml noise), RMSE against the noise-free hand, seeds {:?}:", a.test_seeds);
    println!("{:>28} | {:>10} {:>10} | {:>11} {:>11}", "source", "pos raw m", "pos KF m", "vel raw m/s", "vel KF m/s");
    for (name, sensor, r) in [("30 Hz depth tracker", SensorConfig::depth_tracker(), 0.015), ("120 Hz Xsens", SensorConfig::xsens(), 0.004)] {
        let mut rows = Vec::new();
        for s in &a.test_seeds {
            rows.extend(kalman_track(*s, &sensor, KalmanConfig { measurement_noise_m: r, ..KalmanConfig::default() })?);
        }
        let [rp, fp, rv, fv] = track_rmse(&rows, 10);
        println!("{name:>28} | {rp:>10.4} {fp:>10.4} | {rv:>11.4} {fv:>11.4}");
    }
    Ok(())
}
