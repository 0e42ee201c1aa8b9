//! `cowork`: one command line for the whole stack, usable without a ROS installation.

use anyhow::Result;
use clap::{Parser, Subcommand};

mod cmd;

/// Counts allocations per thread so `cowork bench control` can show the 1 kHz step allocates
/// nothing; only with the `alloc-count` feature, the shipped binary uses the system allocator.
#[cfg(feature = "alloc-count")]
#[global_allocator]
static ALLOCATOR: cowork_testkit::CountingAllocator = cowork_testkit::CountingAllocator;

/// cowork — teach a robot arm structured tasks by showing them, and run them beside people.
#[derive(Debug, Parser)]
#[command(version, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Robot model: forward kinematics and Jacobians from the URDF.
    #[command(subcommand)]
    Robot(cmd::robot::RobotCommand),
    /// Publish a speech command on /speech_command (teach, done, stop, repeat, ...).
    Say(cmd::say::SayArgs),
    /// Inspect live topics over DDS (no ROS installation needed).
    #[command(subcommand)]
    Topic(cmd::topic::TopicCommand),
    /// DDS domains of this machine's graphs: run a command on a free one, list who holds which.
    #[command(subcommand)]
    Domain(cmd::domain::DomainCommand),
    /// ROS 2 nodes on the domain (`cowork node list`).
    #[command(subcommand)]
    Node(NodeCommand),
    /// Robot manager's primitive database: list, show, rm; learn from a kinesthetic bag.
    #[command(subcommand)]
    Primitives(cmd::primitives::PrimitivesCommand),
    /// Attentional supervisor: run on an event script, show the working memory.
    #[command(subcommand)]
    Supervisor(cmd::supervisor::SupervisorCommand),
    /// Motion primitives: fit DMP / GMR / C-GMR / HMM from CSV demonstrations, roll them out.
    #[command(subcommand)]
    Learn(cmd::learn::LearnCommand),
    /// MCAP bags (ROS 2 profile): record, play, info, synth, bench.
    #[command(subcommand)]
    Bag(cmd::bag::BagCommand),
    /// fDED robot–obstacle distances in depth space, frame by frame from a bag.
    #[command(subcommand)]
    Fded(cmd::fded::FdedCommand),
    /// Simulated DS-controller experiments of the thesis (Fig. 5.3–5.7, Sec. 5.1.3); prints JSON.
    Scenario(cmd::scenario::ScenarioArgs),
    /// The human observer offline on a bag: recognised gestures and every /human/state as CSV.
    Observe(cmd::observe::ObserveArgs),
    /// Kinesthetic teaching in the graph: replay demonstration bags, keep the learned LTM and primitives.
    Teach(cmd::teach::TeachArgs),
    /// Thesis experiments in the whole graph (node processes over DDS, sim clock); JSON, bags.
    Experiment(cmd::experiment::ExperimentArgs),
    /// Foxglove WebSocket view of the live graph (ws://localhost:8765): every topic, ros2msg + cdr.
    Bridge(cmd::bridge::BridgeArgs),
    /// Report (index.html + PNG plots) of recorded experiment runs.
    Report(cmd::report::ReportArgs),
    /// Benchmarks that print tables.
    #[command(subcommand)]
    Bench(BenchCommand),
    /// DDS Security keystores (SROS2 layout): create, enclave.
    #[command(subcommand)]
    Keystore(cmd::keystore::KeystoreCommand),
}

#[derive(Debug, Subcommand)]
enum NodeCommand {
    /// The nodes seen on the domain, one per line (as `ros2 node list`).
    List {
        /// How long to listen for discovery, s.
        #[arg(long, default_value_t = 2.0)]
        wait: f64,
    },
}

