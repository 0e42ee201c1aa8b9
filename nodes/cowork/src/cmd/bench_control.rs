//! `cowork bench control`: time and allocations of one `DsController::step` (the 1 kHz loop of
//! thesis Sec. 5.1.1) on the LWR, per case, as a table.
//!
//! Allocations are counted, on the measuring thread only, when the CLI is built with the
//! `alloc-count` feature (`cargo run --release -p cowork --features alloc-count -- bench
//! control`), which installs `cowork_testkit`'s counting global allocator; the shipped binary
//! uses the system allocator and prints `-`. The zero-allocation guarantee itself is a test
//! (`cargo test -p cowork_ds --test alloc`).

use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use cowork_ds::primitive::ConstantSpeed;
use cowork_ds::{
    ControlInput, ControlOutput, ControllerConfig, Distances, DsController, HumanInput, HumanState,
    LinkDistance, MotionCommand, Primitive,
};
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use nalgebra::{Point3, Vector3};

/// Arguments of `cowork bench control`.
#[derive(Debug, clap::Args)]
pub struct BenchControlArgs {
    /// Robot description.
    #[arg(long, default_value = "config/robot/lwr4plus.urdf", value_parser = cowork_ros::config::path_arg)]
    pub urdf: PathBuf,
    /// Measured steps per case (after 1 000 warm-up steps).
    #[arg(long, default_value_t = 10_000)]
    pub steps: usize,
}

/// Inputs of one case along a moving trajectory: `(name, inputs)`.
fn cases(model: &RobotModel, steps: usize) -> Vec<(&'static str, Vec<ControlInput>)> {
    let q0 = JointVector::from_row_slice(&[0.0, 0.52, 0.0, 1.57, 0.0, 1.05, 0.0]);
    let goal = model.link_pose(&q0, model.tip_link()).translation.vector + Vector3::new(0.0, 0.3, -0.05);
    let mut poses = LinkPoses::new();
    let tip = model.tip_link();
    let make = |k: usize, obstacles: bool, stale: bool, poses: &mut LinkPoses| {
        let t = k as f64 * 1e-3;
        // A slowly varying configuration so caches and branches see realistic data.
        let q = q0 + JointVector::from_element(0.05 * (t * 0.7).sin());
        model.forward_kinematics(&q, poses);
        let mut d = Distances::clear(if stale { t - 1.0 } else { t });
        if obstacles {
            d.count = model.link_count();
            let x = poses.get(tip).translation.vector;
            d.links[tip] = LinkDistance {
                valid: true,
                distance: 0.08,
                robot_point: Point3::from(x),
                obstacle_point: Point3::from(x + Vector3::new(0.06, 0.05, 0.0)),
                normal: Vector3::new(-0.77, -0.64, 0.0),
                obstacle_velocity: Vector3::new(0.0, -0.3, 0.0),
            };
            let e = poses.get(4).translation.vector;
            d.links[4] = LinkDistance {
                valid: true,
                distance: 0.12,
                robot_point: Point3::from(e),
                obstacle_point: Point3::from(e + Vector3::new(0.0, 0.12, 0.0)),
                normal: Vector3::new(0.0, -1.0, 0.0),
                obstacle_velocity: Vector3::zeros(),
            };
        }
        ControlInput {
            time: t,
            q,
            command: MotionCommand {
                id: 1,
                primitive: Primitive::ConstantSpeed(ConstantSpeed::new(0.3)),
                goal,
                orientation: None,
                end_effector_avoidance: true,
            },
            distances: d,
            human: HumanInput { stamp: t, state: HumanState::default() },
        }
    };
    let total = steps + 1000;
    let mut out = Vec::new();
    for (name, obstacles, stale) in [
        ("free space", false, false),
        ("obstacles at hand + link (modulation, null space)", true, false),
        ("stale distances (watchdog braking)", true, true),
    ] {
        out.push((name, (0..total).map(|k| make(k, obstacles, stale, &mut poses)).collect()));
    }
    out
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

/// Runs the cases and prints the table.
pub fn run(args: BenchControlArgs) -> Result<()> {
    if args.steps == 0 {
        bail!("--steps must be positive");
    }
    let model = RobotModel::from_urdf_file(cowork_ros::config::resolve(&args.urdf))
        .with_context(|| format!("cannot load robot description {}", args.urdf.display()))?;
    let cases = cases(&model, args.steps);
    println!("DsController::step on {} ({} steps per case after 1000 warm-up steps)", model.name(), args.steps);
    println!("{:<52} {:>10} {:>10} {:>10} {:>12} {:>8}", "case", "median_us", "p99_us", "max_us", "allocations", "faults");
    let mut times = Vec::with_capacity(args.steps);
    for (name, inputs) in &cases {
        let mut ctl = DsController::new(model.clone(), ControllerConfig::default())?;
        let mut out = ControlOutput::default();
        for input in &inputs[..1000] {
            let _ = ctl.step(input, &mut out);
        }
        times.clear();
        let mut faults = 0usize;
        let before = allocations();
        for input in &inputs[1000..] {
            let t0 = Instant::now();
            let r = ctl.step(black_box(input), &mut out);
            let dt = t0.elapsed();
            faults += usize::from(r.is_err());
            black_box(&out);
            times.push(dt.as_secs_f64() * 1e6);
        }
        let allocations = allocations().zip(before).map_or_else(|| "-".to_owned(), |(a, b)| (a - b).to_string());
        times.sort_by(f64::total_cmp);
        println!(
            "{:<52} {:>10.2} {:>10.2} {:>10.2} {:>12} {:>8}",
            name,
            percentile(&times, 0.5),
            percentile(&times, 0.99),
            times[times.len() - 1],
            allocations,
            faults
        );
    }
    println!("goal: median <= 20 us, 0 allocations (timer overhead ~0.03 us included)");
    if allocations().is_none() {
        println!("allocations: not counted in this build (--features alloc-count counts them)");
    }
    Ok(())
}

/// Allocations made so far on this thread, when the counting allocator is installed.
#[cfg(feature = "alloc-count")]
fn allocations() -> Option<u64> {
    Some(cowork_testkit::allocations() as u64)
}

/// Allocations made so far on this thread, when the counting allocator is installed.
#[cfg(not(feature = "alloc-count"))]
fn allocations() -> Option<u64> {
    None
}
