//! Robot removal against a naive reference: every front-facing link triangle, every pixel of
//! its grown box, the point test written out here — no chunks, culling, depth blocks or
//! spans. The full-resolution classification and the lattice samples must agree with it, and
//! the normals (whose windows classify only the pixels in the fit's ball, together when they
//! overlap) must equal a plain fit over the fully classified image.

mod common;

use common::{look_at, model, plane, robot, sphere};
use cowork_depth::{DepthImage, Intrinsics};
use cowork_fded::{Fded, FdedParams, Frame};
use nalgebra::{Isometry3, Point3, Vector3};

/// The pose fDED is told; the depth shows the robot at `SHOWN` (a few pixels away at the
/// silhouettes), so the margin matters.
const TOLD: [f64; 7] = [0.0, 0.5, 0.0, 1.2, 0.0, 0.8, 0.0];
const SHOWN: [f64; 7] = [0.02, 0.52, 0.0, 1.18, 0.03, 0.8, 0.0];

fn edge(a: [f32; 2], b: [f32; 2], p: [f32; 2]) -> f32 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Per pixel: 1 when some front-facing triangle, grown by `margin` px, covers it and its
/// candidate depth is within `delta` of the triangle's depth there (clamped barycentrics).
fn reference(f: &Fded, depth: &DepthImage, delta: f32, margin: f32) -> Vec<u8> {
    let b = f.buffers();
    let k = f.classification();
    let (w, h) = (b.width as usize, b.height as usize);
    let mut flags = vec![0u8; w * h];
    for tri in &f.meshes().triangles {
        let [a, bb, c] = tri.map(|i| b.robot.cam_vertices[i as usize]);
        let [pa, pb, pc] = tri.map(|i| b.robot.vertex_uv[i as usize]);
        if pa[0].is_nan() || pb[0].is_nan() || pc[0].is_nan() {
            continue;
        }
        let n = Vector3::new(bb[0] - a[0], bb[1] - a[1], bb[2] - a[2])
            .cross(&Vector3::new(c[0] - a[0], c[1] - a[1], c[2] - a[2]));
        if n.dot(&Vector3::new(a[0], a[1], a[2])) >= 0.0 {
            continue;
        }
        let area = edge(pa, pb, pc);
        if area.abs() < 1e-12 {
            continue;
        }
        let s = area.signum();
        let len = |p: [f32; 2], q: [f32; 2]| ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)).sqrt();
        let tol = [margin * len(pb, pc), margin * len(pc, pa), margin * len(pa, pb)];
        let (zlo, zhi) = (a[2].min(bb[2]).min(c[2]) - delta, a[2].max(bb[2]).max(c[2]) + delta);
        let lo = |x: f32| (x - margin).ceil().max(0.0) as usize;
        let u1 = ((pa[0].max(pb[0]).max(pc[0]) + margin).floor().max(-1.0) as i64).min(w as i64 - 1);
        let v1 = ((pa[1].max(pb[1]).max(pc[1]) + margin).floor().max(-1.0) as i64).min(h as i64 - 1);
        for v in lo(pa[1].min(pb[1]).min(pc[1]))..=v1.max(-1) as usize {
            if v1 < 0 {
                break;
            }
            for u in lo(pa[0].min(pb[0]).min(pc[0]))..=u1.max(-1) as usize {
                if u1 < 0 {
                    break;
                }
                let i = v * w + u;
                let d = depth.data[i];
                if !(k.candidate(d, b.ray_x[u], b.ray_y[v]) && d >= zlo && d <= zhi) {
                    continue;
                }
                let p = [u as f32, v as f32];
                let e = [s * edge(pb, pc, p), s * edge(pc, pa, p), s * edge(pa, pb, p)];
                if e[0] < -tol[0] || e[1] < -tol[1] || e[2] < -tol[2] {
                    continue;
                }
                let wts = e.map(|x| x.max(0.0));
                let sum = wts[0] + wts[1] + wts[2];
                let z = if sum > 0.0 {
                    sum / (wts[0] / a[2] + wts[1] / bb[2] + wts[2] / c[2])
                } else {
                    3.0 / (1.0 / a[2] + 1.0 / bb[2] + 1.0 / c[2])
                };
                if (d - z).abs() <= delta {
                    flags[i] = 1;
                }
            }
        }
    }
    flags
}

