//! The wgpu path against the CPU reference on rendered frames: per-link distances within 1 mm,
//! same validity, same lattice sizes, same filtered depth.
//!
//! Runs on whatever Vulkan adapter exists (Mesa's lavapipe in CI). Without one the tests print a
//! notice and pass, unless `COWORK_REQUIRE_GPU_ADAPTER=1`, which makes a missing adapter fail.

use cowork_depth::{DepthImage, Intrinsics};
use cowork_fded::gpu::{BackendRequest, FdedEngine, GpuContext, GpuFded};
use cowork_fded::{Error, Fded, FdedOutput, FdedParams, Frame};
use cowork_robot::RobotModel;
use nalgebra::{Isometry3, Point3, Vector3};
use rand::{Rng, SeedableRng};

/// The adapter, or `None` with a printed notice (a failure when the environment requires one).
fn adapter(test: &str) -> Option<GpuContext> {
    let ctx = GpuContext::open().expect("probing for a wgpu adapter");
    if ctx.is_none() {
        let required = std::env::var("COWORK_REQUIRE_GPU_ADAPTER").is_ok_and(|v| v.trim() == "1");
        assert!(!required, "COWORK_REQUIRE_GPU_ADAPTER=1 but no wgpu (Vulkan) adapter was found");
        eprintln!("NOTICE: no wgpu adapter on this machine; {test} skipped");
    }
    ctx
}

struct Scene {
    name: &'static str,
    camera: Isometry3<f64>,
    q: [f64; 7],
    depth: DepthImage,
}

/// Table, objects, the robot itself and a person-sized obstacle, with depth noise, dropped
/// pixels (0) and NaN pixels, as a sensor would give.
fn scenes(model: &RobotModel, k: &Intrinsics) -> Vec<Scene> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let setups: [(&str, [f64; 3], [f64; 3], [f64; 7]); 4] = [
        ("front", [1.9, 0.0, 0.9], [0.45, 0.0, 0.2], [0.0, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0]),
        ("side", [0.4, 1.8, 1.0], [0.3, 0.0, 0.4], [0.4, 0.8, -0.3, -1.0, 0.2, 0.9, 0.1]),
        ("above", [0.8, 0.3, 2.2], [0.4, 0.0, 0.3], [-0.5, 1.0, 0.2, -1.4, -0.3, 0.4, 0.0]),
        ("close", [1.2, -0.6, 0.8], [0.3, 0.0, 0.5], [0.2, 0.3, 0.1, -0.6, 0.0, 1.2, 0.5]),
    ];
    setups
        .iter()
        .map(|&(name, eye, target, q)| {
            let camera = look_at(eye, target);
            let mut depth = DepthImage::new(k.width, k.height);
            plane(&mut depth, k, &camera, Vector3::z(), 0.0);
            cuboid(&mut depth, k, &camera, &Isometry3::translation(0.6, 0.35, 0.1), Vector3::new(0.08, 0.06, 0.1));
            sphere(&mut depth, k, &camera, Point3::new(0.55, -0.25, 0.6), 0.1);
            sphere(&mut depth, k, &camera, Point3::new(0.2, 0.45, 0.9), 0.15);
            robot(&mut depth, model, k, &camera, &q);
            for d in depth.data.iter_mut() {
                let x: f64 = rng.random();
                if x < 0.01 {
                    *d = 0.0;
                } else if x < 0.02 {
                    *d = f32::NAN;
                } else if *d > 0.0 {
                    *d += (rng.random::<f32>() - 0.5) * 0.004 * *d * *d;
                }
            }
            Scene { name, camera, q, depth }
        })
        .collect()
}

#[derive(Default)]
struct Agreement {
    links: usize,
    max_dist_diff: f64,
    same_pair: usize,
    normal_max_angle_same_pair: f64,
}

