//! After warm-up, a single-threaded frame allocates nothing.

mod common;

use common::{look_at, model, robot, sphere};
use cowork_depth::{DepthImage, Intrinsics};
use cowork_fded::{Fded, FdedParams, Frame};
use nalgebra::Point3;

#[global_allocator]
static GLOBAL: cowork_testkit::CountingAllocator = cowork_testkit::CountingAllocator;

#[test]
fn process_allocates_nothing_after_warm_up() {
    let k = Intrinsics::kinect();
    let cam = look_at([2.0, 0.0, 0.8], [0.3, 0.0, 0.5]);
    let m = model();
    let q = [0.0, 0.5, 0.0, 1.2, 0.0, 0.8, 0.0];
    let mut depth = DepthImage::new(k.width, k.height);
    robot(&mut depth, &m, &k, &cam, &q);
    sphere(&mut depth, &k, &cam, Point3::new(0.6, 0.35, 0.7), 0.1);
    for step in [16, 1] {
        let params = FdedParams { step_x: step, step_y: step, ..FdedParams::default() };
        let mut f = Fded::new(&m, &k, params).unwrap();
        let mut out = f.new_output();
        let frame = Frame { stamp: 0.0, depth: &depth, camera_pose: &cam, joints: Some(&q) };
        f.process(&frame, &mut out).unwrap();
        let before = cowork_testkit::allocations();
        for i in 1..4 {
            let frame = Frame { stamp: i as f64 * 0.033, ..frame };
            f.process(&frame, &mut out).unwrap();
        }
        assert_eq!(cowork_testkit::allocations() - before, 0, "S = {step}");
        assert!(out.minimum().is_some());
    }
}
