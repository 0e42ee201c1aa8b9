//! Kinect-like noise: standard deviation against the model at 1 m and 3 m, quantisation levels,
//! dropout rates, determinism.

mod common;

use cowork_depth::{DepthImage, DepthRenderer, Intrinsics, KinectNoise, Layers, Table};
use cowork_robot::JointVector;
use cowork_sim::Shape;
use nalgebra::{Isometry3, Point3};

type Obj = (Shape, Isometry3<f64>);

/// A renderer looking straight at a wall (fronto-parallel plane) at depth `z`, filling the image.
fn wall(z: f64) -> DepthRenderer {
    let k = Intrinsics::kinect();
    let mut r = DepthRenderer::with_camera(&common::model(), k, Isometry3::identity()).unwrap();
    r.set_layers(Layers { robot: false, ..Layers::default() });
    let size = [20.0 * z, 20.0 * z, 0.1];
    r.set_table(Some(Table { size, pose: Isometry3::translation(0.0, 0.0, z + 0.05) })).unwrap();
    r
}

fn stats(values: impl Iterator<Item = f64>) -> (f64, f64, usize) {
    let v: Vec<f64> = values.collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt(), v.len())
}

fn noisy_wall(z: f64, noise: KinectNoise) -> DepthImage {
    let mut r = wall(z);
    r.set_noise(Some(noise)).unwrap();
    let mut out = DepthImage::default();
    r.render(&JointVector::zeros(), &[] as &[Obj], &[], &mut out).unwrap();
    assert_eq!(r.clean_depth().valid_count(), 640 * 480, "the wall fills the image");
    out
}

#[test]
fn gaussian_std_matches_the_model_at_1_and_3_m() {
    for z in [1.0, 3.0] {
        let noise = KinectNoise::gaussian_only(11);
        let out = noisy_wall(z, noise);
        let (mean, std, n) = stats(out.data.iter().map(|d| f64::from(*d)));
        assert_eq!(n, 640 * 480);
        let sigma = noise.sigma(z);
        println!("z = {z} m: std {:.3} mm, model {:.3} mm, mean error {:.4} mm", std * 1e3, sigma * 1e3, (mean - z) * 1e3);
        assert!((std / sigma - 1.0).abs() < 0.02, "z = {z}: std {std} vs model {sigma}");
        assert!((mean - z).abs() < 4.0 * sigma / (n as f64).sqrt() + 1e-6, "unbiased: {mean} vs {z}");
    }
}

#[test]
fn full_model_std_and_quantisation_levels_at_1_and_3_m() {
    for z in [1.0, 3.0] {
        let noise = KinectNoise { dropout_probability: 0.0, edge_dropout_probability: 0.0, ..KinectNoise::with_seed(5) };
        let out = noisy_wall(z, noise);
        let (mean, std, _) = stats(out.data.iter().map(|d| f64::from(*d)));
        let sigma = noise.sigma(z);
        let q = noise.quantisation_step(z);
        println!(
            "z = {z} m: std {:.2} mm (model σ {:.2} mm, quantisation step {:.2} mm), mean error {:.2} mm",
            std * 1e3,
            sigma * 1e3,
            q * 1e3,
            (mean - z) * 1e3
        );
        // Sheppard's correction is approximate when σ_g is about half the step: 8 %.
        assert!((std / sigma - 1.0).abs() < 0.08, "z = {z}: std {std} vs model {sigma}");
        assert!((mean - z).abs() < 0.2 * q, "z = {z}: mean {mean}");
        // Every depth is f b / (k Δd) for an integer k.
        let fb = noise.disparity_focal_px * noise.baseline_m;
        for d in out.data.iter().step_by(97) {
            let k = fb / f64::from(*d) / noise.disparity_step_px;
            assert!((k - k.round()).abs() < 1e-3, "depth {d} is not on a disparity level ({k})");
        }
        // Few distinct levels: values are quantised, not continuous.
        let mut levels: Vec<u32> = out.data.iter().map(|d| d.to_bits()).collect();
        levels.sort_unstable();
        levels.dedup();
        assert!(levels.len() < 40, "{} levels", levels.len());
    }
}

