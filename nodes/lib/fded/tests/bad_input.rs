//! Bad input gives clear errors or is skipped, never a panic.

mod common;

use common::{look_at, model, sphere};
use cowork_depth::{DepthImage, Intrinsics};
use cowork_fded::{Backend, Error, Fded, FdedParams, Frame};
use nalgebra::Point3;

const Q: [f64; 7] = [0.0, 0.5, 0.0, 1.2, 0.0, 0.8, 0.0];

#[test]
fn nan_and_zero_pixels_are_not_obstacles() {
    let k = Intrinsics::kinect();
    let cam = look_at([2.0, 0.0, 0.8], [0.3, 0.0, 0.5]);
    let m = model();
    let mut f = Fded::new(&m, &k, FdedParams::default()).unwrap();
    let mut out = f.new_output();
    // All NaN, all zero, all infinite: nothing to avoid.
    for fill in [f32::NAN, 0.0, f32::INFINITY, -1.0] {
        let depth = DepthImage { width: k.width, height: k.height, data: vec![fill; k.pixel_count()] };
        f.process(&Frame { stamp: 0.0, depth: &depth, camera_pose: &cam, joints: Some(&Q) }, &mut out).unwrap();
        assert!(out.minimum().is_none(), "fill {fill}");
        assert!(out.links.iter().all(|l| !l.valid));
    }
    // A sphere with every third pixel NaN still yields a finite distance.
    let mut depth = DepthImage::new(k.width, k.height);
    sphere(&mut depth, &k, &cam, Point3::new(0.5, 0.4, 0.6), 0.1);
    for (i, d) in depth.data.iter_mut().enumerate() {
        if i % 3 == 0 {
            *d = f32::NAN;
        }
    }
    f.process(&Frame { stamp: 0.1, depth: &depth, camera_pose: &cam, joints: Some(&Q) }, &mut out).unwrap();
    let min = out.minimum().expect("sphere seen");
    assert!(min.distance.is_finite() && min.normal.iter().all(|v| v.is_finite()));
}

#[test]
fn size_mismatch_is_an_error() {
    let k = Intrinsics::kinect();
    let cam = look_at([2.0, 0.0, 0.8], [0.3, 0.0, 0.5]);
    let mut f = Fded::new(&model(), &k, FdedParams::default()).unwrap();
    let mut out = f.new_output();
    let small = DepthImage::new(320, 240);
    let err = f.process(&Frame { stamp: 0.0, depth: &small, camera_pose: &cam, joints: Some(&Q) }, &mut out);
    assert!(matches!(err, Err(Error::SizeMismatch { got_width: 320, width: 640, .. })), "{err:?}");
    // Right size, wrong buffer length.
    let bad = DepthImage { width: 640, height: 480, data: vec![1.0; 100] };
    let err = f.process(&Frame { stamp: 0.0, depth: &bad, camera_pose: &cam, joints: Some(&Q) }, &mut out);
    assert!(matches!(err, Err(Error::SizeMismatch { got_len: 100, .. })), "{err:?}");
    assert!(err.unwrap_err().to_string().contains("640x480"));
}

#[test]
fn missing_or_bad_joint_state_is_an_error() {
    let k = Intrinsics::kinect();
    let cam = look_at([2.0, 0.0, 0.8], [0.3, 0.0, 0.5]);
    let mut f = Fded::new(&model(), &k, FdedParams::default()).unwrap();
    let mut out = f.new_output();
    let depth = DepthImage::new(k.width, k.height);
    let frame = Frame { stamp: 1.5, depth: &depth, camera_pose: &cam, joints: None };
    let err = f.process(&frame, &mut out).unwrap_err();
    assert!(matches!(err, Error::MissingJointState { .. }) && err.to_string().contains("1.5"), "{err}");
    let err = f.process(&Frame { joints: Some(&Q[..5]), ..frame }, &mut out).unwrap_err();
    assert!(matches!(err, Error::JointCount { got: 5, expected: 7 }), "{err}");
    let nan = [0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0];
    let err = f.process(&Frame { joints: Some(&nan), ..frame }, &mut out).unwrap_err();
    assert!(matches!(err, Error::NotFinite { .. }), "{err}");
}

#[test]
fn bad_configuration_is_rejected_up_front() {
    let m = model();
    let mut k = Intrinsics::kinect();
    k.fx = 0.0;
    assert!(matches!(Fded::new(&m, &k, FdedParams::default()), Err(Error::BadIntrinsics { .. })));
    let k = Intrinsics::kinect();
    let p = FdedParams { max_depth: f64::NAN, ..FdedParams::default() };
    assert!(matches!(Fded::new(&m, &k, p), Err(Error::BadParameter { name: "max_depth", .. })));
    let p = FdedParams { backend: Backend::Gpu, ..FdedParams::default() };
    assert!(matches!(Fded::new(&m, &k, p), Err(Error::BackendUnavailable { .. })));
}