fn compare(tag: &str, cpu: &FdedOutput, gpu: &FdedOutput, agg: &mut Agreement) {
    assert_eq!(cpu.links.len(), gpu.links.len());
    for (c, g) in cpu.links.iter().zip(&gpu.links) {
        assert_eq!(c.valid, g.valid, "{tag}: link {} valid on one path only (cpu {c:?}, gpu {g:?})", c.link);
        if !c.valid {
            continue;
        }
        let diff = (c.distance - g.distance).abs();
        assert!(
            diff <= 1e-3,
            "{tag}: link {}: cpu {:.5} m, gpu {:.5} m (|Δ| = {:.2} mm > 1 mm)",
            c.link,
            c.distance,
            g.distance,
            diff * 1e3
        );
        agg.links += 1;
        agg.max_dist_diff = agg.max_dist_diff.max(diff);
        let same = (c.robot_point - g.robot_point).norm() <= 1e-3 && (c.obstacle_point - g.obstacle_point).norm() <= 1e-3;
        if same {
            agg.same_pair += 1;
            let angle = c.normal.angle(&g.normal);
            agg.normal_max_angle_same_pair = agg.normal_max_angle_same_pair.max(angle);
            assert!(angle < 0.05, "{tag}: link {}: normals differ by {angle} rad at the same point", c.link);
        }
    }
    assert_eq!(cpu.closest.is_some(), gpu.closest.is_some(), "{tag}: global minimum on one path only");
    if let (Some(c), Some(g)) = (cpu.minimum(), gpu.minimum()) {
        assert!((c.distance - g.distance).abs() <= 1e-3, "{tag}: global minimum {c:?} vs {g:?}");
    }
}

#[test]
fn gpu_agrees_with_cpu_within_1mm() {
    let Some(ctx) = adapter("gpu_agrees_with_cpu_within_1mm") else { return };
    let adapter_name = ctx.adapter_name().to_owned();
    let model = model();
    let k = Intrinsics::kinect();
    let scenes = scenes(&model, &k);
    let mut variants = Vec::new();
    for (tile, step) in [(32, 16), (8, 4), (16, 1), (64, 32), (32, 8)] {
        for refine_obstacle in [true, false] {
            variants.push(FdedParams { tile_size: tile, step_x: step, step_y: step, refine_obstacle, ..FdedParams::default() });
        }
    }
    variants.push(FdedParams { table_z: None, ..FdedParams::default() });
    let mut agg = Agreement::default();
    let mut ctx = Some(ctx);
    for params in &variants {
        let mut cpu = Fded::new(&model, &k, params.clone()).expect("cpu");
        let context = match ctx.take() {
            Some(c) => c,
            None => GpuContext::open().expect("adapter").expect("adapter again"),
        };
        let mut gpu = GpuFded::new(context, &model, &k, params.clone()).expect("gpu pipeline");
        let (mut co, mut go) = (cpu.new_output(), gpu.new_output());
        for (i, s) in scenes.iter().enumerate() {
            let frame = Frame { stamp: i as f64 * 0.033, depth: &s.depth, camera_pose: &s.camera, joints: Some(&s.q) };
            cpu.process(&frame, &mut co).expect("cpu frame");
            gpu.process(&frame, &mut go).expect("gpu frame");
            let tag = format!("{} T_s={} S={} refine_obstacle={} table={:?}", s.name, params.tile_size, params.step_x, params.refine_obstacle, params.table_z);
            // The host stages are shared: the same lattices.
            assert_eq!(cpu.buffers().obj_pixel, gpu.buffers().obj_pixel, "{tag}: object lattice");
            // (The CPU lists only the winning slots' points: compare point, slot and count.)
            let slots = |f: &[[u32; 4]]| f.iter().map(|i| [i[0], i[1], i[3]]).collect::<Vec<_>>();
            assert_eq!(slots(&cpu.buffers().robot_lattice_info), slots(&gpu.buffers().robot_lattice_info), "{tag}: robot lattice");
            assert_eq!(co.counts, go.counts, "{tag}: lattice sizes");
            compare(&tag, &co, &go, &mut agg);
        }
    }
    assert!(agg.links > 100, "too few valid links compared: {}", agg.links);
    eprintln!(
        "GPU ({adapter_name}) vs CPU: {} link results, max |Δd| = {:.4} mm, same closest pair in {} ({:.1} %), max normal angle there {:.2e} rad",
        agg.links,
        agg.max_dist_diff * 1e3,
        agg.same_pair,
        100.0 * agg.same_pair as f64 / agg.links as f64,
        agg.normal_max_angle_same_pair
    );
}

