//! Benchmark support (thesis Tables 5.1 and 5.2, Sec. 5.1.3 comparison): synthetic scenes
//! rendered with `cowork_depth`, timing statistics and error against the brute force.
//! Benchmark-only: allocates freely.

use std::time::Instant;

use crate::baseline::{Flacco, FlaccoParams, brute_force};
use crate::error::{Error, Result};
use crate::layout::{LinkBest, NO_LINK};
use crate::params::FdedParams;
use crate::pipeline::{Fded, FdedOutput, Frame};
use cowork_depth::{Capsule, DepthImage, DepthRenderer, Intrinsics, KinectNoise, Layers};
use cowork_robot::{JointVector, RobotModel};
use cowork_sim::Shape;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

/// Frames of one fixed scene: camera, joints and depth images (noise differs per frame).
#[derive(Debug, Clone)]
pub struct BenchScene {
    /// What it shows.
    pub description: String,
    /// Camera intrinsics.
    pub intrinsics: Intrinsics,
    /// Base ← camera optical frame.
    pub camera_pose: Isometry3<f64>,
    /// Joint positions per frame, rad.
    pub joints: Vec<[f64; 7]>,
    /// Stamp per frame, s.
    pub stamps: Vec<f64>,
    /// Depth images, m.
    pub frames: Vec<DepthImage>,
}

impl BenchScene {
    /// Frame `i` as fDED input.
    pub fn frame(&self, i: usize) -> Frame<'_> {
        Frame {
            stamp: self.stamps[i],
            depth: &self.frames[i],
            camera_pose: &self.camera_pose,
            joints: Some(&self.joints[i]),
        }
    }
}

fn scene_err(e: cowork_depth::Error) -> Error {
    Error::Scene {
        message: e.to_string(),
    }
}

/// Optical-frame pose (z forward, y down) at `eye` looking at `target`, base frame.
pub fn look_at(eye: [f64; 3], target: [f64; 3]) -> Isometry3<f64> {
    Isometry3::face_towards(&Point3::from(eye), &Point3::from(target), &-Vector3::z())
}

/// The static scene of the benchmark (thesis Fig. 5.10 in spirit): the LWR on a table in a
/// ready pose, four small boxes and a larger one on the table, and a person beside the table
/// reaching towards the arm; a Kinect (640×480, f = 525 px) 2.2–2.6 m away, Kinect-like noise
/// with a different seed per frame (the thesis averaged 100 recorded frames).
pub fn static_scene(model: &RobotModel, frames: usize, seed: u64) -> Result<BenchScene> {
    let k = Intrinsics::kinect();
    let camera_pose = look_at([2.6, 0.0, 1.1], [0.4, 0.0, 0.3]);
    let deg = std::f64::consts::PI / 180.0;
    let joints = [0.0, 30.0 * deg, 0.0, 90.0 * deg, 0.0, 60.0 * deg, 0.0];
    let at = |x: f64, y: f64, z: f64| Isometry3::from_parts(Translation3::new(x, y, z), UnitQuaternion::identity());
    let b = |s: f64| Shape::Box { size: [s, s, s] };
    let objects: Vec<(Shape, Isometry3<f64>)> = vec![
        (b(0.06), at(0.50, 0.40, 0.03)),
        (b(0.06), at(0.60, 0.40, 0.03)),
        (b(0.06), at(0.50, -0.40, 0.03)),
        (b(0.06), at(0.60, -0.40, 0.03)),
        (Shape::Box { size: [0.2, 0.15, 0.3] }, at(0.45, 0.35, 0.15)),
    ];
    let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
    let people = vec![
        Capsule::new(p(0.75, -0.75, -0.75), p(0.75, -0.75, 0.0), 0.08),
        Capsule::new(p(0.75, -0.6, -0.75), p(0.75, -0.6, 0.0), 0.08),
        Capsule::new(p(0.75, -0.68, 0.05), p(0.75, -0.68, 0.55), 0.16),
        Capsule::new(p(0.75, -0.68, 0.75), p(0.75, -0.68, 0.8), 0.1),
        Capsule::new(p(0.72, -0.5, 0.55), p(0.6, -0.4, 0.35), 0.05),
        Capsule::new(p(0.6, -0.4, 0.35), p(0.5, -0.22, 0.42), 0.04),
    ];
    let mut r = DepthRenderer::with_camera(model, k, camera_pose).map_err(scene_err)?;
    r.set_table(Some(cowork_depth::Table {
        size: [1.4, 1.8, 0.04],
        pose: at(0.45, 0.0, -0.02),
    }))
    .map_err(scene_err)?;
    let q = JointVector::from_row_slice(&joints);
    let mut out = Vec::with_capacity(frames);
    for i in 0..frames {
        r.set_noise(Some(KinectNoise::with_seed(seed.wrapping_add(i as u64)))).map_err(scene_err)?;
        let mut img = DepthImage::new(k.width, k.height);
        r.render(&q, &objects, &people, &mut img).map_err(scene_err)?;
        out.push(img);
    }
    Ok(BenchScene {
        description: "LWR on a table, 5 boxes, a person reaching in; Kinect 640x480 with noise".into(),
        intrinsics: k,
        camera_pose,
        joints: vec![joints; frames],
        stamps: (0..frames).map(|i| i as f64 / 30.0).collect(),
        frames: out,
    })
}

