//! One supervisor tick on the learned prepare-coffee task (27-node WM with 24 actions).
//! `steady`: nothing changed since the last tick (the common case at 100 Hz).
//! `replan`: the bottle disappears / reappears before each tick, so the winner changes.

use std::path::PathBuf;

use cowork_supervisor::{Event, Ltm, ObjectObs, RunConfig, Supervisor, SupervisorConfig, parse_jsonl, runner};
use criterion::{Criterion, criterion_group, criterion_main};

fn learned_coffee() -> Ltm {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let ltm = Ltm::load(&root.join("../../../config/tasks/kitchen.schema")).expect("kitchen.schema");
    let script = std::fs::read_to_string(root.join("tests/data/coffee_teach.jsonl")).expect("script");
    let mut sup = Supervisor::new(ltm, "prepareCoffee", SupervisorConfig::default()).expect("task");
    runner::run(&mut sup, &parse_jsonl(&script).expect("valid"), &RunConfig::default(), |_, _, _, _| {});
    sup.ltm().clone()
}

fn objects(water_visible: bool) -> Event {
    let o = |name: &str, d: f64, visible: bool| ObjectObs {
        name: name.into(),
        distance: Some(d),
        arm_distances: Default::default(),
        visible,
        area: None,
    };
    Event::Objects { objects: vec![o("water", 0.4, water_visible), o("coffee", 0.8, true), o("spoon", 1.2, true), o("cup", 0.8, true)] }
}

fn bench(c: &mut Criterion) {
    let ltm = learned_coffee();
    let mut sup = Supervisor::new(ltm.clone(), "prepareCoffee", SupervisorConfig::default()).expect("task");
    sup.handle(&objects(true), 0.0);
    let mut out = Vec::with_capacity(64);
    sup.tick(0.0, &mut out);
    let mut t = 0.0;
    c.bench_function("supervisor_tick_coffee_steady", |b| {
        b.iter(|| {
            t += 0.01;
            out.clear();
            sup.tick(t, &mut out);
        })
    });
    let mut sup = Supervisor::new(ltm, "prepareCoffee", SupervisorConfig::default()).expect("task");
    let mut visible = true;
    c.bench_function("supervisor_tick_coffee_replan", |b| {
        b.iter(|| {
            t += 0.01;
            visible = !visible;
            sup.handle(&objects(visible), t);
            out.clear();
            sup.tick(t, &mut out);
            assert!(!out.is_empty());
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
