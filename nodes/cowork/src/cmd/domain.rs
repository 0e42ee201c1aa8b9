//! `cowork domain`: the DDS domains of this machine's graphs (see `cowork_ros::domain`).
//!
//! `cowork domain run -- CMD...` runs CMD (e.g. `launch_scripts/graph.sh`) with `ROS_DOMAIN_ID`
//! set to a domain no other graph on this machine has, held until CMD ends; `cowork domain list`
//! shows who holds which.

use std::ffi::OsString;
use std::os::unix::process::CommandExt as _;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result};
use clap::Subcommand;
use cowork_ros::domain::{self, DomainLease};

/// `cowork domain ...`.
#[derive(Debug, Subcommand)]
pub enum DomainCommand {
    /// Run a command on a DDS domain no other graph on this machine has: ROS_DOMAIN_ID is set for
    /// it and the domain is held until it ends.
    Run {
        /// This domain (refused, naming its holder, when another graph has it); default: a free one.
        #[arg(long)]
        domain: Option<u16>,
        /// Who holds the domain, as `cowork domain list` shows it; default: the command.
        #[arg(long)]
        what: Option<String>,
        /// The command and its arguments.
        #[arg(required = true, trailing_var_arg = true, allow_hyphen_values = true)]
        command: Vec<OsString>,
    },
    /// The domains that graphs on this machine hold, and who holds them.
    List,
}

/// Runs `cowork domain`; `run` exits with the command's status.
pub fn run(command: DomainCommand) -> Result<ExitCode> {
    match command {
        DomainCommand::List => {
            let held = domain::held();
            if held.is_empty() {
                println!("no DDS domain is held on this machine (locks in {})", domain::lock_dir().display());
            }
            for h in held {
                match h.holder {
                    Some(who) => println!("{:>3}  {who}", h.domain),
                    None => println!("{:>3}  (no lease: cowork nodes started by hand or by ros2 launch)", h.domain),
                }
            }
            Ok(ExitCode::SUCCESS)
        }
        DomainCommand::Run { domain, what, command } => run_on_domain(domain, what, &command),
    }
}

fn run_on_domain(domain: Option<u16>, what: Option<String>, command: &[OsString]) -> Result<ExitCode> {
    let what = what.unwrap_or_else(|| command.iter().map(|a| a.to_string_lossy()).collect::<Vec<_>>().join(" "));
    let lease = match domain {
        Some(d) => DomainLease::take(d, &what)?,
        None => DomainLease::acquire(&what)?,
    };
    cowork_ros::shutdown::install();
    let (program, args) = command.split_first().context("no command to run")?;
    // The command runs in its own process group: a Ctrl-C (or a SIGTERM to this process) reaches
    // it once, as SIGINT from here, then SIGTERM if it still runs 10 s later.
    let mut child = std::process::Command::new(program)
        .args(args)
        .env("ROS_DOMAIN_ID", lease.id().to_string())
        // Scripts run under a lease do not lease again (graph.sh inside walkthrough.sh).
        .env("COWORK_DOMAIN_HELD", lease.id().to_string())
        .process_group(0)
        .spawn()
        .with_context(|| format!("cannot start {}", program.to_string_lossy()))?;
    let pid = i32::try_from(child.id()).ok().map(nix::unistd::Pid::from_raw);
    let send = |sig| {
        if let Some(pid) = pid {
            let _ = nix::sys::signal::kill(pid, sig);
        }
    };
    let mut asked: Option<Instant> = None;
    let mut termed = false;
    let status = loop {
        if let Some(status) = child.try_wait().context("waiting for the command")? {
            break status;
        }
        if asked.is_none() && cowork_ros::shutdown::requested() {
            asked = Some(Instant::now());
            send(nix::sys::signal::Signal::SIGINT);
        }
        if !termed && asked.is_some_and(|t| t.elapsed() > Duration::from_secs(10)) {
            termed = true;
            send(nix::sys::signal::Signal::SIGTERM);
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    drop(lease);
    use std::os::unix::process::ExitStatusExt as _;
    let code = status.code().or_else(|| status.signal().map(|s| 128 + s)).unwrap_or(1);
    Ok(ExitCode::from(u8::try_from(code).unwrap_or(1)))
}
