//! CI budget of the fuzzing campaign: every parser target, a fixed number of mutated inputs
//! from a fixed seed, and no input may panic. The table is printed (`--nocapture` shows it);
//! `cowork-fuzz --iterations N` runs longer campaigns.

#[test]
fn no_parser_panics_on_mutated_inputs() {
    let mut targets = cowork_reliability::targets::all().expect("seed corpus loads");
    assert!(targets.len() > 100, "every message type, schema, file format: {} targets", targets.len());
    let reports: Vec<_> = targets.iter_mut().map(|t| cowork_reliability::fuzz(t, 4000, 19)).collect();
    let table = cowork_reliability::table(&reports);
    println!("{table}");
    let inputs: u64 = reports.iter().map(|r| r.inputs).sum();
    assert!(inputs > 50_000, "{inputs} inputs");
    for r in &reports {
        assert!(r.refused > 0, "{}: no mutated input was refused — is the check wired to the parser?", r.name);
    }
    let panics: u64 = reports.iter().map(|r| r.panics).sum();
    assert_eq!(panics, 0, "inputs panicked:\n{table}");
}

/// The harness itself: a parser that panics on some inputs is caught, counted and kept.
#[test]
fn a_panicking_parser_is_reported() {
    let mut t = cowork_reliability::Target {
        name: "panics on a zero byte".into(),
        family: "self-test",
        seeds: vec![b"abcdef".to_vec()],
        dictionary: &[],
        max_len: 64,
        cost: 1,
        check: Box::new(|b| {
            assert!(!b.contains(&0), "zero byte");
            cowork_reliability::Verdict::Accepted
        }),
    };
    let r = cowork_reliability::fuzz(&mut t, 2000, 3);
    assert!(r.panics > 0 && r.accepted > 0);
    assert!(r.findings[0].message.contains("zero byte"), "{}", r.findings[0].message);
    assert!(r.findings[0].input.contains(&0));
}
