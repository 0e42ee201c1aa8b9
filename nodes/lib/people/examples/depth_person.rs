//! Renders the `stacking` scene with a synthetic person (capsule body) at four moments of a
//! visit — walking in, standing, reaching towards the robot, sweeping a hand — as a 2 × 2 mosaic
//! of depth images.
//!
//! `cargo run -p cowork_people --example depth_person -- -o out/depth_person.png`

use std::path::PathBuf;

use anyhow::Context;
use clap::Parser;
use cowork_depth::{DepthImage, DepthRenderer};
use cowork_people::{BodySize, Room, SpanKind, body_capsules};
use cowork_robot::{JointVector, RobotModel};
use cowork_sim::Scene;
use nalgebra::Point3;

#[derive(Parser, Debug)]
struct Args {
    /// Output PNG.
    #[arg(short, long, default_value = "out/depth_person.png")]
    output: PathBuf,
    /// Robot description.
    #[arg(long, default_value = "config/robot/lwr4plus.urdf")]
    urdf: PathBuf,
    /// Scene.
    #[arg(long, default_value = "config/scenes/stacking.yaml")]
    scene: PathBuf,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let model = RobotModel::from_urdf_file(&args.urdf).with_context(|| format!("loading {}", args.urdf.display()))?;
    let scene = Scene::from_file(&args.scene).with_context(|| format!("loading {}", args.scene.display()))?;
    let q = JointVector::from_iterator(scene.initial_joints_deg().iter().map(|d| d.to_radians()));
    let objects: Vec<_> = scene.objects.iter().map(|o| (o.shape, o.pose.isometry())).collect();
    let mut renderer = DepthRenderer::new(&model, &scene)?;
    let room = Room::default();
    let person = room.visit(
        1,
        BodySize::MEDIUM,
        7,
        Point3::new(0.35, -0.45, 0.35),
        (Point3::new(0.1, -0.55, 0.2), Point3::new(0.75, -0.55, 0.2)),
    )?;
    let spans = person.spans();
    let at = |k: SpanKind, u: f64| spans.iter().find(|s| s.kind == k).map(|s| s.start + u * (s.end - s.start));
    let times = [
        at(SpanKind::Walk, 0.85).context("walk")?,
        at(SpanKind::Stand, 0.5).context("stand")?,
        at(SpanKind::Reach, 0.5).context("reach")?,
        at(SpanKind::Sweep, 0.6).context("sweep")?,
    ];
    let mut mosaic: Option<DepthImage> = None;
    for (k, t) in times.iter().enumerate() {
        let caps = body_capsules(&person.pose(*t));
        let mut depth = DepthImage::default();
        renderer.render(&q, &objects, &caps, &mut depth)?;
        let (w, h) = (depth.width as usize, depth.height as usize);
        let m = mosaic.get_or_insert_with(|| DepthImage { width: 2 * depth.width, height: 2 * depth.height, data: vec![0.0; 4 * w * h] });
        let (ox, oy) = ((k % 2) * w, (k / 2) * h);
        for row in 0..h {
            let dst = (oy + row) * 2 * w + ox;
            m.data[dst..dst + w].copy_from_slice(&depth.data[row * w..(row + 1) * w]);
        }
        println!("t = {t:.2} s: {} px with a return", depth.valid_count());
    }
    if let Some(dir) = args.output.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let m = mosaic.context("no frame")?;
    m.write_png_range(&args.output, 1.0, 3.5)?;
    println!("wrote {}", args.output.display());
    Ok(())
}
