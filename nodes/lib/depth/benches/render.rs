//! Depth rendering cost of one 640×480 frame of the stacking scene (table, four boxes, the LWR
//! at a working pose and a person of 10 capsules reaching over the table).
//!
//! ```text
//! cargo bench -p cowork_depth --bench render
//! ```
//!
//! * `render/parallel/*`: bands on the rayon pool (all cores);
//! * `render/single_thread/*`: `set_parallel(false)`, everything on the calling thread;
//! * `*/clean` without noise, `*/kinect_noise` with the default Kinect model;
//! * `render/robot_only`: fDED's virtual depth (robot layer only), single thread.
//!
//! * `render_cpu/*`: the single-thread cases timed in CPU time of the calling thread
//!   (`/proc/thread-self/schedstat`), so a machine shared with other jobs still gives the cost
//!   of a frame on one core rather than the share of it this process got.
//!
//! frames/s = 1 / time per iteration.

use std::hint::black_box;
use std::path::PathBuf;

use cowork_depth::{Capsule, DepthImage, DepthRenderer, KinectNoise, Layers};
use cowork_robot::{JointVector, RobotModel};
use cowork_sim::Scene;
use criterion::measurement::{Measurement, ValueFormatter};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::Point3;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

fn person() -> Vec<Capsule> {
    let c = |a: [f64; 3], b: [f64; 3], r: f64| Capsule::new(Point3::from(a), Point3::from(b), r);
    vec![
        c([0.55, 1.0, 0.95], [0.55, 1.0, 1.35], 0.16),
        c([0.55, 1.0, 1.65], [0.55, 1.0, 1.65], 0.11),
        c([0.75, 1.0, 1.43], [0.35, 1.0, 1.43], 0.07),
        c([0.35, 1.0, 1.43], [0.4, 0.75, 1.2], 0.05),
        c([0.4, 0.75, 1.2], [0.45, 0.5, 0.8], 0.04),
        c([0.45, 0.5, 0.8], [0.47, 0.43, 0.72], 0.045),
        c([0.75, 1.0, 1.43], [0.75, 1.0, 1.13], 0.05),
        c([0.75, 1.0, 1.13], [0.75, 0.95, 0.87], 0.04),
        c([0.65, 1.0, 0.95], [0.65, 1.0, 0.0], 0.07),
        c([0.45, 1.0, 0.95], [0.45, 1.0, 0.0], 0.07),
    ]
}

/// The stacking scene, the arm at a working pose and a reaching person.
struct Fixture {
    model: RobotModel,
    scene: Scene,
    objects: Vec<(cowork_sim::Shape, nalgebra::Isometry3<f64>)>,
    q: JointVector,
    people: Vec<Capsule>,
}

impl Fixture {
    fn new() -> Self {
        let model = RobotModel::from_urdf_file(repo().join("config/robot/lwr4plus.urdf")).expect("URDF");
        let scene = Scene::from_file(&repo().join("config/scenes/stacking.yaml")).expect("scene");
        let objects = scene.objects.iter().map(|o| (o.shape, o.pose.isometry())).collect();
        let q = JointVector::from_row_slice(&[0.3, 0.6, 0.0, 1.3, 0.0, 0.8, 0.0]);
        Self { model, scene, objects, q, people: person() }
    }

    /// A renderer of the scene on the rayon pool or the calling thread, with or without noise.
    fn renderer(&self, parallel: bool, noise: bool) -> DepthRenderer {
        let mut r = DepthRenderer::new(&self.model, &self.scene).expect("renderer");
        r.set_parallel(parallel);
        if noise {
            r.set_noise(Some(KinectNoise::with_seed(1))).expect("noise");
        }
        r
    }

    fn render(&self, r: &mut DepthRenderer, out: &mut DepthImage) {
        r.render(black_box(&self.q), &self.objects, &self.people, out).expect("render");
    }
}

fn bench(c: &mut Criterion) {
    let f = Fixture::new();
    let mut out = DepthImage::default();

    let mut group = c.benchmark_group("render");
    for parallel in [true, false] {
        for noise in [false, true] {
            let mut r = f.renderer(parallel, noise);
            let name = format!(
                "{}/{}",
                if parallel { "parallel" } else { "single_thread" },
                if noise { "kinect_noise" } else { "clean" }
            );
            group.bench_function(name, |b| b.iter(|| f.render(&mut r, &mut out)));
        }
    }
    let mut r = f.renderer(false, false);
    r.set_layers(Layers::robot_only());
    group.bench_function("robot_only", |b| b.iter(|| f.render(&mut r, &mut out)));
    group.finish();
}

/// CPU time of the calling thread, ns (Linux `/proc/thread-self/schedstat`, first field).
struct ThreadCpuTime;

fn thread_cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|v| v.parse().ok()))
        .unwrap_or(0)
}

struct NsFormatter;

impl ValueFormatter for NsFormatter {
    fn scale_values(&self, typical: f64, values: &mut [f64]) -> &'static str {
        let (factor, unit) = if typical < 1e3 {
            (1.0, "ns")
        } else if typical < 1e6 {
            (1e-3, "µs")
        } else {
            (1e-6, "ms")
        };
        values.iter_mut().for_each(|v| *v *= factor);
        unit
    }
    fn scale_throughputs(&self, _typical: f64, _t: &Throughput, _values: &mut [f64]) -> &'static str {
        "ns"
    }
    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        "ns"
    }
}

impl Measurement for ThreadCpuTime {
    type Intermediate = u64;
    type Value = u64;
    fn start(&self) -> u64 {
        thread_cpu_ns()
    }
    fn end(&self, start: u64) -> u64 {
        thread_cpu_ns().saturating_sub(start)
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, v: &u64) -> f64 {
        *v as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        &NsFormatter
    }
}

fn bench_cpu(c: &mut Criterion<ThreadCpuTime>) {
    let f = Fixture::new();
    let mut out = DepthImage::default();
    let mut group = c.benchmark_group("render_cpu");
    for noise in [false, true] {
        let mut r = f.renderer(false, noise);
        let name = format!("single_thread/{}", if noise { "kinect_noise" } else { "clean" });
        group.bench_function(name, |b| b.iter(|| f.render(&mut r, &mut out)));
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_group! {
    name = cpu;
    config = Criterion::default().with_measurement(ThreadCpuTime);
    targets = bench_cpu
}
criterion_main!(benches, cpu);
