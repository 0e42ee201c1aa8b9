//! Property tests: releasers respected, exclusive resources never granted twice, LTM
//! save → load → save byte-identical, random event streams never panic.

mod common;

use std::collections::HashSet;

use common::*;
use cowork_supervisor::schema::{Arg, Clause, Cond, Document, Entry, Item, Literal, Pos, Schema, Seg, Term};
use cowork_supervisor::{
    ActionKind, Decision, Event, GripperState, Ltm, ObjectObs, RunConfig, SimRobot, Supervisor, SupervisorConfig, TimedEvent,
    runner,
};
use proptest::prelude::*;

const OBJECTS: [&str; 9] = ["water", "coffee", "spoon", "cup", "tea", "tomato", "oil", "pizza", "bogus"];
const SPEECH: [&str; 12] = [
    "teach", "done", "stop", "repeat", "gripper open", "gripper close", "human add(water)", "human add(left,tomato)",
    "human nonsense(", "make me a sandwich", "", "human",
];

fn object_obs() -> impl Strategy<Value = ObjectObs> {
    (
        prop::sample::select(&OBJECTS[..]),
        prop_oneof![Just(None), (0.0f64..2.5).prop_map(Some), Just(Some(f64::NAN)), Just(Some(f64::INFINITY))],
        any::<bool>(),
        prop::sample::select(vec![None, Some("left"), Some("right"), Some("central"), Some("nowhere")]),
        prop::option::of((prop::sample::select(vec!["left", "right", "middle"]), 0.0f64..2.5)),
    )
        .prop_map(|(name, distance, visible, area, arm_d)| ObjectObs {
            name: name.into(),
            distance,
            arm_distances: arm_d.into_iter().map(|(a, d)| (a.to_owned(), d)).collect(),
            visible,
            area: area.map(str::to_owned),
        })
}

fn arm() -> impl Strategy<Value = Option<String>> {
    prop::sample::select(vec![None, Some("left"), Some("right"), Some("elbow")]).prop_map(|a| a.map(str::to_owned))
}

fn label() -> impl Strategy<Value = String> {
    prop_oneof![
        (prop::sample::select(vec!["foa", "noa", "close", "open", "lfoa", "rnoa"]), 1u32..40, prop::sample::select(&OBJECTS[..]))
            .prop_map(|(k, n, o)| format!("{k}{n}({o})")),
        Just("Bad(Label".to_owned()),
        Just("X".to_owned()),
        Just(String::new()),
    ]
}

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        prop::collection::vec(object_obs(), 1..4).prop_map(|objects| Event::Objects { objects }),
        (arm(), any::<bool>(), prop::option::of(prop::sample::select(&OBJECTS[..]))).prop_map(|(arm, c, o)| Event::Gripper {
            arm,
            state: if c { GripperState::Close } else { GripperState::Open },
            object: o.map(str::to_owned),
        }),
        (arm(), label()).prop_map(|(arm, label)| Event::ActionDone { arm, label }),
        (arm(), label()).prop_map(|(arm, label)| Event::ActionFailed { arm, label, reason: "slipped".into() }),
        (arm(), label(), prop::sample::select(vec![ActionKind::Foa, ActionKind::Noa, ActionKind::Gripper]), prop::option::of(prop::sample::select(&OBJECTS[..])))
            .prop_map(|(arm, label, kind, o)| Event::Segment { arm, label, kind, object: o.map(str::to_owned) }),
        prop::sample::select(&SPEECH[..]).prop_map(|t| Event::Speech { text: t.to_owned() }),
        (prop::sample::select(vec!["water.added", "coffee.added", "hand.free", "water.taken", "tomato.used", "a..b", ""]), any::<bool>())
            .prop_map(|(v, value)| Event::State { var: v.to_owned(), value }),
    ]
}

fn script() -> impl Strategy<Value = Vec<TimedEvent>> {
    prop::collection::vec((0.0f64..20.0, event()), 0..60).prop_map(|mut v| {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v.into_iter().map(|(t, event)| TimedEvent { t, event }).collect()
    })
}

/// Runs a random script and checks the invariants at every tick.
fn check_invariants(ltm: Ltm, task: &str, events: &[TimedEvent], duration: f64) {
    let mut sup = Supervisor::new(ltm, task, SupervisorConfig::default()).expect("task");
    let cfg = RunConfig { rate_hz: 50.0, tail_s: 5.0, robot: Some(SimRobot { action_duration_s: duration }) };
    runner::run(&mut sup, events, &cfg, |s, _, _, decisions| {
        for d in decisions {
            if let Decision::Action { label, .. } = d {
                let n = s.wm().iter().find(|n| &n.label == label && !n.accomplished).expect("commanded node is allocated");
                assert!(s.state().eval(&n.releaser), "{label} commanded with false releaser {}", n.releaser);
                for a in s.wm().ancestors(n.id) {
                    let an = s.wm().get(a).expect("ancestor");
                    assert!(an.enabled && !an.human, "{label} commanded below disabled {}", an.label);
                }
            }
        }
        let grants = s.grants();
        let mut seen = HashSet::new();
        for g in &grants {
            assert!(seen.insert(g.resource.clone()), "{} granted twice: {grants:?}", g.resource);
        }
        let running: Vec<&str> = (0..s.state().n_arms()).filter_map(|a| s.running(a)).collect();
        let distinct: HashSet<&&str> = running.iter().collect();
        assert_eq!(distinct.len(), running.len(), "one behaviour on two arms: {running:?}");
        for a in 0..s.state().n_arms() {
            if let Some(l) = s.running(a) {
                let n = s.wm().iter().find(|n| n.label == l).expect("running node");
                let central = n.action_object.as_deref().and_then(|o| s.state().area(o)) == Some("central");
                if central {
                    assert_eq!(s.central_holder(), Some(s.state().arm_names()[a].as_str()), "central used without grant");
                }
            }
        }
    });
}