#[test]
fn velocities_follow_a_moving_obstacle_on_both_paths() {
    let Some(ctx) = adapter("velocities_follow_a_moving_obstacle_on_both_paths") else { return };
    let model = model();
    let k = Intrinsics::kinect();
    let camera = look_at([1.9, 0.0, 0.9], [0.45, 0.0, 0.2]);
    let q = [0.0, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0];
    let params = FdedParams::default();
    let mut cpu = Fded::new(&model, &k, params.clone()).expect("cpu");
    let mut gpu = GpuFded::new(ctx, &model, &k, params).expect("gpu");
    let (mut co, mut go) = (cpu.new_output(), gpu.new_output());
    for i in 0..4 {
        let t = i as f64 * 0.1;
        let mut depth = DepthImage::new(k.width, k.height);
        plane(&mut depth, &k, &camera, Vector3::z(), 0.0);
        // The sphere, beside the arm (not in front: the gray area would pin the obstacle point to
        // the robot), is the only obstacle; the table is removed as table.
        sphere(&mut depth, &k, &camera, Point3::new(0.4, 0.45 + 0.2 * t, 0.6), 0.1);
        let frame = Frame { stamp: t, depth: &depth, camera_pose: &camera, joints: Some(&q) };
        cpu.process(&frame, &mut co).expect("cpu");
        gpu.process(&frame, &mut go).expect("gpu");
        compare(&format!("moving sphere frame {i}"), &co, &go, &mut Agreement::default());
    }
    let (c, g) = (co.minimum().expect("cpu sees the sphere"), go.minimum().expect("gpu sees the sphere"));
    assert!((c.obstacle_velocity - g.obstacle_velocity).norm() < 0.02, "cpu {:?} gpu {:?}", c.obstacle_velocity, g.obstacle_velocity);
    assert!(g.obstacle_velocity.y > 0.05, "the sphere moves along +y: {:?}", g.obstacle_velocity);
}

#[test]
fn gpu_rejects_bad_frames_like_the_cpu() {
    let Some(ctx) = adapter("gpu_rejects_bad_frames_like_the_cpu") else { return };
    let model = model();
    let k = Intrinsics::kinect();
    let mut gpu = GpuFded::new(ctx, &model, &k, FdedParams::default()).expect("gpu");
    let mut out = gpu.new_output();
    let camera = look_at([1.9, 0.0, 0.9], [0.45, 0.0, 0.2]);
    let q = [0.0; 7];
    let small = DepthImage::new(320, 240);
    let err = gpu.process(&Frame { stamp: 0.0, depth: &small, camera_pose: &camera, joints: Some(&q) }, &mut out);
    assert!(matches!(err, Err(cowork_fded::gpu::GpuError::Fded(Error::SizeMismatch { .. }))), "{err:?}");
    let depth = DepthImage::new(k.width, k.height);
    let err = gpu.process(&Frame { stamp: 0.0, depth: &depth, camera_pose: &camera, joints: None }, &mut out);
    assert!(matches!(err, Err(cowork_fded::gpu::GpuError::Fded(Error::MissingJointState { .. }))), "{err:?}");
    // All-NaN depth: nothing is an obstacle, and the frame still goes through.
    let nan = DepthImage { data: vec![f32::NAN; depth.data.len()], ..depth };
    gpu.process(&Frame { stamp: 0.0, depth: &nan, camera_pose: &camera, joints: Some(&q) }, &mut out)
        .expect("a NaN image is a valid frame with no obstacle");
    assert!(out.links.iter().all(|l| !l.valid));
    assert_eq!(out.counts.object_lattice, 0);
}

#[test]
fn engine_auto_takes_the_adapter() {
    let Some(_ctx) = adapter("engine_auto_takes_the_adapter") else { return };
    if std::env::var_os(cowork_fded::gpu::BACKEND_ENV).is_some() {
        eprintln!("NOTICE: {} is set; engine choice test skipped", cowork_fded::gpu::BACKEND_ENV);
        return;
    }
    let model = model();
    let k = Intrinsics::kinect();
    let auto = FdedEngine::new(&model, &k, FdedParams::default(), BackendRequest::Auto).expect("engine");
    assert_eq!(auto.backend_name(), "wgpu");
    let cpu = FdedEngine::new(&model, &k, FdedParams::default(), BackendRequest::Cpu).expect("engine");
    assert_eq!(cpu.backend_name(), "cpu");
    let bad = FdedEngine::new(&model, &k, FdedParams { step_x: 0, ..FdedParams::default() }, BackendRequest::Auto);
    assert!(matches!(bad, Err(cowork_fded::gpu::GpuError::Fded(Error::BadParameter { .. }))), "{bad:?}");
}

