//! Analytic depth scenes for the tests: spheres, boxes and planes ray-cast per pixel
//! (independent of the rasteriser under test), and the bundled LWR model.
#![allow(dead_code)]

use cowork_depth::{DepthImage, Intrinsics};
use cowork_fded::{Fded, FdedParams, Frame};
use cowork_robot::RobotModel;
use nalgebra::{Isometry3, Point3, Vector3};

pub fn model() -> RobotModel {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../config/robot/lwr4plus.urdf");
    RobotModel::from_urdf_file(path).expect("bundled URDF loads")
}

/// Optical-frame pose (z forward, y down) at `eye` looking at `target`, base frame.
pub fn look_at(eye: [f64; 3], target: [f64; 3]) -> Isometry3<f64> {
    Isometry3::face_towards(&Point3::from(eye), &Point3::from(target), &-Vector3::z())
}

/// Camera ray of pixel (u, v) with unit z (so the ray parameter is the z-depth), camera frame.
fn ray(k: &Intrinsics, u: u32, v: u32) -> Vector3<f64> {
    Vector3::new((u as f64 - k.cx) / k.fx, (v as f64 - k.cy) / k.fy, 1.0)
}

/// Writes `min(current, z)` where the ray hits; 0 counts as empty.
fn put(img: &mut DepthImage, i: usize, z: f64) {
    let cur = img.data[i];
    if z > 0.0 && (cur <= 0.0 || (z as f32) < cur) {
        img.data[i] = z as f32;
    }
}

/// Renders a sphere (centre in the base frame, m).
pub fn sphere(img: &mut DepthImage, k: &Intrinsics, cam: &Isometry3<f64>, centre: Point3<f64>, r: f64) {
    let c = (cam.inverse() * centre).coords;
    for v in 0..k.height {
        for u in 0..k.width {
            let d = ray(k, u, v);
            // |t d − c|² = r²
            let a = d.norm_squared();
            let b = -2.0 * d.dot(&c);
            let cc = c.norm_squared() - r * r;
            let disc = b * b - 4.0 * a * cc;
            if disc >= 0.0 {
                let t = (-b - disc.sqrt()) / (2.0 * a);
                put(img, (v * k.width + u) as usize, t);
            }
        }
    }
}

/// Renders a box with half extents `half` at `pose` (base frame).
pub fn cuboid(img: &mut DepthImage, k: &Intrinsics, cam: &Isometry3<f64>, pose: &Isometry3<f64>, half: Vector3<f64>) {
    let box_from_cam = pose.inverse() * cam;
    let o = box_from_cam.translation.vector;
    for v in 0..k.height {
        for u in 0..k.width {
            let d = box_from_cam.rotation * ray(k, u, v);
            let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
            let mut hit = true;
            for a in 0..3 {
                if d[a].abs() < 1e-12 {
                    if o[a].abs() > half[a] {
                        hit = false;
                    }
                    continue;
                }
                let (ta, tb) = ((-half[a] - o[a]) / d[a], (half[a] - o[a]) / d[a]);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
            if hit && t0 <= t1 && t0 > 0.0 {
                put(img, (v * k.width + u) as usize, t0);
            }
        }
    }
}

/// Renders the plane `n · x = offset` (base frame) where it is in front of the camera.
pub fn plane(img: &mut DepthImage, k: &Intrinsics, cam: &Isometry3<f64>, n: Vector3<f64>, offset: f64) {
    let nc = cam.rotation.inverse() * n;
    let oc = offset - n.dot(&cam.translation.vector);
    for v in 0..k.height {
        for u in 0..k.width {
            let d = ray(k, u, v);
            let den = nc.dot(&d);
            if den.abs() > 1e-12 {
                let t = oc / den;
                put(img, (v * k.width + u) as usize, t);
            }
        }
    }
}

/// Copies the robot as `fded` sees it at `q` into `img` (nearest wins), as a sensor would.
pub fn robot(img: &mut DepthImage, model: &RobotModel, k: &Intrinsics, cam: &Isometry3<f64>, q: &[f64]) {
    let mut f = Fded::new(model, k, FdedParams::default()).expect("fded");
    let empty = DepthImage::new(k.width, k.height);
    f.prepare(&Frame { stamp: 0.0, depth: &empty, camera_pose: cam, joints: Some(q) })
        .expect("prepare");
    for (i, &z) in f.buffers().virtual_depth.iter().enumerate() {
        put(img, i, f64::from(z));
    }
}

/// A posed link mesh as a parry TriMesh (base frame).
pub fn link_trimesh(model: &RobotModel, q: &[f64], link: usize) -> Option<parry3d_f64::shape::TriMesh> {
    let mesh = model.link_mesh(link)?;
    let pose = model.link_pose(&cowork_robot::JointVector::from_row_slice(q), link);
    let verts: Vec<Point3<f64>> = mesh.vertices.iter().map(|p| pose * p).collect();
    parry3d_f64::shape::TriMesh::new(verts, mesh.triangles.clone()).ok()
}
