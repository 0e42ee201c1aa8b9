//! Plots skeleton sequences (side and top views) of a walk-in, a reach, a hand sweep and the
//! three gestures to a PNG.
//!
//! `cargo run -p cowork_people --example skeleton_png -- -o out/skeleton.png`

use std::path::PathBuf;

use anyhow::Context;
use clap::Parser;
use cowork_people::{
    Action, BodySize, GestureKind, GestureStyle, Performer, Room, Segment, SkeletonPose, SpanKind, Stance,
    body_capsules,
};
use nalgebra::{Point3, Vector3};
use plotters::prelude::*;

#[derive(Parser, Debug)]
struct Args {
    /// Output PNG.
    #[arg(short, long, default_value = "out/skeleton.png")]
    output: PathBuf,
    /// Seed of the performers' sway.
    #[arg(long, default_value_t = 7)]
    seed: u64,
}

/// One row of the figure: a performer, a time span, the horizontal axis of the side view.
struct Row {
    title: String,
    performer: Performer,
    start: f64,
    end: f64,
    frames: usize,
    side_axis: Vector3<f64>,
}

const BONES: [(Segment, Segment); 10] = [
    (Segment::Pelvis, Segment::Sternum),
    (Segment::Sternum, Segment::Head),
    (Segment::Sternum, Segment::RightShoulder),
    (Segment::RightShoulder, Segment::RightElbow),
    (Segment::RightElbow, Segment::RightWrist),
    (Segment::RightWrist, Segment::RightHand),
    (Segment::Sternum, Segment::LeftShoulder),
    (Segment::LeftShoulder, Segment::LeftElbow),
    (Segment::LeftElbow, Segment::LeftWrist),
    (Segment::LeftWrist, Segment::LeftHand),
];

fn bone_colour(a: Segment, b: Segment) -> RGBColor {
    let right = [Segment::RightShoulder, Segment::RightElbow, Segment::RightWrist, Segment::RightHand];
    let left = [Segment::LeftShoulder, Segment::LeftElbow, Segment::LeftWrist, Segment::LeftHand];
    if right.contains(&b) && a != Segment::Sternum {
        RGBColor(200, 30, 30)
    } else if left.contains(&b) && a != Segment::Sternum {
        RGBColor(30, 140, 30)
    } else {
        RGBColor(30, 30, 30)
    }
}

fn span_of(p: &Performer, kind: SpanKind, nth: usize) -> anyhow::Result<(f64, f64)> {
    let s = p.spans().into_iter().filter(|s| s.kind == kind).nth(nth).context("span missing")?;
    Ok((s.start, s.end))
}

fn rows(seed: u64) -> anyhow::Result<Vec<Row>> {
    let room = Room::default();
    let reach = Point3::new(0.35, -0.45, 0.35);
    let sweep = (Point3::new(0.1, -0.55, 0.2), Point3::new(0.75, -0.55, 0.2));
    let visit = room.visit(1, BodySize::TALL, seed, reach, sweep)?;
    let walk = span_of(&visit, SpanKind::Walk, 0)?;
    let walk_dir = Vector3::new(room.standing_spot.x - room.entry.x, room.standing_spot.y - room.entry.y, 0.0).normalize();
    let facing = visit.end_stance();
    let spot = visit.spans()[1].start;
    let yaw = visit.pose(spot).segment(Segment::Pelvis).orientation * Vector3::x();
    let face_axis = Vector3::new(yaw.x, yaw.y, 0.0).normalize();
    let _ = facing;
    let mut out = vec![
        Row { title: "walk in (tall, 1.90 m)".into(), performer: visit.clone(), start: walk.0, end: walk.1, frames: 9, side_axis: walk_dir },
    ];
    let r = span_of(&visit, SpanKind::Reach, 0)?;
    out.push(Row { title: "reach towards the robot".into(), performer: visit.clone(), start: r.0, end: r.0 + 0.5 * (r.1 - r.0), frames: 5, side_axis: face_axis });
    let s = span_of(&visit, SpanKind::Sweep, 0)?;
    out.push(Row { title: "hand sweep across the robot's path".into(), performer: visit.clone(), start: s.0 + 0.7, end: s.1 - 0.7, frames: 6, side_axis: face_axis });
    let stance = Stance::facing(room.standing_spot.x, room.standing_spot.y, &room.workspace_centre);
    for (kind, body) in [(GestureKind::Come, BodySize::MEDIUM), (GestureKind::Stop, BodySize::SMALL), (GestureKind::HandoverRight, BodySize::MEDIUM)] {
        let p = Performer::new(2, body, stance, seed)?.then(Action::Gesture { kind, style: GestureStyle::default() })?;
        let d = p.duration();
        let (start, end, frames) = match kind {
            GestureKind::Come => (0.6, d - 0.6, 8),
            _ => (0.0, 0.5 * d, 5),
        };
        out.push(Row {
            title: format!("{} ({:.2} m)", kind.label(), body.height),
            performer: p,
            start,
            end,
            frames,
            side_axis: Vector3::new(stance.yaw.cos(), stance.yaw.sin(), 0.0),
        });
    }
    Ok(out)
}

fn poses(row: &Row) -> Vec<SkeletonPose> {
    (0..row.frames)
        .map(|i| {
            let u = if row.frames > 1 { i as f64 / (row.frames - 1) as f64 } else { 0.0 };
            row.performer.pose(row.start + u * (row.end - row.start))
        })
        .collect()
}