// ---- Scene helpers: analytic shapes ray-cast per pixel, independent of the rasteriser. ----

fn model() -> RobotModel {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../config/robot/lwr4plus.urdf");
    RobotModel::from_urdf_file(path).expect("bundled URDF loads")
}

/// Optical-frame pose (z forward, y down) at `eye` looking at `target`, base frame.
fn look_at(eye: [f64; 3], target: [f64; 3]) -> Isometry3<f64> {
    Isometry3::face_towards(&Point3::from(eye), &Point3::from(target), &-Vector3::z())
}

/// Ray of pixel (u, v) with unit z (its parameter is the z-depth), camera frame.
fn ray(k: &Intrinsics, u: u32, v: u32) -> Vector3<f64> {
    Vector3::new((u as f64 - k.cx) / k.fx, (v as f64 - k.cy) / k.fy, 1.0)
}

/// Keeps the nearer of the current depth and `z` (0 = empty).
fn put(img: &mut DepthImage, i: usize, z: f64) {
    let cur = img.data[i];
    if z > 0.0 && (cur <= 0.0 || (z as f32) < cur) {
        img.data[i] = z as f32;
    }
}

/// Each pixel's ray parameter from `hit` (camera-frame ray → z-depth, if any).
fn cast(img: &mut DepthImage, k: &Intrinsics, hit: impl Fn(Vector3<f64>) -> Option<f64>) {
    for v in 0..k.height {
        for u in 0..k.width {
            if let Some(t) = hit(ray(k, u, v)) {
                put(img, (v * k.width + u) as usize, t);
            }
        }
    }
}

fn sphere(img: &mut DepthImage, k: &Intrinsics, cam: &Isometry3<f64>, centre: Point3<f64>, r: f64) {
    let c = (cam.inverse() * centre).coords;
    cast(img, k, |d| {
        let (a, b, cc) = (d.norm_squared(), -2.0 * d.dot(&c), c.norm_squared() - r * r);
        let disc = b * b - 4.0 * a * cc;
        (disc >= 0.0).then(|| (-b - disc.sqrt()) / (2.0 * a))
    });
}

fn cuboid(img: &mut DepthImage, k: &Intrinsics, cam: &Isometry3<f64>, pose: &Isometry3<f64>, half: Vector3<f64>) {
    let box_from_cam = pose.inverse() * cam;
    let o = box_from_cam.translation.vector;
    cast(img, k, |d| {
        let d = box_from_cam.rotation * d;
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for a in 0..3 {
            if d[a].abs() < 1e-12 {
                if o[a].abs() > half[a] {
                    return None;
                }
                continue;
            }
            let (ta, tb) = ((-half[a] - o[a]) / d[a], (half[a] - o[a]) / d[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        (t0 <= t1 && t0 > 0.0).then_some(t0)
    });
}

/// The plane `n · x = offset` (base frame) where it lies in front of the camera.
fn plane(img: &mut DepthImage, k: &Intrinsics, cam: &Isometry3<f64>, n: Vector3<f64>, offset: f64) {
    let nc = cam.rotation.inverse() * n;
    let oc = offset - n.dot(&cam.translation.vector);
    cast(img, k, |d| {
        let den = nc.dot(&d);
        (den.abs() > 1e-12).then(|| oc / den)
    });
}

/// The robot as the CPU pipeline renders it at `q`, copied in as a sensor would see it.
fn robot(img: &mut DepthImage, model: &RobotModel, k: &Intrinsics, cam: &Isometry3<f64>, q: &[f64]) {
    let mut f = Fded::new(model, k, FdedParams::default()).expect("fded");
    let empty = DepthImage::new(k.width, k.height);
    f.prepare(&Frame { stamp: 0.0, depth: &empty, camera_pose: cam, joints: Some(q) }).expect("prepare");
    for (i, &z) in f.buffers().virtual_depth.iter().enumerate() {
        put(img, i, f64::from(z));
    }
}
