//! `cowork primitives`: the robot manager's primitive database (list, show, rm) and offline
//! teaching from a kinesthetic bag (`learn`), replayed through the same library the
//! `robot_manager` node runs.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use cowork_bag::BagReader;
use cowork_manager::{
    Database, Input, Manager, ManagerConfig, ObjectReport, Output, Primitive, Stamp, WorldReport, reproduction_error,
};
use cowork_msgs::std_msgs::String as RosString;
use cowork_sim::{GripperState, Simulator};

/// Subcommands of `cowork primitives`.
#[derive(Debug, clap::Subcommand)]
pub enum PrimitivesCommand {
    /// One line per primitive: key, label, kind, object, samples, duration, source; then the
    /// HMM primitives (key, label, version, states, generated duration, last refinement).
    List(DbArgs),
    /// Everything about one primitive (`--json`: as stored).
    Show {
        #[command(flatten)]
        db: DbArgs,
        /// Primitive key (the label's functor, e.g. `noa2`).
        id: String,
        /// Print the stored JSON.
        #[arg(long)]
        json: bool,
    },
    /// Remove primitives (the file is rewritten atomically).
    Rm {
        #[command(flatten)]
        db: DbArgs,
        /// Primitive keys.
        #[arg(required = true)]
        ids: Vec<String>,
    },
    /// Teach from a kinesthetic bag offline: its /external_wrench and /speech_command replayed
    /// into a fresh simulator, segmented and learned by the robot manager library; prints the
    /// segments and each NOA's reproduction error.
    Learn(LearnArgs),
}

/// Where the database is.
#[derive(Debug, clap::Args)]
pub struct DbArgs {
    /// Database directory (default: `database_dir` of --params).
    #[arg(long)]
    dir: Option<PathBuf>,
    /// Robot name (default: `manager.robot` of --params).
    #[arg(long)]
    robot: Option<String>,
    /// robot_manager parameter file.
    #[arg(long, default_value = "config/robot_manager.yaml", value_parser = cowork_ros::config::path_arg)]
    params: PathBuf,
}

/// `cowork primitives learn`.
#[derive(Debug, clap::Args)]
pub struct LearnArgs {
    /// Kinesthetic bag (`cowork bag synth kinesthetic-pour`).
    #[arg(long)]
    bag: PathBuf,
    /// Config directory (robot, scenes, lwr_sim.yaml).
    #[arg(long, default_value = "config", value_parser = cowork_ros::config::path_arg)]
    config: PathBuf,
    /// Scene file inside `<config>/scenes`.
    #[arg(long, default_value = "kitchen.yaml")]
    scene: String,
    /// Save the learned primitives into the database (`--dir` / `--robot`); default: print only.
    #[arg(long)]
    save: bool,
    /// Write the segments and errors as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write every NOA's demonstration and our DMP rollout (object frame, 100 Hz) as
    /// `<key>.demo.csv` / `<key>.ours.csv` (`t,x,y,z,qw,qx,qy,qz`) into this directory, for the
    /// movement_primitives cross-check.
    #[arg(long)]
    export: Option<PathBuf>,
    #[command(flatten)]
    db: DbArgs,
}

/// Runs a `cowork primitives` subcommand.
pub fn run(cmd: PrimitivesCommand) -> Result<()> {
    match cmd {
        PrimitivesCommand::List(db) => list(&db),
        PrimitivesCommand::Show { db, id, json } => show(&db, &id, json),
        PrimitivesCommand::Rm { db, ids } => rm(&db, &ids),
        PrimitivesCommand::Learn(a) => learn(&a),
    }
}

fn manager_params(path: &Path) -> Result<(ManagerConfig, PathBuf)> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let doc: serde_yaml_ng::Value = serde_yaml_ng::from_str(&text).with_context(|| format!("{} is not YAML", path.display()))?;
    let block = doc.get("robot_manager").and_then(|n| n.get("ros__parameters"));
    let cfg: ManagerConfig = match block.and_then(|b| b.get("manager")) {
        Some(m) => serde_yaml_ng::from_value(m.clone())
            .with_context(|| format!("{}: robot_manager.ros__parameters.manager", path.display()))?,
        None => ManagerConfig::default(),
    };
    cfg.validate().with_context(|| format!("invalid parameters in {}", path.display()))?;
    let dir = block
        .and_then(|b| b.get("database_dir"))
        .and_then(|d| d.as_str())
        .unwrap_or("out/primitives");
    Ok((cfg, PathBuf::from(dir)))
}

