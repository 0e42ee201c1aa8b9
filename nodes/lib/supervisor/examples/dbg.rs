use cowork_supervisor::*;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let ltm = Ltm::load(std::path::Path::new(&a[1])).unwrap();
    let mut sup = Supervisor::new(ltm, &a[2], SupervisorConfig::default()).unwrap();
    let evs = parse_jsonl(&std::fs::read_to_string(&a[3]).unwrap()).unwrap();
    let until: f64 = a[4].parse().unwrap();
    let rep = runner::run(&mut sup, &evs.into_iter().filter(|e| e.t <= until).collect::<Vec<_>>(), &RunConfig{tail_s:30.0, robot: std::env::var("ROBOT").ok().map(|d| SimRobot{action_duration_s: d.parse().unwrap()}), ..Default::default()}, |_,_,_,_|{});
    for r in &rep.records { println!("{} {:?}", r.t, r.decision); }
    println!("{}", sup.render_text());
    if a.len() > 5 { sup.ltm().save(std::path::Path::new(&a[5])).unwrap(); }
}