fn scene(k: &Intrinsics, cam: &Isometry3<f64>) -> DepthImage {
    let m = model();
    let mut d = DepthImage::new(k.width, k.height);
    robot(&mut d, &m, k, cam, &SHOWN);
    // Obstacles touching the arm, one in front of it, the table and a wall behind.
    sphere(&mut d, k, cam, Point3::new(0.45, 0.15, 0.75), 0.1);
    sphere(&mut d, k, cam, Point3::new(0.9, 0.0, 0.6), 0.06);
    plane(&mut d, k, cam, Vector3::z(), 0.0);
    plane(&mut d, k, cam, -Vector3::x(), 0.6);
    d
}

#[test]
fn chunked_removal_equals_the_naive_reference() {
    let k = Intrinsics::kinect();
    let views = [
        look_at([2.0, 0.0, 0.8], [0.3, 0.0, 0.5]),
        // Close up: chunks near the camera cover many pixels.
        look_at([0.9, 0.5, 0.9], [0.3, 0.0, 0.6]),
    ];
    let mut compared = 0usize;
    for cam in &views {
        let depth = scene(&k, cam);
        for margin in [0.0, 3.0] {
            for step in [1u32, 4, 16] {
                let params = FdedParams { robot_margin: margin, step_x: step, step_y: step, ..FdedParams::default() };
                let (delta, margin) = (params.robot_delta as f32, margin as f32);
                let mut f = Fded::new(&model(), &k, params).unwrap();
                let mut out = f.new_output();
                let frame = Frame { stamp: 0.0, depth: &depth, camera_pose: cam, joints: Some(&TOLD) };
                f.process(&frame, &mut out).unwrap();
                let want = reference(&f, &depth, delta, margin);
                let b = f.buffers();
                let w = b.width as usize;
                let robot = want.iter().filter(|&&x| x != 0).count();
                assert!(robot > 1000, "the robot must cover pixels: {robot}");
                // Lattice samples (candidates only: the others are never obstacles).
                for j in 0..b.lattice_ny as usize {
                    for i in 0..b.lattice_nx as usize {
                        let s = j * b.lattice_nx as usize + i;
                        if b.lattice_depth[s] > 0.0 {
                            let px = j * step as usize * w + i * step as usize;
                            assert_eq!(b.lattice_robot[s], want[px], "margin {margin} S {step}: sample ({i}, {j})");
                            compared += 1;
                        }
                    }
                }
                // Every pixel.
                f.classify_full(&frame).unwrap();
                let b = f.buffers();
                for (i, (&got, &want)) in b.robot_flags.iter().zip(&want).enumerate() {
                    if b.filtered[i] > 0.0 || got != 0 {
                        assert_eq!(got, want, "margin {margin}: pixel ({}, {})", i % w, i / w);
                    }
                }
            }
        }
    }
    assert!(compared > 10_000, "too few samples compared: {compared}");
}