fn db_path(a: &DbArgs) -> Result<(ManagerConfig, PathBuf)> {
    let (mut cfg, dir) = manager_params(&a.params)?;
    if let Some(r) = &a.robot {
        r.clone_into(&mut cfg.robot);
        cfg.validate().context("--robot")?;
    }
    let dir = a.dir.clone().unwrap_or(dir);
    let path = Database::path(&dir, &cfg.robot);
    Ok((cfg, path))
}

fn load(a: &DbArgs) -> Result<(Database, PathBuf)> {
    let (_, path) = db_path(a)?;
    if !path.exists() {
        bail!("no primitive database at {} (teach first, or pass --dir / --robot)", path.display());
    }
    Ok((Database::load(&path)?, path))
}

fn kind_name(p: &Primitive) -> String {
    match (p.kind, p.gripper) {
        (cowork_manager::ActionKind::Gripper, Some(g)) => format!("gripper {}", g.word()),
        (k, _) => k.prefix().to_uppercase(),
    }
}

fn list(a: &DbArgs) -> Result<()> {
    let (db, path) = load(a)?;
    println!(
        "{} — robot {}, {} primitives, {} HMM primitives, next label number {}",
        path.display(),
        db.robot,
        db.primitives.len(),
        db.hmm.len(),
        db.next_index
    );
    println!("{:<10} {:<16} {:<13} {:<7} {:>7} {:>8}  source", "key", "label", "kind", "object", "samples", "time_s");
    let mut all: Vec<&Primitive> = db.primitives.values().collect();
    let number = |p: &Primitive| p.id.trim_start_matches(|c: char| c.is_ascii_alphabetic()).parse::<u32>().unwrap_or(u32::MAX);
    all.sort_by(|x, y| x.source.start_s.total_cmp(&y.source.start_s).then(number(x).cmp(&number(y))));
    for p in all {
        println!(
            "{:<10} {:<16} {:<13} {:<7} {:>7} {:>8.2}  {} [{:.2}, {:.2}] s",
            p.id,
            p.label,
            kind_name(p),
            p.object,
            p.samples,
            p.source.end_s - p.source.start_s,
            if p.source.demonstration.is_empty() { "live" } else { &p.source.demonstration },
            p.source.start_s,
            p.source.end_s
        );
    }
    for (id, e) in &db.hmm {
        let refined = e.history.last().map_or("learned".to_owned(), |r| format!("refined from {}", r.demonstration));
        println!(
            "{:<10} {:<16} {:<13} {:<7} {:>7} {:>8.2}  {refined}",
            id,
            e.label,
            format!("HMM v{} {}st", e.version, e.model.states.len()),
            "-",
            "-",
            hmm_duration_s(&e.model),
        );
    }
    Ok(())
}

/// Length of the HMM's generated path (s), NaN when it cannot be generated.
fn hmm_duration_s(m: &cowork_motion::hmm::HmmPrimitive) -> f64 {
    m.generate(None, m.dt).map_or(f64::NAN, |t| t.t.last().copied().unwrap_or(0.0))
}

fn show_hmm(e: &cowork_manager::HmmEntry, json: bool) -> Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(e)?);
        return Ok(());
    }
    println!("{} ({}) — HMM, version {}", e.id, e.label, e.version);
    println!(
        "  {} states, {}-D, η = {}, generated path {:.2} s, created {} (Unix s)",
        e.model.states.len(),
        e.model.dim,
        e.model.config.forgetting,
        hmm_duration_s(&e.model),
        e.created_unix_s
    );
    for (i, st) in e.model.states.iter().enumerate() {
        println!("  state {i}: mean {:.3?} m, {:.0} samples", st.mean, e.model.durations[i]);
    }
    for r in &e.history {
        println!(
            "  v{}: {} — contact at {:.2} s, {} samples, states kept {:?}, changed {:?} (Unix s {})",
            r.version, r.demonstration, r.t_contact_s, r.samples, r.kept_states, r.changed_states, r.unix_s
        );
    }
    Ok(())
}

