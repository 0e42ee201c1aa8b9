//! The per-step evaluation paths (GMR query, GMR-DS velocity, C-GMR control step) must not touch
//! the heap: counted with a wrapping global allocator.


use cowork_motion::cgmr::Components;
use cowork_motion::{Cgmr, CgmrConfig, Demonstration, DsPolicy, EmConfig, FirstOrderDs};

#[global_allocator]
static GLOBAL: cowork_testkit::CountingAllocator = cowork_testkit::CountingAllocator;

#[test]
fn evaluation_paths_do_not_allocate() {
    let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.01).collect();
    let pos = t
        .iter()
        .flat_map(|t| {
            let s = 1.0 - t / 1.99;
            [3.0 * s * (2.0 * t).cos(), 3.0 * s * (2.0 * t).sin()]
        })
        .collect();
    let demo = Demonstration::new(2, t, pos, None).expect("demo");
    let m = Cgmr::fit(
        &[demo],
        Components::Fixed(6),
        &EmConfig::default(),
        1,
        &CgmrConfig::default(),
    )
    .expect("fit");
    let mut runner = m.runner(None).expect("runner");
    runner.reset(&[1.0, 1.0]).expect("reset");
    let mut v = [0.0; 2];
    let mut x = [2.0, -1.0];
    let before = cowork_testkit::allocations();
    for _ in 0..1000 {
        m.ds.velocity(&x, &mut v).expect("gmr");
        m.ds.gmr.predict(&x, &mut v).expect("predict");
        runner.step(&x, 0.001, &mut v).expect("step");
        x[0] += 0.001 * v[0];
        x[1] += 0.001 * v[1];
    }
    let after = cowork_testkit::allocations();
    assert_eq!(
        after - before,
        0,
        "{} allocations in 1000 steps",
        after - before
    );
}