#[test]
fn dropouts_random_and_at_edges() {
    // Random dropouts on a plain wall.
    let noise = KinectNoise { dropout_probability: 0.02, ..KinectNoise::gaussian_only(9) };
    let out = noisy_wall(1.5, noise);
    let dropped = out.data.iter().filter(|d| **d == 0.0).count() as f64 / out.data.len() as f64;
    assert!((dropped - 0.02).abs() < 0.002, "dropout rate {dropped}");

    // Edge dropouts around a box in front of the wall.
    let mut r = wall(2.0);
    let noise = KinectNoise { edge_dropout_probability: 0.5, ..KinectNoise::gaussian_only(9) };
    r.set_noise(Some(noise)).unwrap();
    let objects: [Obj; 1] = [(Shape::Box { size: [0.4, 0.4, 0.4] }, Isometry3::translation(0.0, 0.0, 1.0))];
    let mut out = DepthImage::default();
    r.render(&JointVector::zeros(), &objects, &[], &mut out).unwrap();
    let clean = r.clean_depth();
    let w = 640usize;
    let (mut edge, mut edge_dropped, mut inner_dropped) = (0, 0, 0);
    for y in 1..479 {
        for x in 1..639 {
            let i = y * w + x;
            let z = clean.data[i];
            let is_edge = [i - 1, i + 1, i - w, i + w].iter().any(|&j| (clean.data[j] - z).abs() > 0.05);
            if is_edge {
                edge += 1;
                edge_dropped += usize::from(out.data[i] == 0.0);
            } else {
                inner_dropped += usize::from(out.data[i] == 0.0);
            }
        }
    }
    let rate = edge_dropped as f64 / edge as f64;
    assert!(edge > 1000, "{edge} edge pixels");
    assert!((rate - 0.5).abs() < 0.05, "edge dropout rate {rate}");
    assert_eq!(inner_dropped, 0);
}

#[test]
fn range_limits() {
    let noise = KinectNoise { max_range_m: 2.0, ..KinectNoise::gaussian_only(1) };
    assert_eq!(noisy_wall(3.0, noise).valid_count(), 0);
    let noise = KinectNoise { min_range_m: 0.5, ..KinectNoise::gaussian_only(1) };
    assert_eq!(noisy_wall(0.3, noise).valid_count(), 0);
    assert_eq!(noisy_wall(1.0, noise).valid_count(), 640 * 480);
}

#[test]
fn noise_is_deterministic_from_the_seed() {
    let model = common::model();
    let scene = common::scene("stacking.yaml");
    let objects: Vec<Obj> = scene.objects.iter().map(|o| (o.shape, o.pose.isometry())).collect();
    let q = JointVector::from_row_slice(&[0.0, 0.5, 0.0, 1.5, 0.0, 0.6, 0.0]);
    let person = [cowork_depth::Capsule::new(Point3::new(0.8, 0.6, 0.0), Point3::new(0.8, 0.6, 1.0), 0.15)];
    let run = |seed: u64| {
        let mut r = DepthRenderer::new(&model, &scene).unwrap();
        r.set_noise(Some(KinectNoise::with_seed(seed))).unwrap();
        let mut frames = Vec::new();
        for _ in 0..3 {
            let mut out = DepthImage::default();
            r.render(&q, &objects, &person, &mut out).unwrap();
            frames.push(out);
        }
        frames
    };
    let a = run(42);
    assert_eq!(a, run(42));
    assert_ne!(a, run(43));
    // Successive frames differ (a new draw each frame) but stay close to the clean image.
    assert_ne!(a[0], a[1]);
    // Turning noise off gives the clean image.
    let mut r = DepthRenderer::new(&model, &scene).unwrap();
    let mut clean = DepthImage::default();
    r.render(&q, &objects, &person, &mut clean).unwrap();
    let both: Vec<(f32, f32)> =
        a[0].data.iter().zip(&clean.data).filter(|(n, c)| **n > 0.0 && **c > 0.0).map(|(n, c)| (*n, *c)).collect();
    assert!(both.len() > 640 * 480 / 2);
    let big = both.iter().filter(|(n, c)| (n - c).abs() > 0.1).count();
    assert!(big < both.len() / 1000, "{big} pixels off by more than 10 cm");
}

#[test]
fn bad_noise_parameters_are_rejected() {
    let mut r = wall(1.0);
    let err = r.set_noise(Some(KinectNoise { dropout_probability: 2.0, ..KinectNoise::default() })).unwrap_err();
    assert!(err.to_string().contains("noise.dropout_probability"));
    assert!(r.noise().is_none());
}
