//! Criterion benchmarks of the motion library: EM fit, GMR query, C-GMR control step, DTW, DHB,
//! DMP learning + rollout. Data are synthetic LASA-like spirals (no dataset needed).

use std::hint::black_box;
use std::time::Duration;

use cowork_motion::cgmr::{Components, fit_gmr_ds};
use cowork_motion::dhb::Dhb;
use cowork_motion::dmp::{Dmp, DmpConfig};
use cowork_motion::dtw::dtw_distance;
use cowork_motion::{Cgmr, CgmrConfig, Demonstration, DsPolicy, EmConfig, FirstOrderDs, Gmm};
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;

/// Seven 2-D spiral demonstrations of 1000 samples ending at the origin (like a LASA motion).
fn demos() -> Vec<Demonstration> {
    (0..7)
        .map(|k| {
            let t: Vec<f64> = (0..1000).map(|i| i as f64 * 0.003).collect();
            let r0 = 40.0 + 2.0 * k as f64;
            let pos = t
                .iter()
                .flat_map(|t| {
                    let s = t / 2.997;
                    let r = r0 * (1.0 - s);
                    [r * (4.0 * s + 0.1 * k as f64).cos(), r * (4.0 * s).sin()]
                })
                .collect();
            Demonstration::new(2, t, pos, None).expect("demo")
        })
        .collect()
}

fn benches(c: &mut Criterion) {
    let demos = demos();
    let em = EmConfig {
        tol: 1e-3,
        max_iter: 100,
        ..EmConfig::default()
    };
    let target = cowork_motion::demo::mean_end_point(&demos).expect("target");
    let data = cowork_motion::cgmr::ds_training_data(&demos, &target, 20).expect("data");
    c.bench_function("gmm_em_fit_350x4_k8", |b| {
        b.iter(|| Gmm::fit(black_box(&data), 4, 8, &em).expect("fit"))
    });
    c.bench_function("gmm_em_bic_350x4_k1to10", |b| {
        b.iter(|| Gmm::fit_bic(black_box(&data), 4, 10, &em).expect("fit"))
    });
    let (ds, _) = fit_gmr_ds(&demos, Components::Fixed(8), &em, 20).expect("gmr");
    let mut v = [0.0; 2];
    c.bench_function("gmr_ds_velocity_k8_2d", |b| {
        b.iter(|| ds.velocity(black_box(&[10.0, -5.0]), &mut v).expect("v"))
    });
    let cgmr = Cgmr::from_gmr_ds(ds.clone(), &demos, &CgmrConfig::default()).expect("cgmr");
    c.bench_function("cgmr_extras_k8_7000pts", |b| {
        b.iter(|| {
            Cgmr::from_gmr_ds(ds.clone(), black_box(&demos), &CgmrConfig::default()).expect("cgmr")
        })
    });
    let mut runner = cgmr.runner(None).expect("runner");
    runner.reset(&[10.0, -5.0]).expect("reset");
    c.bench_function("cgmr_step_k8_2d", |b| {
        b.iter(|| {
            runner
                .step(black_box(&[10.0, -5.0]), 0.002, &mut v)
                .expect("step")
        })
    });
    let a = &demos[0].pos;
    let bb = &demos[1].pos;
    c.bench_function("dtw_distance_1000x1000_2d", |b| {
        b.iter(|| dtw_distance(black_box(a), black_box(bb), 2, None).expect("dtw"))
    });
    let tw: (Vec<Vector3<f64>>, Vec<Vector3<f64>>) = (0..1000)
        .map(|i| {
            let t = i as f64 * 0.004;
            (
                Vector3::new(0.01 * t.exp(), 5.0 + 1.5 * t.sin(), t.cos()),
                Vector3::new(0.5 * t.sin(), t.cos(), 0.1 * t),
            )
        })
        .unzip();
    c.bench_function("dhb_from_twists_1000", |b| {
        b.iter(|| Dhb::from_twists(black_box(&tw.0), black_box(&tw.1)).expect("dhb"))
    });
    c.bench_function("ds_invariants_1000", |b| {
        b.iter(|| {
            cowork_motion::screw::ds_invariants(black_box(&tw.0), black_box(&tw.1), 0.004)
                .expect("ds")
        })
    });
    c.bench_function("efs_signal_1000", |b| {
        b.iter(|| cowork_motion::invariants::efs_signal(black_box(&tw.0), 0.004).expect("efs"))
    });
    let d0 = &demos[0];
    c.bench_function("dmp_fit_rollout_1000x2_30basis", |b| {
        b.iter(|| {
            let dmp = Dmp::fit(black_box(d0), &DmpConfig::default()).expect("dmp");
            dmp.rollout(None, None, 1.0, 0.003, 999, 0.0)
                .expect("rollout")
        })
    });
}

criterion_group! {
    name = motion;
    config = Criterion::default().sample_size(20).measurement_time(Duration::from_secs(2)).warm_up_time(Duration::from_millis(500));
    targets = benches
}
criterion_main!(motion);
