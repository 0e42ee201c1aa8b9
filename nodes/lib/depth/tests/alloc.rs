//! After warm-up, rendering a frame (with noise) allocates nothing on the calling thread.
#![allow(unsafe_code)] // the counting global allocator

mod common;

use cowork_depth::{Capsule, DepthImage, DepthRenderer, KinectNoise};
use cowork_robot::JointVector;
use nalgebra::Point3;

#[global_allocator]
static GLOBAL: cowork_testkit::CountingAllocator = cowork_testkit::CountingAllocator;

#[test]
fn render_allocates_nothing_after_warm_up() {
    let model = common::model();
    let scene = common::scene("stacking.yaml");
    let mut r = DepthRenderer::new(&model, &scene).unwrap();
    r.set_parallel(false);
    r.set_noise(Some(KinectNoise::with_seed(2))).unwrap();
    let objects: Vec<_> = scene.objects.iter().map(|o| (o.shape, o.pose.isometry())).collect();
    let people = [Capsule::new(Point3::new(0.6, 0.8, 0.0), Point3::new(0.6, 0.8, 1.4), 0.15)];
    let mut out = DepthImage::default();
    let mut q = JointVector::from_row_slice(&[0.0, 0.5, 0.0, 1.4, 0.0, 0.7, 0.0]);
    for _ in 0..2 {
        r.render(&q, &objects, &people, &mut out).unwrap();
    }
    let before = cowork_testkit::allocations();
    for i in 0..5 {
        q[0] = 0.1 * f64::from(i);
        r.render(&q, &objects, &people, &mut out).unwrap();
    }
    assert_eq!(cowork_testkit::allocations() - before, 0);
}