fn show(a: &DbArgs, id: &str, json: bool) -> Result<()> {
    let (db, path) = load(a)?;
    if let Some(e) = db.hmm(id) {
        return show_hmm(e, json);
    }
    let p = db.get(id).with_context(|| {
        let keys: Vec<&str> = db.primitives.keys().chain(db.hmm.keys()).map(String::as_str).collect();
        format!("no primitive `{id}` in {} (keys: {})", path.display(), keys.join(", "))
    })?;
    if json {
        println!("{}", serde_json::to_string_pretty(p)?);
        return Ok(());
    }
    println!("{} ({}) — {}", p.id, p.label, kind_name(p));
    println!("  object frame: {}", p.object);
    println!("  goal in the object frame: position {:?} m, quaternion xyzw {:?}", p.goal.position, p.goal.quaternion_xyzw);
    println!("  object pose when taught: position {:?} m", p.taught_object_pose.position);
    if let Some(d) = &p.dmp {
        println!(
            "  position DMP: {} basis functions, K = {} 1/s², D = {:.3} 1/s, γ = {:.4} 1/s, duration {:.3} s",
            d.basis.centers.len(),
            d.stiffness,
            d.damping,
            d.basis.gamma,
            d.duration
        );
    }
    if let Some(o) = &p.orientation_dmp {
        println!("  orientation DMP: {} basis functions, K = {}, D = {:.3}", o.basis.centers.len(), o.stiffness, o.damping);
    }
    if let Some(k) = p.linear_gain {
        println!("  linear DS gain: {k} 1/s");
    }
    println!(
        "  source: {} [{:.3}, {:.3}] s, {} samples, created {} (Unix s)",
        if p.source.demonstration.is_empty() { "live" } else { &p.source.demonstration },
        p.source.start_s,
        p.source.end_s,
        p.samples,
        p.created_unix_s
    );
    Ok(())
}

fn rm(a: &DbArgs, ids: &[String]) -> Result<()> {
    let (mut db, path) = load(a)?;
    for id in ids {
        if db.hmm.remove(id).is_none() {
            db.remove(id).with_context(|| format!("{}", path.display()))?;
        }
    }
    db.save(&path)?;
    println!("removed {} from {} ({} left)", ids.join(", "), path.display(), db.primitives.len() + db.hmm.len());
    Ok(())
}

/// The simulator's state as the manager's world report (what `lwr_sim` puts on `/lwr/world`).
pub fn world_report(sim: &Simulator) -> WorldReport {
    let tool = sim.tool_pose();
    let point = nalgebra::Point3::from(tool.translation.vector);
    WorldReport {
        t: sim.time_ns() as f64 * 1e-9,
        tool,
        gripper_closed: matches!(sim.gripper(), GripperState::Closed { .. }),
        held: sim.held_object().map(str::to_owned),
        objects: sim
            .objects()
            .iter()
            .map(|o| ObjectReport {
                name: o.name.clone(),
                pose: o.pose,
                distance: o.distance_to(&point),
                tilt: (o.pose.rotation * nalgebra::Vector3::z()).z.clamp(-1.0, 1.0).acos(),
                visible: true,
            })
            .collect(),
    }
}

