//! Dumps forward kinematics and Jacobians for random joint configurations as JSON, for the
//! kinpy cross-check (`tests/crosscheck/check_kinematics.sh`) or anyone's own comparison.
//!
//! ```text
//! cargo run -p cowork_robot --example fk_dump -- --urdf config/robot/lwr4plus.urdf --count 1000 --out fk.json
//! ```
//!
//! Per sample: `q` (rad, uniform within the limits, ±π for continuous joints); for every link of
//! the chain its base-frame pose (`position` m, row-major `rotation`) and, for links moved by at
//! least one joint, the 6×7 Jacobian of the link origin (rows: linear then angular velocity,
//! base frame); plus the Jacobian of one random point on one random link (`point_jacobian`).
//! Numbers are written with serde_json's shortest round-trip form, so no precision is lost.

use anyhow::Context;
use clap::Parser;
use cowork_robot::{DOF, Jacobian, JointVector, LinkPoses, RobotModel};
use nalgebra::Point3;
use rand::{Rng, SeedableRng};
use serde_json::{Value, json};
use std::path::PathBuf;

#[derive(Debug, Parser)]
struct Args {
    /// The robot description.
    #[arg(long)]
    urdf: PathBuf,
    /// Tip link of the chain (default: the deepest link).
    #[arg(long)]
    tip: Option<String>,
    /// Number of random configurations.
    #[arg(long, default_value_t = 1000)]
    count: usize,
    /// Seed of the configuration generator.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output JSON file.
    #[arg(long)]
    out: PathBuf,
}

fn rows(j: &Jacobian) -> Value {
    json!(
        (0..6)
            .map(|r| (0..DOF).map(|c| j[(r, c)]).collect::<Vec<_>>())
            .collect::<Vec<_>>()
    )
}

fn run(args: Args) -> anyhow::Result<()> {
    let model = match &args.tip {
        Some(tip) => RobotModel::from_urdf_file_with_tip(&args.urdf, tip),
        None => RobotModel::from_urdf_file(&args.urdf),
    }
    .with_context(|| format!("loading {}", args.urdf.display()))?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(args.seed);
    let mut poses = LinkPoses::new();
    let mut jac = Jacobian::zeros();
    let mut samples = Vec::with_capacity(args.count);
    for _ in 0..args.count {
        let q = JointVector::from_fn(|i, _| {
            let l = model.joint_limits()[i];
            rng.random_range(l.lower.max(-std::f64::consts::PI)..l.upper.min(std::f64::consts::PI))
        });
        model.forward_kinematics(&q, &mut poses);
        let mut links = serde_json::Map::new();
        for (l, name) in model.link_names().iter().enumerate() {
            let pose = poses.get(l);
            let r = pose.rotation.to_rotation_matrix();
            let mut entry = json!({
                "position": pose.translation.vector.as_slice(),
                "rotation": (0..3).map(|i| (0..3).map(|k| r[(i, k)]).collect::<Vec<_>>()).collect::<Vec<_>>(),
                "joints": model.joints_moving_link(l),
            });
            if model.joints_moving_link(l) > 0 {
                model.jacobian(&poses, l, &Point3::origin(), &mut jac);
                entry["jacobian"] = rows(&jac);
            }
            links.insert(name.clone(), entry);
        }
        let link = rng.random_range(1..model.link_count());
        let point = Point3::new(
            rng.random_range(-0.2..0.2),
            rng.random_range(-0.2..0.2),
            rng.random_range(-0.2..0.2),
        );
        model.jacobian(&poses, link, &point, &mut jac);
        samples.push(json!({
            "q": q.as_slice(),
            "links": links,
            "point_jacobian": {
                "link": model.link_names()[link],
                "point": point.coords.as_slice(),
                "joints": model.joints_moving_link(link),
                "jacobian": rows(&jac),
            },
        }));
    }
    let doc = json!({
        "urdf": args.urdf.display().to_string(),
        "root": model.link_names()[0],
        "tip": model.link_names()[model.tip_link()],
        "joint_names": model.joint_names().as_slice(),
        "link_names": model.link_names(),
        "samples": samples,
    });
    let file = std::fs::File::create(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    serde_json::to_writer(std::io::BufWriter::new(file), &doc)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!(
        "{} configurations of `{}` ({} links) -> {}",
        args.count,
        model.name(),
        model.link_count(),
        args.out.display()
    );
    Ok(())
}

fn main() -> anyhow::Result<()> {
    run(Args::parse())
}
