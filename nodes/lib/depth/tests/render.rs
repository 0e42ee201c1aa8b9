//! Renderer geometry: analytic shapes at known poses, robot pixels against forward kinematics,
//! labels, layers and bad input.

mod common;

use cowork_depth::{Capsule, DepthImage, DepthRenderer, Error, Intrinsics, Label, Layers, Table};
use cowork_robot::{JointVector, LinkPoses};
use cowork_sim::Shape;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

type Obj = (Shape, Isometry3<f64>);

const NO_OBJECTS: [Obj; 0] = [];

/// A renderer whose optical frame is the base frame (z forward, x right, y down), drawing only
/// objects and people.
fn bare(k: Intrinsics) -> DepthRenderer {
    let mut r = DepthRenderer::with_camera(&common::model(), k, Isometry3::identity()).unwrap();
    r.set_layers(Layers { robot: false, ..Layers::default() });
    r
}

fn ray(k: &Intrinsics, x: u32, y: u32) -> Vector3<f64> {
    Vector3::new((f64::from(x) - k.cx) / k.fx, (f64::from(y) - k.cy) / k.fy, 1.0)
}

/// Depth (optical z) where the ray through pixel (x, y) meets a sphere, by the textbook formula.
fn sphere_depth(k: &Intrinsics, x: u32, y: u32, c: &Point3<f64>, r: f64) -> f64 {
    let d = ray(k, x, y).normalize();
    let b = d.dot(&c.coords);
    let dist = b - (b * b - c.coords.norm_squared() + r * r).sqrt();
    (d * dist).z
}

#[test]
fn sphere_on_the_axis_matches_analytic_depth() {
    let k = Intrinsics::kinect();
    let mut r = bare(k);
    let c = Point3::new(0.0, 0.0, 2.0);
    let objects: [Obj; 1] = [(Shape::Sphere { radius: 0.2 }, Isometry3::translation(c.x, c.y, c.z))];
    let mut out = DepthImage::default();
    r.render(&JointVector::zeros(), &objects, &[], &mut out).unwrap();
    assert_eq!((out.width, out.height), (640, 480));
    for (x, y) in [(320, 240), (319, 239), (330, 250), (300, 200)] {
        let want = sphere_depth(&k, x, y, &c, 0.2);
        let got = f64::from(out.get(x, y).unwrap());
        assert!((got - want).abs() < 1e-3, "pixel ({x}, {y}): {got} vs {want}");
        assert!((got - want).abs() < 1e-5, "ray cast is exact: {got} vs {want}");
        assert_eq!(r.labels()[(y * 640 + x) as usize], Label::Object(0));
    }
    // Silhouette: radius 0.2 m at 2 m spans about f r / sqrt(z² − r²) ≈ 52.8 px each side.
    assert_eq!(out.get(320 + 51, 240).map(|d| d > 0.0), Some(true));
    assert_eq!(out.get(320 + 54, 240), Some(0.0));
    assert_eq!(r.labels()[(240 * 640 + 320 + 54) as usize], Label::None);
}

#[test]
fn box_faces_match_analytic_depth() {
    let k = Intrinsics::kinect();
    let mut r = bare(k);
    // Fronto-parallel face at z = 1.5 m.
    let objects: [Obj; 1] = [(Shape::Box { size: [0.4, 0.3, 0.2] }, Isometry3::translation(0.05, -0.02, 1.6))];
    let mut out = DepthImage::default();
    r.render(&JointVector::zeros(), &objects, &[], &mut out).unwrap();
    for (x, y) in [(320, 240), (330, 230), (300, 260)] {
        assert!((f64::from(out.get(x, y).unwrap()) - 1.5).abs() < 1e-5);
    }
    // Tilted box: depth where the centre pixel's ray meets the front face's plane.
    let pose = Isometry3::from_parts(
        Translation3::new(0.0, 0.0, 2.0),
        UnitQuaternion::from_euler_angles(0.3, -0.4, 0.2),
    );
    let size = [0.5, 0.6, 0.4];
    let objects: [Obj; 1] = [(Shape::Box { size }, pose)];
    r.render(&JointVector::zeros(), &objects, &[], &mut out).unwrap();
    let (x, y) = (320, 240);
    let d = ray(&k, x, y);
    // Nearest hit over the six face planes, each checked to lie inside its face.
    let h = Vector3::from(size) * 0.5;
    let inv = pose.inverse();
    let mut want = f64::INFINITY;
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut n = Vector3::zeros();
            n[axis] = sign;
            let n_cam = pose.rotation * n;
            let p0 = pose * Point3::from(n * h[axis]);
            let t = n_cam.dot(&p0.coords) / n_cam.dot(&d);
            let local = inv * Point3::from(d * t);
            if t > 0.0 && (0..3).all(|i| local[i].abs() <= h[i] + 1e-9) {
                want = want.min(t);
            }
        }
    }
    let got = f64::from(out.get(x, y).unwrap());
    assert!(want.is_finite());
    assert!((got - want).abs() < 1e-3, "{got} vs {want}");
}

