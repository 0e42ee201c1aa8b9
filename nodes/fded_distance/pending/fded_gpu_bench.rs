//! Criterion benchmark of one fDED frame on the wgpu path beside the CPU path, on the same
//! frames: the static scene at T_s = 32 with S = 16 and S = 4, and the worst case at S = 32.
//! On Mesa's lavapipe (a CPU rasteriser behind Vulkan) the GPU numbers say nothing about a real
//! GPU; they show the overhead of the device round trip. Without an adapter only the CPU runs.

use std::hint::black_box;

use cowork_fded::bench::{BenchScene, static_scene, worst_case};
use cowork_fded::gpu::{GpuContext, GpuFded};
use cowork_fded::{Fded, FdedParams};
use cowork_robot::RobotModel;
use criterion::{Criterion, criterion_group, criterion_main};

fn model() -> RobotModel {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../config/robot/lwr4plus.urdf");
    RobotModel::from_urdf_file(path).expect("bundled URDF")
}

fn pair(c: &mut Criterion, model: &RobotModel, scene: &BenchScene, name: &str, params: FdedParams) {
    let frame = scene.frame(0);
    let mut cpu = Fded::new(model, &scene.intrinsics, params.clone()).expect("cpu");
    let mut out = cpu.new_output();
    c.bench_function(&format!("{name}_cpu1"), |b| {
        b.iter(|| {
            cpu.process(black_box(&frame), &mut out).expect("frame");
            black_box(out.closest)
        })
    });
    let Some(ctx) = GpuContext::open().expect("adapter probe") else {
        eprintln!("no wgpu adapter: {name}_wgpu not measured");
        return;
    };
    let adapter = ctx.adapter_name().to_owned();
    let mut gpu = GpuFded::new(ctx, model, &scene.intrinsics, params).expect("gpu");
    let mut out = gpu.new_output();
    c.bench_function(&format!("{name}_wgpu"), |b| {
        b.iter(|| {
            gpu.process(black_box(&frame), &mut out).expect("frame");
            black_box(out.closest)
        })
    });
    eprintln!("{name}_wgpu ran on {adapter}");
}

fn bench(c: &mut Criterion) {
    let model = model();
    let scene = static_scene(&model, 1, 1).expect("scene");
    for step in [16, 4] {
        let params = FdedParams { step_x: step, step_y: step, ..FdedParams::default() };
        pair(c, &model, &scene, &format!("static_ts32_s{step}"), params);
    }
    let (wc, _) = worst_case(&model, 1.0).expect("worst case");
    let params = FdedParams { step_x: 32, step_y: 32, ..FdedParams::default() };
    pair(c, &model, &wc, "worst_case_ts32_s32", params);
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(3));
    targets = bench
}
criterion_main!(benches);
