//! A graph refuses to go on when a participant it did not start writes on its domain: here a
//! second `lwr_sim` (another graph's, or one started by hand) on the graph's leased domain. Its
//! own nodes, started a moment before, are never taken for strangers.

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use cowork_graph_tests::{Processes, config_set, node_bin_dir, private_domain, repo_root};

/// A `lwr_sim` that no graph of ours started, on `domain`, with `graph_id` as its graph.
fn foreign_sim(bins: &std::path::Path, params: &str, domain: u16, graph_id: Option<&str>) -> Child {
    let mut cmd = Command::new(bins.join("lwr_sim"));
    cmd.args(["--scene", "config/scenes/stacking.yaml", "--params", params, "--rate", "1", "--duration", "60"])
        .current_dir(repo_root())
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env_remove("COWORK_GRAPH_ID")
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    if let Some(id) = graph_id {
        cmd.env("COWORK_GRAPH_ID", id);
    }
    cmd.spawn().expect("start the foreign lwr_sim")
}

/// The graph's check, every 0.1 s for at most `limit_s`: the first error.
fn first_error(g: &mut Processes, limit_s: f64) -> Option<String> {
    let until = Instant::now() + Duration::from_secs_f64(limit_s);
    while Instant::now() < until {
        if let Err(e) = g.check_alive() {
            return Some(e);
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    None
}

#[test]
fn a_foreign_participant_on_the_graphs_domain_is_named_and_refused() {
    let bins = node_bin_dir(&["lwr_sim"]);
    let dir = tempfile::tempdir().expect("tempdir");
    // No camera: nothing here reads it, and rendering would load the machine.
    let params = config_set("lwr_sim.yaml", &[("enabled", "false")], &dir.path().join("lwr_sim.yaml"));
    let params = params.display().to_string();
    let domain = private_domain();
    let mut g = Processes::new(&domain, &bins, &dir.path().join("logs"));
    g.spawn("lwr_sim", &["--scene", "config/scenes/stacking.yaml", "--params", &params, "--rate", "1", "--duration", "60"]);
    // Our own node for the whole grace period and more: never a stranger.
    let own = first_error(&mut g, cowork_ros::graph::STRANGER_GRACE_S + 3.0);
    assert!(own.is_none(), "the graph's own node was refused: {own:?}");

    // A lwr_sim started by hand on the same domain: it writes /joint_states, /clock, ...
    let mut stranger = foreign_sim(&bins, &params, domain.id(), None);
    let t = Instant::now();
    let e = first_error(&mut g, cowork_ros::graph::STRANGER_GRACE_S + 15.0);
    let _ = stranger.kill();
    let _ = stranger.wait();
    let e = e.expect("the stranger was not noticed");
    assert!(
        e.contains(&format!("DDS domain {}", domain.id()))
            && e.contains("node /lwr_sim that no cowork graph started")
            && e.contains("/joint_states")
            && e.contains("refuses"),
        "{e}"
    );
    eprintln!("noticed after {:.1} s: {e}", t.elapsed().as_secs_f64());

    // Another cowork graph's node (its own graph id) is named with that graph.
    let mut g = Processes::new(&domain, &bins, &dir.path().join("logs2"));
    g.spawn("lwr_sim", &["--scene", "config/scenes/stacking.yaml", "--params", &params, "--rate", "1", "--duration", "60"]);
    let mut other = foreign_sim(&bins, &params, domain.id(), Some("0123456789ab"));
    let e = first_error(&mut g, cowork_ros::graph::STRANGER_GRACE_S + 15.0);
    let _ = other.kill();
    let _ = other.wait();
    let e = e.expect("the other graph's node was not noticed");
    assert!(e.contains("node /lwr_sim of another cowork graph (0123456789ab)"), "{e}");
    g.stop();
}