fn shade(c: RGBColor, u: f64) -> RGBColor {
    // Early frames light, late frames full colour.
    let mix = |x: u8| (f64::from(x) + (1.0 - (0.3 + 0.7 * u)) * (235.0 - f64::from(x))) as u8;
    RGBColor(mix(c.0), mix(c.1), mix(c.2))
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if let Some(dir) = args.output.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let rows = rows(args.seed)?;
    let (w, h) = (1500u32, 330 * rows.len() as u32);
    {
        let root = BitMapBackend::new(&args.output, (w, h)).into_drawing_area();
        root.fill(&WHITE)?;
        let cells = root.split_evenly((rows.len(), 2));
        for (i, row) in rows.iter().enumerate() {
            let ps = poses(row);
            draw_side(&cells[2 * i], row, &ps)?;
            println!("row {}: {} (left: side view, right: top view)", i + 1, row.title);
            draw_top(&cells[2 * i + 1], row, &ps)?;
        }
        root.present().with_context(|| format!("writing {}", args.output.display()))?;
    }
    println!("wrote {}", args.output.display());
    Ok(())
}

fn draw_side(area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>, row: &Row, ps: &[SkeletonPose]) -> anyhow::Result<()> {
    let u = row.side_axis;
    let hs: Vec<f64> = ps.iter().flat_map(|p| p.segments.iter().map(move |s| s.position.coords.dot(&u))).collect();
    let (lo, hi) = hs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let mid = 0.5 * (lo + hi);
    let half = (0.5 * (hi - lo) + 0.35).max(0.9);
    let floor = ps[0].floor_z;
    let mut b = ChartBuilder::on(area);
    b.margin(8);
    let mut chart = b.build_cartesian_2d(mid - half..mid + half, floor - 0.05..floor + 2.05)?;
    // Grid every 0.5 m (no text: the plot has no font).
    draw_grid(&mut chart, (mid - half, mid + half), (floor - 0.05, floor + 2.05))?;
    // Floor and table top (z = 0).
    chart.draw_series(LineSeries::new([(mid - half, floor), (mid + half, floor)], BLACK.stroke_width(2)))?;
    chart.draw_series(LineSeries::new([(mid - half, 0.0), (mid + half, 0.0)], RGBColor(150, 110, 60).stroke_width(1)))?;
    let n = ps.len().max(2) - 1;
    for (k, p) in ps.iter().enumerate() {
        let t = k as f64 / n as f64;
        let pr = |q: Point3<f64>| (q.coords.dot(&u), q.z);
        for c in body_capsules(p).iter().skip(10) {
            chart.draw_series(LineSeries::new([pr(c.a), pr(c.b)], shade(RGBColor(90, 90, 200), t).stroke_width(2)))?;
        }
        for (a, b2) in BONES {
            chart.draw_series(LineSeries::new([pr(p.position(a)), pr(p.position(b2))], shade(bone_colour(a, b2), t).stroke_width(2)))?;
        }
        chart.draw_series([Circle::new(pr(p.position(Segment::Head)), 6, shade(BLACK, t).stroke_width(1))])?;
    }
    Ok(())
}

fn draw_top(area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>, row: &Row, ps: &[SkeletonPose]) -> anyhow::Result<()> {
    let mut b = ChartBuilder::on(area);
    b.margin(8);
    let mut chart = b.build_cartesian_2d(-1.6..2.3, -3.7..1.0)?;
    draw_grid(&mut chart, (-1.6, 2.3), (-3.7, 1.0))?;
    // Table outline, robot base, camera.
    let table = [(-0.25, -0.9), (1.15, -0.9), (1.15, 0.9), (-0.25, 0.9), (-0.25, -0.9)];
    chart.draw_series(LineSeries::new(table, RGBColor(150, 110, 60).stroke_width(2)))?;
    chart.draw_series([Circle::new((0.0, 0.0), 5, BLACK.filled())])?;
    chart.draw_series([TriangleMarker::new((1.9, 0.0), 8, BLUE.filled())])?;
    // Right-hand path over the whole span, sampled densely.
    let path: Vec<(f64, f64)> = (0..=200)
        .map(|i| {
            let p = row.performer.pose(row.start + (row.end - row.start) * f64::from(i) / 200.0);
            let h = p.position(Segment::RightHand);
            (h.x, h.y)
        })
        .collect();
    chart.draw_series(LineSeries::new(path, RGBColor(240, 150, 150).stroke_width(1)))?;
    let n = ps.len().max(2) - 1;
    for (k, p) in ps.iter().enumerate() {
        let t = k as f64 / n as f64;
        let pr = |q: Point3<f64>| (q.x, q.y);
        for f in &p.feet {
            chart.draw_series(LineSeries::new([pr(f.ankle), pr(f.ankle + 0.15 * f.heading)], shade(RGBColor(90, 90, 200), t).stroke_width(2)))?;
        }
        for (a, b2) in BONES {
            chart.draw_series(LineSeries::new([pr(p.position(a)), pr(p.position(b2))], shade(bone_colour(a, b2), t).stroke_width(2)))?;
        }
        chart.draw_series([Circle::new(pr(p.position(Segment::Head)), 5, shade(BLACK, t).stroke_width(1))])?;
    }
    Ok(())
}

type Chart<'a> = ChartContext<'a, BitMapBackend<'a>, Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>>;

/// Light grey lines every 0.5 m.
fn draw_grid(chart: &mut Chart<'_>, x: (f64, f64), y: (f64, f64)) -> anyhow::Result<()> {
    let grey = RGBColor(225, 225, 225);
    let mut v = (x.0 / 0.5).ceil() * 0.5;
    while v <= x.1 {
        chart.draw_series(LineSeries::new([(v, y.0), (v, y.1)], grey))?;
        v += 0.5;
    }
    let mut v = (y.0 / 0.5).ceil() * 0.5;
    while v <= y.1 {
        chart.draw_series(LineSeries::new([(x.0, v), (x.1, v)], grey))?;
        v += 0.5;
    }
    Ok(())
}