#[test]
fn cylinder_and_capsule_match_analytic_depth() {
    let k = Intrinsics::kinect();
    let mut r = bare(k);
    // Upright cylinder (axis along the pose z) turned so its axis is the image's y: the centre
    // pixel sees the side at depth z − radius.
    let pose = Isometry3::from_parts(
        Translation3::new(0.0, 0.0, 1.2),
        UnitQuaternion::from_euler_angles(std::f64::consts::FRAC_PI_2, 0.0, 0.0),
    );
    let objects: [Obj; 1] = [(Shape::Cylinder { radius: 0.05, height: 0.3 }, pose)];
    let mut out = DepthImage::default();
    r.render(&JointVector::zeros(), &objects, &[], &mut out).unwrap();
    let (x, y) = (320, 240);
    let d = ray(&k, x, y);
    // Distance to the axis (along y) is √(X² + (Z − 1.2)²) with (X, Z) = t (dx, 1).
    let (a, b, c) = (d.x * d.x + 1.0, -2.4, 1.44 - 0.0025);
    let want = (-b - (b * b - 4.0 * a * c).sqrt()) / (2.0 * a);
    let got = f64::from(out.get(x, y).unwrap());
    assert!((got - want).abs() < 1e-5, "{got} vs {want}");

    // A capsule seen end-on: its near end is a sphere.
    let person = [Capsule::new(Point3::new(0.0, 0.0, 1.0), Point3::new(0.0, 0.0, 1.6), 0.1)];
    r.render(&JointVector::zeros(), &NO_OBJECTS, &person, &mut out).unwrap();
    let want = sphere_depth(&k, x, y, &Point3::new(0.0, 0.0, 1.0), 0.1);
    let got = f64::from(out.get(x, y).unwrap());
    assert!((got - want).abs() < 1e-5, "{got} vs {want}");
    assert_eq!(r.labels()[(y * 640 + x) as usize], Label::Person(0));
}

#[test]
fn scene_camera_pose_projects_object_centres() {
    // Objects seen through the stacking scene's camera: the top-face centre of each box
    // projects to a pixel that shows that box at the FK-free, analytic depth.
    let model = common::model();
    let scene = common::scene("stacking.yaml");
    let mut r = DepthRenderer::new(&model, &scene).unwrap();
    r.set_layers(Layers { robot: false, ..Layers::default() });
    let objects: Vec<Obj> = scene.objects.iter().map(|o| (o.shape, o.pose.isometry())).collect();
    let mut out = DepthImage::default();
    r.render(&JointVector::zeros(), &objects, &[], &mut out).unwrap();
    let cam = r.camera_pose().inverse();
    let k = *r.intrinsics();
    for (i, (shape, pose)) in objects.iter().enumerate() {
        let Shape::Box { size } = shape else { panic!("stacking boxes") };
        let top = cam * (pose * Point3::new(0.0, 0.0, 0.5 * size[2]));
        let (u, v, _) = k.project(&top).expect("box top in view");
        let (x, y) = k.pixel(u, v).unwrap();
        assert_eq!(r.labels()[(y * k.width + x) as usize], Label::Object(i as u16));
        // The pixel's ray meets the top plane (z = top in the base frame) at:
        let d_cam = ray(&k, x, y);
        let n_cam = cam.rotation * Vector3::z();
        let t = n_cam.dot(&top.coords) / n_cam.dot(&d_cam);
        let got = f64::from(out.get(x, y).unwrap());
        assert!((got - t).abs() < 1e-3, "box {i}: {got} vs {t}");
    }
    // A pixel of the table far from any object shows the table top.
    let p = cam * Point3::new(0.9, 0.0, 0.0);
    let (u, v, z) = k.project(&p).unwrap();
    let (x, y) = k.pixel(u, v).unwrap();
    assert_eq!(r.labels()[(y * k.width + x) as usize], Label::Table);
    assert!((f64::from(out.get(x, y).unwrap()) - z).abs() < 0.01);
}

/// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
fn closest_on_triangle(p: Point3<f64>, a: Point3<f64>, b: Point3<f64>, c: Point3<f64>) -> Point3<f64> {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

fn robot_pixels_lie_on_their_links(q: JointVector) {
    let model = common::model();
    let scene = common::scene("stacking.yaml");
    let mut r = DepthRenderer::new(&model, &scene).unwrap();
    r.set_layers(Layers::robot_only());
    let mut out = DepthImage::default();
    r.render(&q, &NO_OBJECTS, &[], &mut out).unwrap();
    let k = *r.intrinsics();
    let mut poses = LinkPoses::new();
    model.forward_kinematics(&q, &mut poses);
    let cam_pose = *r.camera_pose();

    // Every robot pixel (sampled) is a point on the surface of the link its label names.
    let mut checked = 0;
    let mut worst: f64 = 0.0;
    for (i, label) in r.labels().iter().enumerate().step_by(5) {
        let Label::Link(l) = *label else {
            assert_eq!(out.data[i], 0.0, "robot-only render: non-robot pixels are empty");
            continue;
        };
        let (x, y) = ((i % k.width as usize) as f64, (i / k.width as usize) as f64);
        let p_base = cam_pose * k.unproject(x, y, f64::from(out.data[i]));
        let p_link = poses.get(l as usize).inverse() * p_base;
        let mesh = model.link_mesh(l as usize).unwrap();
        let dist = mesh
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|j| mesh.vertices[j as usize]);
                (closest_on_triangle(p_link, a, b, c) - p_link).norm()
            })
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(dist);
        checked += 1;
    }
    assert!(checked > 500, "the robot covers enough pixels ({checked} sampled)");
    assert!(worst < 1e-3, "robot pixels are within {worst} m of their link surfaces");

    // The robot's silhouette spans the projection of its FK-posed vertices.
    let cam = cam_pose.inverse();
    let (mut u0, mut u1, mut v0, mut v1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for l in 0..model.link_count() {
        let Some(mesh) = model.link_mesh(l) else { continue };
        for v in &mesh.vertices {
            let (u, v, _) = k.project_unclipped(&(cam * (poses.get(l) * v))).unwrap();
            (u0, u1, v0, v1) = (u0.min(u), u1.max(u), v0.min(v), v1.max(v));
        }
    }
    let (mut x0, mut x1, mut y0, mut y1) = (u32::MAX, 0, u32::MAX, 0);
    for (i, label) in r.labels().iter().enumerate() {
        if label.is_robot() {
            let (x, y) = (i as u32 % k.width, i as u32 / k.width);
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
    }
    let (w, h) = (f64::from(k.width) - 1.0, f64::from(k.height) - 1.0);
    assert!(u0 > 0.0 && v0 > 0.0 && u1 < w && v1 < h, "the whole arm is in view");
    for (got, want) in [(x0, u0), (x1, u1), (y0, v0), (y1, v1)] {
        assert!((f64::from(got) - want).abs() <= 1.0, "silhouette bound {got} vs projected {want}");
    }
}

#[test]
fn robot_pixels_match_forward_kinematics_at_start() {
    let scene = common::scene("stacking.yaml");
    let q = JointVector::from_iterator(scene.initial_joints_deg().iter().map(|d| d.to_radians()));
    robot_pixels_lie_on_their_links(q);
}

#[test]
fn robot_pixels_match_forward_kinematics_elsewhere() {
    robot_pixels_lie_on_their_links(JointVector::from_row_slice(&[0.5, 0.8, 0.3, 1.0, -0.5, 0.9, 0.2]));
}

#[test]
fn nearer_things_hide_farther_ones() {
    let k = Intrinsics::kinect();
    let mut r = bare(k);
    r.set_table(Some(Table { size: [4.0, 4.0, 0.1], pose: Isometry3::translation(0.0, 0.0, 3.05) })).unwrap();
    let objects: [Obj; 2] = [
        (Shape::Box { size: [0.2, 0.2, 0.2] }, Isometry3::translation(0.0, 0.0, 2.0)),
        (Shape::Sphere { radius: 0.05 }, Isometry3::translation(0.0, 0.0, 2.5)), // hidden by the box
    ];
    let person = [Capsule::new(Point3::new(0.3, -0.3, 1.5), Point3::new(0.3, 0.3, 1.5), 0.05)];
    let mut out = DepthImage::default();
    r.render(&JointVector::zeros(), &objects, &person, &mut out).unwrap();
    fn at(out: &DepthImage, r: &DepthRenderer, x: u32, y: u32) -> (f32, Label) {
        (out.get(x, y).unwrap(), r.labels()[(y * 640 + x) as usize])
    }
    assert_eq!(at(&out, &r, 320, 240).1, Label::Object(0));
    assert!((at(&out, &r, 320, 240).0 - 1.9).abs() < 1e-5);
    assert!(!r.labels().contains(&Label::Object(1)));
    let u = (0.3 / 1.5 * 525.0 + 319.5_f64).round() as u32;
    assert_eq!(at(&out, &r, u, 240).1, Label::Person(0));
    assert_eq!(at(&out, &r, 10, 10).1, Label::Table);
    assert!((at(&out, &r, 10, 10).0 - 3.0).abs() < 1e-5);

    // Layers switch parts off.
    r.set_layers(Layers { table: false, robot: false, ..Layers::default() });
    r.render(&JointVector::zeros(), &objects, &person, &mut out).unwrap();
    assert_eq!(at(&out, &r, 10, 10), (0.0, Label::None));
    r.set_layers(Layers { people: false, robot: false, ..Layers::default() });
    r.render(&JointVector::zeros(), &objects, &person, &mut out).unwrap();
    assert_ne!(at(&out, &r, u, 240).1, Label::Person(0));
}

#[test]
fn geometry_behind_or_through_the_camera_is_clipped() {
    let k = Intrinsics::kinect();
    let mut r = bare(k);
    // A box around the camera origin: the camera is inside, so its back-facing inner walls are
    // culled and nothing is seen; the box behind the camera is never drawn.
    let objects: [Obj; 2] = [
        (Shape::Box { size: [0.5, 0.5, 0.5] }, Isometry3::translation(0.0, 0.0, -2.0)),
        (Shape::Box { size: [1.0, 1.0, 4.0] }, Isometry3::translation(0.0, 0.0, 1.0)),
    ];
    let mut out = DepthImage::default();
    r.render(&JointVector::zeros(), &objects, &[], &mut out).unwrap();
    assert_eq!(out.valid_count(), 0);
    // A long plank crossing the near plane is drawn where it is in front of the camera only.
    let objects: [Obj; 1] = [(Shape::Box { size: [0.2, 0.05, 4.0] }, Isometry3::translation(0.0, 0.3, 0.0))];
    r.render(&JointVector::zeros(), &objects, &[], &mut out).unwrap();
    assert!(out.valid_count() > 0);
    for (i, d) in out.data.iter().enumerate().filter(|(_, d)| **d > 0.0) {
        let (x, y) = ((i % 640) as f64, (i / 640) as f64);
        let p = k.unproject(x, y, f64::from(*d));
        assert!(p.z >= 0.01 - 1e-9 && p.z <= 2.0 + 1e-6, "{p}");
        // On the plank's top face (y = 0.3 − 0.025 in the optical frame).
        assert!((p.y - 0.275).abs() < 1e-4, "{p}");
    }
}

#[test]
fn bad_input_is_rejected_and_output_untouched() {
    let k = Intrinsics::kinect();
    let mut r = bare(k);
    let mut out = DepthImage::new(2, 2);
    let mut q = JointVector::zeros();
    q[3] = f64::NAN;
    let err = r.render(&q, &NO_OBJECTS, &[], &mut out).unwrap_err();
    assert!(err.to_string().contains("q[3]"), "{err}");
    let person = [Capsule::new(Point3::origin(), Point3::new(0.0, 0.0, 1.0), -0.1)];
    let err = r.render(&JointVector::zeros(), &NO_OBJECTS, &person, &mut out).unwrap_err();
    assert!(err.to_string().contains("people[0].radius"), "{err}");
    let objects: [Obj; 1] = [(Shape::Sphere { radius: f64::NAN }, Isometry3::identity())];
    let err = r.render(&JointVector::zeros(), &objects, &[], &mut out).unwrap_err();
    assert!(err.to_string().contains("objects[0].shape.radius"), "{err}");
    let objects: [Obj; 1] = [(Shape::Sphere { radius: 0.1 }, Isometry3::translation(f64::INFINITY, 0.0, 0.0))];
    let err = r.render(&JointVector::zeros(), &objects, &[], &mut out).unwrap_err();
    assert!(err.to_string().contains("objects[0].pose"), "{err}");
    assert_eq!(out, DepthImage::new(2, 2));

    let bad_k = Intrinsics { fx: 0.0, ..k };
    assert!(matches!(
        DepthRenderer::with_camera(&common::model(), bad_k, Isometry3::identity()),
        Err(Error::BadIntrinsics { field: "fx", .. })
    ));
    let err = r.set_table(Some(Table { size: [1.0, 0.0, 1.0], pose: Isometry3::identity() })).unwrap_err();
    assert!(err.to_string().contains("table.size[1]"));
}

#[test]
fn parallel_and_sequential_give_identical_frames() {
    let model = common::model();
    let scene = common::scene("stacking.yaml");
    let objects: Vec<Obj> = scene.objects.iter().map(|o| (o.shape, o.pose.isometry())).collect();
    let person = [
        Capsule::new(Point3::new(0.7, 0.7, 0.0), Point3::new(0.7, 0.7, 0.9), 0.15),
        Capsule::new(Point3::new(0.7, 0.7, 0.9), Point3::new(0.5, 0.3, 0.4), 0.05),
    ];
    let q = JointVector::from_row_slice(&[0.2, 0.5, 0.0, 1.4, 0.0, 0.8, 0.0]);
    let mut a = DepthRenderer::new(&model, &scene).unwrap();
    let mut b = DepthRenderer::new(&model, &scene).unwrap();
    b.set_parallel(false);
    let (mut da, mut db) = (DepthImage::default(), DepthImage::default());
    for noise in [None, Some(cowork_depth::KinectNoise::with_seed(3))] {
        a.set_noise(noise).unwrap();
        b.set_noise(noise).unwrap();
        a.render(&q, &objects, &person, &mut da).unwrap();
        b.render(&q, &objects, &person, &mut db).unwrap();
        assert_eq!(da, db);
        assert_eq!(a.labels(), b.labels());
    }
    // All four kinds of thing are in view.
    for want in [Label::Table, Label::Object(0), Label::Link(3), Label::Person(0)] {
        assert!(a.labels().contains(&want), "{want:?} in view");
    }
}


#[test]
fn floor_is_a_plane_seen_from_above_only() {
    let k = Intrinsics::kinect();
    // Camera 2 m above the base origin looking straight down: optical z = −base z,
    // x right = base x, y down = base −y.
    let down = Isometry3::from_parts(
        Translation3::new(0.0, 0.0, 2.0),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
    );
    let mut r = DepthRenderer::with_camera(&common::model(), k, down).unwrap();
    r.set_layers(Layers { robot: false, ..Layers::default() });
    let mut out = DepthImage::default();
    r.render(&JointVector::zeros(), &NO_OBJECTS, &[], &mut out).unwrap();
    assert_eq!(out.valid_count(), 0, "no floor unless one is set");

    r.set_floor(Some(cowork_depth::Floor::at(-0.5))).unwrap();
    r.render(&JointVector::zeros(), &NO_OBJECTS, &[], &mut out).unwrap();
    // A plane parallel to the image plane at 2.5 m: every pixel at optical z = 2.5 m.
    assert_eq!(out.valid_count(), 640 * 480);
    for (x, y) in [(0, 0), (320, 240), (639, 479)] {
        let d = f64::from(out.get(x, y).unwrap());
        assert!((d - 2.5).abs() < 1e-5, "pixel ({x}, {y}): {d}");
        assert_eq!(r.labels()[(y * 640 + x) as usize], Label::Floor);
    }
    // A person on the floor hides it.
    let person = [Capsule::new(Point3::new(0.0, 0.0, -0.5), Point3::new(0.0, 0.0, 1.0), 0.2)];
    r.render(&JointVector::zeros(), &NO_OBJECTS, &person, &mut out).unwrap();
    assert!((f64::from(out.get(320, 240).unwrap()) - 0.8).abs() < 1e-5);
    assert_eq!(r.labels()[240 * 640 + 320], Label::Person(0));

    // From below the floor is culled; the layer switch hides it too.
    r.set_floor(Some(cowork_depth::Floor::at(2.5))).unwrap();
    r.render(&JointVector::zeros(), &NO_OBJECTS, &[], &mut out).unwrap();
    assert_eq!(out.valid_count(), 0, "floor above the camera is seen from below");
    r.set_floor(Some(cowork_depth::Floor::at(-0.5))).unwrap();
    r.set_layers(Layers { robot: false, floor: false, ..Layers::default() });
    r.render(&JointVector::zeros(), &NO_OBJECTS, &[], &mut out).unwrap();
    assert_eq!(out.valid_count(), 0);

    for bad in [cowork_depth::Floor { height: f64::NAN, half_size: 1.0 }, cowork_depth::Floor { height: 0.0, half_size: 0.0 }] {
        let e = r.set_floor(Some(bad)).unwrap_err().to_string();
        assert!(e.contains("floor."), "{e}");
    }
}