/// The worst case of Table 5.2: every pixel an object point, the robot behind them covering
/// about `coverage` (0..=1) of the image. A long-focus camera (f = 2000 px, 640×480) looks
/// horizontally at the upper arm from 0.35 m; for partial coverage it is shifted sideways.
/// Returns the scene and the robot's actual share of the pixels.
pub fn worst_case(model: &RobotModel, coverage: f64) -> Result<(BenchScene, f64)> {
    let k = Intrinsics {
        width: 640,
        height: 480,
        fx: 2000.0,
        fy: 2000.0,
        cx: 319.5,
        cy: 239.5,
    };
    let joints = [0.0; 7];
    let q = JointVector::zeros();
    let mut r = DepthRenderer::with_camera(model, k, Isometry3::identity()).map_err(scene_err)?;
    r.set_layers(Layers::robot_only());
    r.set_parallel(false);
    let mut img = DepthImage::new(k.width, k.height);
    let mut best = (f64::INFINITY, 0.0, 0.0);
    let mut shift = 0.0;
    while shift <= 0.4 {
        let pose = look_at([0.35, shift, 0.51], [0.0, shift, 0.51]);
        r.set_camera_pose(pose).map_err(scene_err)?;
        r.render(&q, &[] as &[(Shape, Isometry3<f64>)], &[], &mut img).map_err(scene_err)?;
        let frac = img.data.iter().filter(|d| **d > 0.0).count() as f64 / img.data.len() as f64;
        if (frac - coverage).abs() < best.0 {
            best = ((frac - coverage).abs(), shift, frac);
        }
        if frac < coverage - 0.05 {
            break;
        }
        shift += 0.002;
    }
    let camera_pose = look_at([0.35, best.1, 0.51], [0.0, best.1, 0.51]);
    // A sheet 0.15 m in front of the camera: in front of the robot (≥ 0.28 m) by more than δ.
    let img = DepthImage {
        width: k.width,
        height: k.height,
        data: vec![0.15; k.pixel_count()],
    };
    Ok((
        BenchScene {
            description: format!("worst case: all pixels objects, robot on {:.0} % of the image", best.2 * 100.0),
            intrinsics: k,
            camera_pose,
            joints: vec![joints],
            stamps: vec![0.0],
            frames: vec![img],
        },
        best.2,
    ))
}

/// Median, 90th percentile and mean of a set of times, µs.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TimeStats {
    /// Median, µs.
    pub median_us: f64,
    /// 90th percentile, µs.
    pub p90_us: f64,
    /// Mean, µs.
    pub mean_us: f64,
    /// Standard deviation, µs.
    pub std_us: f64,
}

impl TimeStats {
    /// Statistics of `samples` (sorted in place); zeros when empty.
    pub fn of(samples: &mut [f64]) -> Self {
        if samples.is_empty() {
            return Self::default();
        }
        samples.sort_by(f64::total_cmp);
        let n = samples.len();
        let q = |p: f64| samples[((p * (n - 1) as f64).round() as usize).min(n - 1)];
        let mean = samples.iter().sum::<f64>() / n as f64;
        let var = samples.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / n as f64;
        Self {
            median_us: q(0.5),
            p90_us: q(0.9),
            mean_us: mean,
            std_us: var.sqrt(),
        }
    }
}

/// One measured parameter set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// T_s, px.
    pub tile: u32,
    /// S_x = S_y, px.
    pub step: u32,
    /// Worker threads.
    pub threads: usize,
    /// Whole `process` call.
    pub total: TimeStats,
    /// Lattices + minimum + refinement only.
    pub distance: TimeStats,
    /// Mean |fDED − brute force| over frames and visible links, mm (NaN without ground truth).
    pub mean_err_mm: f64,
    /// Largest such error, mm.
    pub max_err_mm: f64,
    /// Mean robot lattice size.
    pub robot_lattice: f64,
    /// Mean object lattice size.
    pub object_lattice: f64,
    /// Frames measured (fewer than the scene's when the time budget ran out).
    pub frames: usize,
}

