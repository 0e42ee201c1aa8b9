//! Criterion benchmark of one fDED frame at the thesis parameter set (T_s = 32, S = 16) on the
//! synthetic static scene, one thread and two, Flacco et al. on the same frame (robot removal
//! included, as for fDED), plus the worst case at S = 32.

use std::hint::black_box;

use cowork_fded::baseline::{Flacco, FlaccoParams};
use cowork_fded::bench::{static_scene, worst_case};
use cowork_fded::{Fded, FdedParams};
use cowork_robot::RobotModel;
use criterion::{Criterion, criterion_group, criterion_main};

fn model() -> RobotModel {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../config/robot/lwr4plus.urdf");
    RobotModel::from_urdf_file(path).expect("bundled URDF")
}

fn bench(c: &mut Criterion) {
    let model = model();
    let scene = static_scene(&model, 1, 1).expect("scene");
    for threads in [1, 2] {
        let params = FdedParams { threads, ..FdedParams::default() };
        let mut f = Fded::new(&model, &scene.intrinsics, params).expect("fded");
        let mut out = f.new_output();
        let frame = scene.frame(0);
        c.bench_function(&format!("fded_static_ts32_s16_threads{threads}"), |b| {
            b.iter(|| {
                f.process(black_box(&frame), &mut out).expect("frame");
                black_box(out.closest)
            })
        });
    }
    {
        let mut f = Fded::new(&model, &scene.intrinsics, FdedParams::default()).expect("fded");
        let mut fl = Flacco::new(&model, FlaccoParams::default());
        let mut per_link = Vec::new();
        let frame = scene.frame(0);
        c.bench_function("flacco_static_threads1", |b| {
            b.iter(|| {
                fl.distances(&mut f, black_box(&frame), &mut per_link).expect("frame");
                black_box(per_link.len())
            })
        });
    }
    let (wc, _) = worst_case(&model, 1.0).expect("worst case");
    let params = FdedParams { step_x: 32, step_y: 32, ..FdedParams::default() };
    let mut f = Fded::new(&model, &wc.intrinsics, params).expect("fded");
    let mut out = f.new_output();
    let frame = wc.frame(0);
    c.bench_function("fded_worst_case_ts32_s32_threads1", |b| {
        b.iter(|| {
            f.process(black_box(&frame), &mut out).expect("frame");
            black_box(out.closest)
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
