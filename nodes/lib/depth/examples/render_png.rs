//! Renders one depth frame of a scene (robot at the scene's start joints, objects, optionally a
//! person beside the table) and writes it as a colour-mapped PNG.
//!
//! ```text
//! cargo run --example render_png -p cowork_depth -- --scene config/scenes/stacking.yaml \
//!     --person --noise --out out/depth_stacking.png
//! ```

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Parser;
use cowork_depth::{Capsule, DepthImage, DepthRenderer, KinectNoise, Label};
use cowork_robot::{JointVector, RobotModel};
use cowork_sim::Scene;
use nalgebra::{Point3, Vector3};

#[derive(Debug, Parser)]
struct Args {
    /// Robot description.
    #[arg(long, default_value = "config/robot/lwr4plus.urdf")]
    urdf: PathBuf,
    /// Scene file (camera, table, objects, start joints).
    #[arg(long, default_value = "config/scenes/stacking.yaml")]
    scene: PathBuf,
    /// Output PNG.
    #[arg(long, default_value = "out/depth_stacking.png")]
    out: PathBuf,
    /// Also write a PNG of the per-pixel labels next to it (`<out>.labels.png`).
    #[arg(long)]
    labels: bool,
    /// Add Kinect-like noise.
    #[arg(long)]
    noise: bool,
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Put a person (capsules) beside the table, reaching toward the robot.
    #[arg(long)]
    person: bool,
    /// Joint positions, deg (7 values, comma separated); the scene's start joints by default.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    q_deg: Option<Vec<f64>>,
}

/// A person standing at `feet` (base frame, m), facing −y (toward the robot), right hand
/// reaching to `target`.
fn person(feet: Point3<f64>, target: Point3<f64>) -> Vec<Capsule> {
    let up = Vector3::z();
    let pelvis = feet + up * 0.95;
    let sternum = feet + up * 1.35;
    let head = feet + up * 1.65;
    let side = Vector3::x() * 0.2;
    let (ls, rs) = (sternum + side + up * 0.08, sternum - side + up * 0.08);
    let relbow = rs + (target - rs).normalize() * 0.3 - up * 0.05;
    let rwrist = relbow + (target - relbow).normalize() * 0.27;
    let lelbow = ls - up * 0.3;
    let lwrist = lelbow - up * 0.26 + Vector3::y() * -0.05;
    let hip = Vector3::x() * 0.1;
    vec![
        Capsule::new(pelvis, sternum, 0.16),
        Capsule::new(head, head, 0.11),
        Capsule::new(ls, rs, 0.07),
        Capsule::new(rs, relbow, 0.05),
        Capsule::new(relbow, rwrist, 0.04),
        Capsule::new(rwrist, rwrist + (target - rwrist).normalize() * 0.08, 0.045),
        Capsule::new(ls, lelbow, 0.05),
        Capsule::new(lelbow, lwrist, 0.04),
        Capsule::new(pelvis + hip, feet + hip, 0.07),
        Capsule::new(pelvis - hip, feet - hip, 0.07),
    ]
}

fn main() -> Result<()> {
    let args = Args::parse();
    let model = RobotModel::from_urdf_file(&args.urdf).with_context(|| format!("loading {}", args.urdf.display()))?;
    let scene = Scene::from_file(&args.scene).with_context(|| format!("loading {}", args.scene.display()))?;
    // Every arm of the scene at its initial joints; `--q-deg` sets the first arm's.
    let mut arms = Vec::new();
    for (i, arm) in scene.arm_setups().into_iter().enumerate() {
        let q_deg = if i == 0 { args.q_deg.clone().unwrap_or(arm.initial_joints_deg) } else { arm.initial_joints_deg };
        anyhow::ensure!(q_deg.len() == 7, "need 7 joint positions, got {}", q_deg.len());
        arms.push((arm.base.isometry(), JointVector::from_iterator(q_deg.iter().map(|d| d.to_radians()))));
    }
    let mut renderer = DepthRenderer::new(&model, &scene)?;
    if args.noise {
        renderer.set_noise(Some(KinectNoise::with_seed(args.seed)))?;
    }
    let objects: Vec<_> = scene.objects.iter().map(|o| (o.shape, o.pose.isometry())).collect();
    // The floor is 0.75 m below the table top (z = 0 in the scenes).
    let people = if args.person { person(Point3::new(0.6, 0.95, -0.75), Point3::new(0.55, 0.35, 0.3)) } else { Vec::new() };
    let mut depth = DepthImage::default();
    let t = Instant::now();
    renderer.render_arms(&arms, &objects, &people, &mut depth)?;
    let elapsed = t.elapsed();
    if let Some(dir) = args.out.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    depth.write_png(&args.out)?;
    let (tris, prims) = renderer.last_frame_counts();
    let (near, far) = depth.depth_range().unwrap_or((0.0, 0.0));
    println!(
        "{}: {}x{} px, {} px with a return, depth {near:.3}..{far:.3} m, {tris} triangles + {prims} ray-cast shapes, first frame {:.1} ms",
        args.out.display(),
        depth.width,
        depth.height,
        depth.valid_count(),
        elapsed.as_secs_f64() * 1e3
    );
    if args.labels {
        // Labels as a depth-like image: one grey level per kind, so the PNG shows the parts.
        let code = |l: &Label| match *l {
            Label::None => 0.0,
            Label::Table => 1.0,
            Label::Floor => 1.5,
            Label::Object(i) => 2.0 + f32::from(i) * 0.1,
            Label::Link(i) => 3.0 + f32::from(i) * 0.1,
            Label::Person(_) => 5.0,
        };
        let img = DepthImage { width: depth.width, height: depth.height, data: renderer.labels().iter().map(code).collect() };
        let path = args.out.with_extension("labels.png");
        img.write_png_range(&path, 1.0, 5.0)?;
        println!("{}: labels (table red, objects orange, links yellow to green, people blue)", path.display());
    }
    Ok(())
}