/// Brute-force ground truth for every frame of `scene` (per link).
pub fn ground_truth(model: &RobotModel, scene: &BenchScene, params: &FdedParams) -> Result<Vec<Vec<LinkBest>>> {
    let mut f = Fded::new(model, &scene.intrinsics, params.clone())?;
    (0..scene.frames.len())
        .map(|i| brute_force(&mut f, &scene.frame(i)))
        .collect()
}

/// Runs fDED with `params` on every frame `reps` times (after one warm-up call per frame) and
/// compares with `truth` when given. Stops early, after at least one frame, once `budget` of
/// wall-clock time is spent (slow parameter sets such as T_s = 64, S = 1).
pub fn evaluate(
    model: &RobotModel,
    scene: &BenchScene,
    params: &FdedParams,
    reps: usize,
    budget: std::time::Duration,
    truth: Option<&[Vec<LinkBest>]>,
) -> Result<Row> {
    let start = Instant::now();
    let mut f = Fded::new(model, &scene.intrinsics, params.clone())?;
    let mut out = f.new_output();
    let (mut total, mut dist) = (Vec::new(), Vec::new());
    let (mut err_sum, mut err_n, mut err_max) = (0.0, 0usize, 0.0f64);
    let (mut rl, mut ol) = (0.0, 0.0);
    let mut done = 0usize;
    for i in 0..scene.frames.len() {
        if i > 0 && start.elapsed() > budget {
            break;
        }
        done += 1;
        let frame = scene.frame(i);
        f.process(&frame, &mut out)?;
        for r in 0..reps {
            if r > 0 && start.elapsed() > budget {
                break;
            }
            f.process(&frame, &mut out)?;
            total.push(out.times.total_us);
            dist.push(out.times.distance_us());
        }
        rl += out.counts.robot_lattice as f64;
        ol += out.counts.object_lattice as f64;
        if let Some(t) = truth {
            for (l, b) in t[i].iter().enumerate() {
                if b.is_some() && out.links[l].valid {
                    let e = (out.links[l].distance - f64::from(b.dist2).sqrt()).abs() * 1000.0;
                    err_sum += e;
                    err_n += 1;
                    err_max = err_max.max(e);
                }
            }
        }
    }
    let n = done.max(1) as f64;
    Ok(Row {
        frames: done,
        tile: params.tile_size,
        step: params.step_x,
        threads: params.threads,
        total: TimeStats::of(&mut total),
        distance: TimeStats::of(&mut dist),
        mean_err_mm: if err_n > 0 { err_sum / err_n as f64 } else { f64::NAN },
        max_err_mm: if err_n > 0 { err_max } else { f64::NAN },
        robot_lattice: rl / n,
        object_lattice: ol / n,
    })
}

/// Flacco et al. on the same frames: time of the whole query (robot removal included, as for
/// fDED) and of the sphere distances alone, and the error of its global minimum against the
/// brute force's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlaccoRow {
    /// Robot removal + sphere distances.
    pub total: TimeStats,
    /// Sphere distances only.
    pub distance: TimeStats,
    /// Mean |Flacco min − brute-force min| over frames, mm.
    pub mean_min_err_mm: f64,
    /// Largest such error, mm.
    pub max_min_err_mm: f64,
    /// Frames where no sphere saw any point (every link at the default distance).
    pub default_frames: usize,
}

/// Runs Flacco's method on every frame `reps` times.
pub fn evaluate_flacco(
    model: &RobotModel,
    scene: &BenchScene,
    params: &FdedParams,
    flacco: FlaccoParams,
    reps: usize,
    truth: Option<&[Vec<LinkBest>]>,
) -> Result<FlaccoRow> {
    let mut f = Fded::new(model, &scene.intrinsics, params.clone())?;
    let mut fl = Flacco::new(model, flacco);
    let mut per_link = Vec::new();
    let (mut total, mut dist) = (Vec::new(), Vec::new());
    let (mut err_sum, mut err_n, mut err_max, mut defaults) = (0.0, 0usize, 0.0f64, 0usize);
    for i in 0..scene.frames.len() {
        let frame = scene.frame(i);
        fl.distances(&mut f, &frame, &mut per_link)?;
        for _ in 0..reps {
            let t0 = Instant::now();
            f.classify_full(&frame)?;
            let t1 = Instant::now();
            fl.distances_prepared(&f, &frame, &mut per_link);
            let t2 = Instant::now();
            total.push((t2 - t0).as_secs_f64() * 1e6);
            dist.push((t2 - t1).as_secs_f64() * 1e6);
        }
        let min = per_link.iter().flatten().fold(f64::INFINITY, |a, &b| a.min(b));
        if per_link.iter().flatten().all(|&d| d == flacco.default_distance) {
            defaults += 1;
        }
        if let Some(t) = truth {
            let bf = t[i].iter().filter(|b| b.is_some()).fold(f64::INFINITY, |a, b| a.min(f64::from(b.dist2).sqrt()));
            if bf.is_finite() && min.is_finite() {
                let e = (min - bf).abs() * 1000.0;
                err_sum += e;
                err_n += 1;
                err_max = err_max.max(e);
            }
        }
    }
    Ok(FlaccoRow {
        total: TimeStats::of(&mut total),
        distance: TimeStats::of(&mut dist),
        mean_min_err_mm: if err_n > 0 { err_sum / err_n as f64 } else { f64::NAN },
        max_min_err_mm: if err_n > 0 { err_max } else { f64::NAN },
        default_frames: defaults,
    })
}