fn coffee_ltm() -> Ltm {
    learned(ltm("kitchen.schema"), "prepareCoffee", "coffee_teach.jsonl")
}

fn pizza_ltm() -> Ltm {
    let l = learned(ltm("pizza.schema"), "pizza", "pizza_teach_left.jsonl");
    learned(l, "pizza", "pizza_teach_right.jsonl")
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn coffee_random_streams_keep_invariants(events in script(), d in 0.05f64..1.0) {
        check_invariants(coffee_ltm(), "prepareCoffee", &events, d);
    }

    #[test]
    fn pizza_random_streams_keep_invariants(events in script(), d in 0.05f64..1.0) {
        check_invariants(pizza_ltm(), "pizza", &events, d);
    }

    #[test]
    fn untaught_random_streams_never_panic_and_ltm_round_trips(events in script()) {
        // Random teaching on the initial LTM: whatever gets learned saves and reloads exactly.
        let mut sup = Supervisor::new(ltm("kitchen.schema"), "prepareCoffee", SupervisorConfig::default()).expect("task");
        runner::run(&mut sup, &events, &RunConfig { rate_hz: 20.0, tail_s: 1.0, robot: None }, |_, _, _, _| {});
        let dir = tempfile::tempdir().expect("tmp");
        let p = dir.path().join("a.schema");
        sup.ltm().save(&p).expect("save");
        let first = std::fs::read(&p).expect("read");
        let back = Ltm::load(&p).expect("reload learned LTM");
        back.save(&p).expect("save again");
        prop_assert_eq!(first, std::fs::read(&p).expect("read"));
        prop_assert_eq!(&back, sup.ltm());
    }

    #[test]
    fn document_print_parse_print_identical(doc in document()) {
        let text = doc.print();
        let back = Document::parse(&text).map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
        prop_assert_eq!(&back, &doc);
        prop_assert_eq!(back.print(), text);
    }
}

fn name() -> impl Strategy<Value = String> {
    "[a-z][a-zA-Z0-9_]{0,6}".prop_filter("not the keyword true", |s| s != "true")
}

fn var() -> impl Strategy<Value = String> {
    "[A-Z_][a-zA-Z0-9_]{0,4}"
}

fn term() -> impl Strategy<Value = Term> {
    let leaf = name().prop_map(Term::atom);
    leaf.prop_recursive(2, 8, 3, |inner| {
        (name(), prop::collection::vec(prop_oneof![var().prop_map(Arg::Var), inner.prop_map(Arg::Term)], 1..4))
            .prop_map(|(functor, args)| Term { functor, args })
    })
}

fn cond() -> impl Strategy<Value = Cond> {
    let seg = prop_oneof![name().prop_map(Seg::Atom), var().prop_map(Seg::Var)];
    let lit = (any::<bool>(), prop::collection::vec(seg, 1..4))
        .prop_filter("bare true", |(_, p)| !(p.len() == 1 && p[0] == Seg::Atom("true".into())))
        .prop_map(|(negated, path)| Literal { negated, path, pos: Pos::default() });
    prop::collection::vec(lit, 0..3).prop_map(|literals| Cond { literals })
}

fn document() -> impl Strategy<Value = Document> {
    let entry = (term(), cond()).prop_map(|(term, releaser)| Entry { term, releaser, pos: Pos::default() });
    let kind = prop::option::of(prop::sample::select(vec![ActionKind::Foa, ActionKind::Noa, ActionKind::Gripper]));
    let schema = (term(), prop::collection::vec(entry, 0..4), cond(), kind)
        .prop_map(|(head, list, post, kind)| Clause::Schema(Schema { head, list, post, kind, pos: Pos::default() }));
    let clause = prop_oneof![
        4 => schema,
        1 => prop::collection::vec(name(), 0..4).prop_map(|names| Clause::Arms { names, pos: Pos::default() }),
        1 => prop::collection::vec(name(), 0..4).prop_map(|names| Clause::Objects { names, pos: Pos::default() }),
    ];
    let comment = "[a-z][a-z %.()]{0,20}[a-z]|";
    let item = (prop::collection::vec(comment, 0..2), clause).prop_map(|(comments, clause)| Item { comments, clause });
    (prop::collection::vec(item, 0..6), prop::collection::vec(comment, 0..2))
        .prop_map(|(items, trailing_comments)| Document { items, trailing_comments })
}

#[test]
fn learned_ltms_save_load_save_byte_identical() {
    let dir = tempfile::tempdir().expect("tmp");
    for (name, l) in [("coffee", coffee_ltm()), ("pizza", pizza_ltm()), ("kitchen", ltm("kitchen.schema"))] {
        let a = dir.path().join(format!("{name}-a.schema"));
        let b = dir.path().join(format!("{name}-b.schema"));
        l.save(&a).expect("save");
        Ltm::load(&a).expect("load").save(&b).expect("save again");
        assert_eq!(std::fs::read(&a).expect("a"), std::fs::read(&b).expect("b"), "{name}");
    }
    // The shipped files are already canonical: learning only appends to them.
    for f in ["kitchen.schema", "pizza.schema"] {
        let text = std::fs::read_to_string(task_file(f)).expect("read");
        assert_eq!(ltm(f).to_text(), text, "{f} is not in canonical form");
    }
}