fn learn(a: &LearnArgs) -> Result<()> {
    let (cfg, path) = db_path(&a.db)?;
    let mut sim = cowork_synth::load_simulator(&a.config, &a.scene)
        .with_context(|| format!("cannot build the simulator from {}", a.config.display()))?;
    let mut speech: Vec<(i64, String)> = Vec::new();
    let reader = BagReader::open(&a.bag).with_context(|| format!("cannot open {}", a.bag.display()))?;
    for m in reader.messages() {
        let m = m.with_context(|| format!("reading {}", a.bag.display()))?;
        if &*m.topic == cowork_msgs::topics::SPEECH_COMMAND.name {
            let s: RosString = m.decode().with_context(|| format!("{}: /speech_command", a.bag.display()))?;
            speech.push((i64::try_from(m.log_time_ns).unwrap_or(i64::MAX), s.data));
        }
    }
    let db = if a.save { Database::load_or_new(&path, &cfg.robot)? } else { Database::new(&cfg.robot) };
    let mut manager = Manager::new(cfg, db);
    let name = a.bag.file_name().map_or_else(|| a.bag.display().to_string(), |n| n.to_string_lossy().into_owned());
    manager.set_demonstration(&name);
    let mut out = Vec::new();
    let mut log: Vec<String> = Vec::new();
    let mut next_speech = 0;
    let step_ns = (sim.params().step_s * 1e9).round() as i64;
    let every = (0.01e9 as i64 / step_ns).max(1);
    let mut steps: i64 = 0;
    let unix_s = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let handle = |m: &mut Manager, input: Input, t: f64, out: &mut Vec<Output>, log: &mut Vec<String>| {
        out.clear();
        m.handle(&input, Stamp { t, unix_s }, out);
        for o in out.iter() {
            match o {
                Output::Warn(w) => log.push(format!("warning: {w}")),
                Output::Info(i) if i.starts_with("segment") => log.push(i.clone()),
                _ => {}
            }
        }
    };
    handle(&mut manager, Input::World(world_report(&sim)), 0.0, &mut out, &mut log);
    cowork_synth::replay_teaching(&a.bag, &mut sim, 1.0, |s| {
        steps += 1;
        let before = s.time_ns() - step_ns;
        while next_speech < speech.len() && speech[next_speech].0 <= before {
            let t = s.time_ns() as f64 * 1e-9;
            handle(&mut manager, Input::Speech(speech[next_speech].1.clone()), t, &mut out, &mut log);
            next_speech += 1;
        }
        if steps % every == 0 {
            let r = world_report(s);
            let t = r.t;
            handle(&mut manager, Input::World(r), t, &mut out, &mut log);
        }
    })
    .with_context(|| format!("replaying {}", a.bag.display()))?;
    for l in &log {
        println!("{l}");
    }
    if manager.learned().is_empty() {
        let said: Vec<&str> = speech.iter().map(|(_, w)| w.as_str()).collect();
        bail!(
            "{}: no demonstration in this bag, nothing learned: a demonstration is the arm moved between \
             `teach` and `done` on /speech_command (this bag has {} speech command(s){})",
            a.bag.display(),
            said.len(),
            if said.is_empty() { String::new() } else { format!(": {}", said.join(", ")) }
        );
    }
    println!("\n{:<3} {:<15} {:<8} {:<7} {:>7} {:>7} {:>8} {:>8} {:>8} {:>8}", "#", "label", "kind", "object", "start_s", "end_s", "rms_mm", "max_mm", "rms_deg", "max_deg");
    let mut rows = Vec::new();
    for (i, (seg, p)) in manager.learned().iter().enumerate() {
        let err = reproduction_error(p, seg, 0.001)?;
        let f = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{v:.2}"));
        println!(
            "{:<3} {:<15} {:<8} {:<7} {:>7.2} {:>7.2} {:>8} {:>8} {:>8} {:>8}",
            i + 1,
            seg.label,
            kind_name(p),
            seg.object,
            seg.t_start,
            seg.t_end,
            f(err.map(|e| e.position_rms_m * 1e3)),
            f(err.map(|e| e.position_max_m * 1e3)),
            f(err.map(|e| e.orientation_rms_rad.to_degrees())),
            f(err.map(|e| e.orientation_max_rad.to_degrees()))
        );
        rows.push(serde_json::json!({
            "label": seg.label, "kind": kind_name(p), "object": seg.object,
            "start_s": seg.t_start, "end_s": seg.t_end, "samples": seg.samples.len(),
            "reproduction": err,
        }));
    }
    if let Some(dir) = &a.export {
        export(dir, manager.learned())?;
    }
    if let Some(j) = &a.json {
        let doc = serde_json::json!({ "bag": name, "segments": rows, "log": log });
        crate::cmd::output::write(j, serde_json::to_string_pretty(&doc)? + "\n")?;
    }
    if a.save {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        }
        manager.database().save(&path)?;
        println!("\nsaved {} primitives to {}", manager.database().primitives.len(), path.display());
    }
    Ok(())
}

fn export(dir: &Path, learned: &[(cowork_manager::Segment, Primitive)]) -> Result<()> {
    use std::fmt::Write as _;
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let row = |t: f64, p: &nalgebra::Vector3<f64>, q: &nalgebra::UnitQuaternion<f64>| {
        format!("{t:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e}\n", p.x, p.y, p.z, q.w, q.i, q.j, q.k)
    };
    for (seg, p) in learned {
        let (Some(d), Some(o)) = (&p.dmp, &p.orientation_dmp) else { continue };
        let header = "t,x,y,z,qw,qx,qy,qz\n";
        let mut demo = String::from(header);
        let t0 = seg.samples.first().map_or(0.0, |s| s.0);
        for (t, pose) in &seg.samples {
            let local = seg.frame.inverse() * pose;
            demo.push_str(&row(t - t0, &local.translation.vector, &local.rotation));
        }
        let dt = 0.01;
        let tr = d.rollout(None, None, 1.0, dt, (d.duration / dt).round() as usize, 0.0)?;
        let qs = o.rollout(None, None, 1.0, dt)?;
        let mut ours = String::from(header);
        for (k, q) in qs.iter().enumerate().take(tr.len()) {
            let x = nalgebra::Vector3::new(tr.pos[3 * k], tr.pos[3 * k + 1], tr.pos[3 * k + 2]);
            ours.push_str(&row(k as f64 * dt, &x, q));
        }
        let mut meta = String::new();
        let _ = writeln!(meta, "{{\"label\": \"{}\", \"n_basis\": {}, \"stiffness\": {}, \"damping\": {}, \"duration\": {}}}", p.label, d.basis.centers.len(), d.stiffness, d.damping, d.duration);
        for (name, text) in [("demo.csv", demo), ("ours.csv", ours), ("json", meta)] {
            let f = dir.join(format!("{}.{name}", p.id));
            crate::cmd::output::write(&f, text)?;
        }
    }
    Ok(())
}