/// The normal fit reference: every pixel of the L-pixel window that the full-resolution
/// classification keeps, weighted `exp(−‖p − o‖² / σ²)` up to the 10⁻⁶ cut-off, fitted in f64.
fn reference_normal(f: &Fded, depth: &DepthImage, pixel: u32) -> Option<Vector3<f64>> {
    let b = f.buffers();
    let (w, h) = (b.width as i64, b.height as i64);
    let l = (f.params().normal_fraction * (w * h) as f64).round().max(9.0);
    let half = (l.sqrt() / 2.0).ceil() as i64;
    let sigma = f.params().normal_sigma;
    let (pu, pv) = (i64::from(pixel) % w, i64::from(pixel) / w);
    let ray = |u: i64, v: i64, d: f64| Vector3::new(f64::from(b.ray_x[u as usize]) * d, f64::from(b.ray_y[v as usize]) * d, d);
    let o = ray(pu, pv, f64::from(depth.data[pixel as usize]));
    let (mut sw, mut sp, mut spp) = (0.0, Vector3::zeros(), nalgebra::Matrix3::zeros());
    for v in (pv - half).max(0)..=(pv + half).min(h - 1) {
        for u in (pu - half).max(0)..=(pu + half).min(w - 1) {
            let d = f64::from(b.filtered[(v * w + u) as usize]);
            if d <= 0.0 {
                continue;
            }
            let q = ray(u, v, d) - o;
            if q.norm_squared() > 13.8 * sigma * sigma {
                continue;
            }
            let wt = (-q.norm_squared() / (sigma * sigma)).exp();
            sw += wt;
            sp += wt * q;
            spp += wt * q * q.transpose();
        }
    }
    let mean = sp / sw;
    let eig = nalgebra::SymmetricEigen::new(spp / sw - mean * mean.transpose());
    let k = (0..3).min_by(|&a, &c| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[c]))?;
    Some(eig.eigenvectors.column(k).into_owned())
}

/// fDED's normals against [`reference_normal`] on one frame; returns how many distinct
/// obstacle pixels it had.
fn check_normals(k: &Intrinsics, frame: &Frame<'_>) -> usize {
    let mut f = Fded::new(&model(), k, FdedParams::default()).unwrap();
    let mut out = f.new_output();
    f.process(frame, &mut out).unwrap();
    let pixels: Vec<(usize, u32)> = f.buffers().link_best.iter().enumerate().filter(|(_, b)| b.is_some()).map(|(l, b)| (l, b.object_pixel)).collect();
    let mut distinct: Vec<u32> = pixels.iter().map(|p| p.1).collect();
    distinct.sort_unstable();
    distinct.dedup();
    f.classify_full(frame).unwrap();
    let cam_from_base = frame.camera_pose.inverse();
    for (l, pixel) in pixels {
        let want = reference_normal(&f, frame.depth, pixel).expect("a plane");
        let got = cam_from_base.rotation * out.links[l].normal;
        // f32 sums against f64: 1 − |cos| ≈ 1e-8 here.
        assert!(got.dot(&want).abs() > 1.0 - 1e-6, "link {l}: normal {got} vs reference {want}");
    }
    distinct.len()
}

#[test]
fn normals_equal_a_fit_over_the_fully_classified_image() {
    // Obstacle pixels apart: one fit per window.
    let k = Intrinsics::kinect();
    let cam = look_at([2.0, 0.0, 0.8], [0.3, 0.0, 0.5]);
    let depth = scene(&k, &cam);
    let frame = Frame { stamp: 0.0, depth: &depth, camera_pose: &cam, joints: Some(&TOLD) };
    assert!(check_normals(&k, &frame) >= 2);
    // The benchmark's static scene: seven links' obstacle pixels a few pixels apart, their
    // windows classified together.
    let bench = cowork_fded::bench::static_scene(&model(), 1, 1).unwrap();
    assert!(check_normals(&bench.intrinsics, &bench.frame(0)) >= 5);
    // A ball 4–5 cm from the end effector: robot pixels lie inside the fits' balls, so the
    // windows' robot removal must reach them.
    let m = model();
    let mut poses = cowork_robot::LinkPoses::new();
    m.forward_kinematics(&cowork_robot::JointVector::from_column_slice(&TOLD), &mut poses);
    let ee = poses.get(m.link_count() - 1).translation.vector;
    let mut d = DepthImage::new(k.width, k.height);
    robot(&mut d, &m, &k, &cam, &TOLD);
    sphere(&mut d, &k, &cam, Point3::from(ee + Vector3::new(0.0, 0.15, 0.0)), 0.06);
    plane(&mut d, &k, &cam, Vector3::z(), 0.0);
    let frame = Frame { stamp: 0.0, depth: &d, camera_pose: &cam, joints: Some(&TOLD) };
    check_normals(&k, &frame);
}