/// Error of fDED's global minimum against the brute force's on the frames, mm (mean, max).
pub fn min_error(outputs: &[FdedOutput], truth: &[Vec<LinkBest>]) -> (f64, f64) {
    let mut v = Vec::new();
    for (o, t) in outputs.iter().zip(truth) {
        let bf = t.iter().filter(|b| b.is_some()).fold(f64::INFINITY, |a, b| a.min(f64::from(b.dist2).sqrt()));
        if let Some(m) = o.minimum()
            && bf.is_finite()
        {
            v.push((m.distance - bf).abs() * 1000.0);
        }
    }
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    (mean, v.iter().cloned().fold(0.0, f64::max))
}

/// Share of the image the robot covers in `fded`'s last virtual depth.
pub fn robot_share(fded: &Fded) -> f64 {
    let l = &fded.buffers().labels;
    l.iter().filter(|&&x| x != NO_LINK).count() as f64 / l.len().max(1) as f64
}

/// What [`print_tables`] measures.
#[derive(Debug, Clone)]
pub struct TablesOptions {
    /// Timed calls per frame and parameter set.
    pub reps: usize,
    /// Threads of the multi-thread rows.
    pub threads: usize,
    /// Wall-clock budget per parameter set.
    pub budget: std::time::Duration,
    /// Only the thesis parameter set, Flacco and the worst case (no T_s × S grid).
    pub quick: bool,
}

fn ms(t: &TimeStats) -> String {
    format!("{:>7.3} {:>7.3}", t.median_us / 1e3, t.p90_us / 1e3)
}

fn row_line(r: &Row) -> String {
    format!(
        "{:>4} {:>4} {:>3} | {} | {} | {:>7.2} {:>7.2} | {:>6.0} {:>7.0} | {:>3}",
        r.tile,
        r.step,
        r.threads,
        ms(&r.total),
        ms(&r.distance),
        r.mean_err_mm,
        r.max_err_mm,
        r.robot_lattice,
        r.object_lattice,
        r.frames
    )
}

const ROW_HEADER: &str =
    "  Ts    S thr | total ms (med    p90) | dist. ms (med   p90) | err mm (mean    max) |   |R|     |O| | frm";

fn io(e: std::io::Error) -> Error {
    Error::Output {
        message: e.to_string(),
    }
}

