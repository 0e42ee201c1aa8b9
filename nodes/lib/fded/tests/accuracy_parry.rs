//! fDED at S = 1 against exact mesh-to-shape distances from parry (independent geometry):
//! spheres and boxes ray-cast into the depth image beside the arm, camera in front.

mod common;

use common::{cuboid, link_trimesh, look_at, model, robot, sphere};
use cowork_depth::{DepthImage, Intrinsics};
use cowork_fded::{Fded, FdedParams, Frame};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use parry3d_f64::query;
use parry3d_f64::shape::{Ball, Cuboid, Shape};

const Q: [f64; 7] = [0.0, std::f64::consts::FRAC_PI_6, 0.0, std::f64::consts::FRAC_PI_2, 0.0, std::f64::consts::FRAC_PI_3, 0.0];

/// Exact per-link distances (parry) and the index of the closest link.
fn parry_distances(shape: &dyn Shape, pose: &Isometry3<f64>) -> (Vec<Option<f64>>, usize) {
    let m = model();
    let mut d = Vec::new();
    let mut best = (f64::INFINITY, 0);
    for l in 0..m.link_count() {
        let v = link_trimesh(&m, &Q, l).map(|mesh| {
            query::distance(&Isometry3::identity(), &mesh, pose, shape).expect("supported pair")
        });
        if let Some(x) = v
            && x < best.0
        {
            best = (x, l);
        }
        d.push(v);
    }
    (d, best.1)
}

fn run_fded(depth: &DepthImage, k: &Intrinsics, cam: &Isometry3<f64>, tile: u32) -> cowork_fded::FdedOutput {
    let m = model();
    let params = FdedParams { tile_size: tile, step_x: 1, step_y: 1, ..FdedParams::default() };
    let mut f = Fded::new(&m, k, params).unwrap();
    let mut out = f.new_output();
    f.process(&Frame { stamp: 0.0, depth, camera_pose: cam, joints: Some(&Q) }, &mut out).unwrap();
    out
}

/// A point beside the upper arm or forearm, `lateral` m from the link axis, in the arm's
/// x–z plane (the camera looks along base y, so it is at the link's depth).
fn beside(link_a: usize, link_b: usize, lateral: f64) -> Point3<f64> {
    let m = model();
    let q = cowork_robot::JointVector::from_row_slice(&Q);
    let a = m.link_pose(&q, link_a).translation.vector;
    let b = m.link_pose(&q, link_b).translation.vector;
    let d = (b - a).normalize();
    let n = Vector3::new(d.z, 0.0, -d.x).normalize();
    Point3::from((a + b) * 0.5 + n * lateral)
}

fn check(label: &str, shape: &dyn Shape, pose: &Isometry3<f64>, depth: &DepthImage, k: &Intrinsics, cam: &Isometry3<f64>) {
    let (exact, closest) = parry_distances(shape, pose);
    let exact_min = exact[closest].unwrap();
    for tile in [8, 32] {
        let out = run_fded(depth, k, cam, tile);
        let got = out.minimum().expect("an obstacle is seen");
        let link = &out.links[closest];
        println!(
            "{label} T_s={tile}: parry {exact_min:.4} m (link {closest}), fDED min {:.4} m (link {}), fDED link {closest} {:.4} m",
            got.distance, got.link, link.distance
        );
        assert!((got.distance - exact_min).abs() < 0.01, "{label}: global minimum {} vs parry {exact_min}", got.distance);
        assert!(link.valid && (link.distance - exact_min).abs() < 0.01, "{label}: link {closest} {} vs parry {exact_min}", link.distance);
        // The reported points are consistent with the distance and lie near the shapes.
        assert!(((got.robot_point - got.obstacle_point).norm() - got.distance).abs() < 1e-4);
        let on_obstacle = shape.distance_to_point(pose, &got.obstacle_point, true);
        assert!(on_obstacle < 0.01, "{label}: obstacle point {on_obstacle} m off the shape");
    }
}

#[test]
fn spheres_beside_the_arm_match_parry_within_1cm() {
    let k = Intrinsics::kinect();
    let cam = look_at([0.3, -2.0, 0.6], [0.3, 0.0, 0.5]);
    let m = model();
    for (links, gap, r) in [((2, 4), 0.06, 0.08), ((2, 4), 0.15, 0.1), ((4, 6), 0.10, 0.06), ((4, 6), 0.25, 0.12)] {
        let centre = beside(links.0, links.1, 0.07 + gap + r);
        let mut depth = DepthImage::new(k.width, k.height);
        robot(&mut depth, &m, &k, &cam, &Q);
        sphere(&mut depth, &k, &cam, centre, r);
        let pose = Isometry3::from_parts(Translation3::from(centre.coords), UnitQuaternion::identity());
        check(&format!("sphere r={r} gap={gap} beside {links:?}"), &Ball::new(r), &pose, &depth, &k, &cam);
    }
}

#[test]
fn boxes_beside_the_arm_match_parry_within_1cm() {
    let k = Intrinsics::kinect();
    let cam = look_at([0.3, -2.0, 0.6], [0.3, 0.0, 0.5]);
    let m = model();
    for (links, gap, yaw) in [((2, 4), 0.08, 0.0), ((4, 6), 0.12, 0.4), ((2, 4), 0.2, 0.0)] {
        let half = Vector3::new(0.06, 0.05, 0.12);
        let centre = beside(links.0, links.1, -(0.07 + gap + half.y));
        let pose = Isometry3::from_parts(
            Translation3::from(centre.coords),
            UnitQuaternion::from_euler_angles(0.0, 0.0, yaw),
        );
        let mut depth = DepthImage::new(k.width, k.height);
        robot(&mut depth, &m, &k, &cam, &Q);
        cuboid(&mut depth, &k, &cam, &pose, half);
        check(&format!("box yaw={yaw} gap={gap} beside {links:?}"), &Cuboid::new(half), &pose, &depth, &k, &cam);
    }
}