#[derive(Debug, Subcommand)]
enum BenchCommand {
    /// GMR vs C-GMR on the LASA handwriting set (data exported by tests/crosscheck/lasa_export.py).
    Lasa(cmd::bench_lasa::BenchLasaArgs),
    /// fDED Tables 5.1/5.2 vs brute force and Flacco et al.
    Fded(cmd::fded::BenchFdedArgs),
    /// DS controller step time and allocations.
    Control(cmd::bench_control::BenchControlArgs),
    /// Gesture recognition on unseen people (30 and 120 Hz), false gestures, hand Kalman RMSE.
    Gestures(cmd::observe::BenchGesturesArgs),
}

fn main() -> std::process::ExitCode {
    cowork_ros::init_logging();
    // `config/...` paths name the bundled config directory from anywhere (cowork_ros::config).
    let cli = Cli::parse_from(cowork_ros::config::resolve_args(std::env::args_os()));
    if let Command::Domain(c) = cli.command {
        // `domain run` exits with its command's status.
        return cmd::domain::run(c).unwrap_or_else(|e| {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        });
    }
    if prints_for_a_pipe(&cli.command) {
        die_quietly_on_a_closed_pipe();
    }
    // One line `error: ...` with the context chain; a backtrace only with RUST_BACKTRACE=1.
    cowork_ros::exit_code(run(cli.command))
}

/// Commands whose output is read through pipes (`cowork robot fk … | head -1`): they end
/// quietly when the reader goes, as `ls` or `ros2 topic echo` do. Not the long-running ones
/// that hold a graph, sockets or children (experiment, teach, bridge, bag record/play), which
/// must never be killed by a signal meant for a printout.
fn prints_for_a_pipe(command: &Command) -> bool {
    use cmd::bag::BagCommand;
    !matches!(
        command,
        Command::Experiment(_)
            | Command::Teach(_)
            | Command::Bridge(_)
            | Command::Bag(BagCommand::Record(_) | BagCommand::Play(_))
            | Command::Domain(_)
    )
}

/// Rust ignores SIGPIPE, so `println!` to a closed pipe panics (exit 101 and a panic message);
/// the default action ends the process silently instead, as every Unix tool does.
#[allow(unsafe_code)]
fn die_quietly_on_a_closed_pipe() {
    use nix::sys::signal::{SigHandler, Signal, signal};
    // SAFETY: SIG_DFL installs no handler code; called before any thread is started.
    if let Err(e) = unsafe { signal(Signal::SIGPIPE, SigHandler::SigDfl) } {
        tracing::debug!("SIGPIPE left ignored: {e}");
    }
}

fn run(command: Command) -> Result<()> {
    match command {
        Command::Robot(c) => cmd::robot::run(c),
        Command::Say(a) => cmd::say::run(a),
        Command::Topic(c) => cmd::topic::run(c),
        Command::Node(NodeCommand::List { wait }) => cmd::topic::node_list(wait),
        Command::Supervisor(c) => cmd::supervisor::run(c),
        Command::Primitives(c) => cmd::primitives::run(c),
        Command::Learn(c) => cmd::learn::run(c),
        Command::Bag(c) => cmd::bag::run(c),
        Command::Fded(c) => cmd::fded::run(c),
        Command::Scenario(a) => cmd::scenario::run(a),
        Command::Experiment(a) => cmd::experiment::run(a),
        Command::Teach(a) => cmd::teach::run(a),
        Command::Report(a) => cmd::report::run(a),
        Command::Bridge(a) => cmd::bridge::run(&a),
        Command::Bench(BenchCommand::Lasa(a)) => cmd::bench_lasa::run(a),
        Command::Bench(BenchCommand::Fded(a)) => cmd::fded::bench(a),
        Command::Bench(BenchCommand::Control(a)) => cmd::bench_control::run(a),
        Command::Bench(BenchCommand::Gestures(a)) => cmd::observe::bench(a),
        Command::Observe(a) => cmd::observe::observe(a),
        Command::Keystore(c) => cmd::keystore::run(c),
        Command::Domain(_) => unreachable!("handled in main"),
    }
}