/// Prints Table 5.1 (T_s × S grid on `scene`: time and error against the brute force), the
/// comparison with Flacco et al. on the same frames, and Table 5.2 (worst case), single- and
/// multi-thread. Times are whole `process` calls ("total") and the lattice + minimum +
/// refinement stages ("dist.").
pub fn print_tables(
    model: &RobotModel,
    scene: &BenchScene,
    opts: &TablesOptions,
    w: &mut dyn std::io::Write,
) -> Result<()> {
    let budget = opts.budget;
    writeln!(w, "fDED benchmark — scene: {}", scene.description).map_err(io)?;
    writeln!(
        w,
        "{} frames {}x{}, {} timed calls per frame and set; CPU threads available: {}",
        scene.frames.len(),
        scene.intrinsics.width,
        scene.intrinsics.height,
        opts.reps,
        std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
    )
    .map_err(io)?;
    let base = FdedParams::default();
    let truth = ground_truth(model, scene, &base)?;
    let with = |tile: u32, step: u32, threads: usize| FdedParams {
        tile_size: tile,
        step_x: step,
        step_y: step,
        threads,
        ..base.clone()
    };
    writeln!(w, "\nTable 5.1 — static scene: time and error vs brute force (thr = threads)").map_err(io)?;
    writeln!(w, "{ROW_HEADER}").map_err(io)?;
    if !opts.quick {
        for tile in [8, 16, 32, 64] {
            for step in [1, 2, 4, 8, 16, 32] {
                let r = evaluate(model, scene, &with(tile, step, 1), opts.reps, budget, Some(&truth))?;
                writeln!(w, "{}", row_line(&r)).map_err(io)?;
                w.flush().map_err(io)?;
            }
        }
        writeln!(w, "--- thesis parameter set (T_s = 32, S = 16: 0.9 ms, 5 mm on a GTX 660):").map_err(io)?;
    }
    let fded1 = evaluate(model, scene, &with(32, 16, 1), opts.reps, budget * 4, Some(&truth))?;
    writeln!(w, "{}", row_line(&fded1)).map_err(io)?;
    let fded_n = evaluate(model, scene, &with(32, 16, opts.threads), opts.reps, budget * 4, Some(&truth))?;
    writeln!(w, "{}", row_line(&fded_n)).map_err(io)?;
    let plain = FdedParams {
        refine_obstacle: false,
        ..with(32, 16, 1)
    };
    let r = evaluate(model, scene, &plain, opts.reps, budget * 4, Some(&truth))?;
    writeln!(w, "{}   (thesis refinement only, no obstacle-side search)", row_line(&r)).map_err(io)?;

    writeln!(
        w,
        "\nComparison with Flacco et al. (10 spheres r = 0.12 m, rho = 0.4 m, depth 1.8–3.5 m, default 0.5 m), same frames, one thread:"
    )
    .map_err(io)?;
    let fl = evaluate_flacco(model, scene, &base, FlaccoParams::default(), opts.reps, Some(&truth))?;
    let mut f = Fded::new(model, &scene.intrinsics, with(32, 16, 1))?;
    let mut outputs = Vec::with_capacity(scene.frames.len());
    for i in 0..scene.frames.len() {
        let mut o = f.new_output();
        f.process(&scene.frame(i), &mut o)?;
        outputs.push(o);
    }
    let (fmin_mean, fmin_max) = min_error(&outputs, &truth);
    writeln!(w, "method           | total ms (med    p90) | dist. ms (med   p90) | global-min err mm (mean max)").map_err(io)?;
    writeln!(w, "fDED T_s=32 S=16 | {} | {} | {:>7.2} {:>7.2}", ms(&fded1.total), ms(&fded1.distance), fmin_mean, fmin_max).map_err(io)?;
    writeln!(
        w,
        "Flacco spheres   | {} | {} | {:>7.2} {:>7.2}",
        ms(&fl.total),
        ms(&fl.distance),
        fl.mean_min_err_mm,
        fl.max_min_err_mm
    )
    .map_err(io)?;
    writeln!(
        w,
        "fDED is {:.1}x faster (whole query), {:.1}x (distance stages vs sphere distances); thesis: 9.9 / 1.9 ms = 5.2x. Flacco frames with nothing in range: {}",
        fl.total.median_us / fded1.total.median_us,
        fl.distance.median_us / fded1.distance.median_us,
        fl.default_frames
    )
    .map_err(io)?;

    let calls = opts.reps.max(1) * 10;
    writeln!(w, "\nTable 5.2 — worst case: every pixel an object point in front of the robot ({calls} calls)").map_err(io)?;
    writeln!(w, " Ts  S robot%  thr | mean ms   std | median    p90").map_err(io)?;
    for (step, cover) in [(8, 1.0), (16, 1.0), (32, 1.0), (32, 0.5), (32, 0.3)] {
        let (wc, got) = worst_case(model, cover)?;
        let mut threads = vec![1];
        if opts.threads > 1 {
            threads.push(opts.threads);
        }
        for t in threads {
            let r = evaluate(model, &wc, &with(32, step, t), calls, budget * 2, None)?;
            writeln!(
                w,
                " 32 {step:>2} {:>6.0} {t:>4} | {:>7.3} {:>5.3} | {:>6.3} {:>6.3}",
                got * 100.0,
                r.total.mean_us / 1e3,
                r.total.std_us / 1e3,
                r.total.median_us / 1e3,
                r.total.p90_us / 1e3
            )
            .map_err(io)?;
            w.flush().map_err(io)?;
        }
    }
    writeln!(w, "(thesis, GTX 660: S=8 6.3 ms, S=16 3.7 ms, S=32 2.8 ms at 100 %; S=32 1.9 ms at 50 %, 1.3 ms at 30 %)").map_err(io)?;
    Ok(())
}
