//! `cowork learn`: fit motion primitives from CSV demonstrations, roll them out, evaluate their
//! velocity fields, and convert pose trajectories to DHB invariants and back.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use cowork_motion::cgmr::Components;
use cowork_motion::csv_io::{
    read_demonstration, read_dhb, read_points, read_poses, write_dhb, write_poses,
    write_trajectory, write_velocities,
};
use cowork_motion::dhb::Dhb;
use cowork_motion::model::{FitOptions, Model, ModelKind};
use cowork_motion::{RolloutConfig, Trajectory};
use nalgebra::{Rotation3, Vector3};

/// Subcommands of `cowork learn`.
#[derive(Debug, clap::Subcommand)]
pub enum LearnCommand {
    /// Learn a model from demonstrations (CSV `t,x0..x{n-1}[,v0..]`).
    Fit {
        /// Model kind: dmp, gmr, cgmr or hmm.
        #[arg(long)]
        model: ModelKind,
        /// Demonstration CSV files (a DMP takes exactly one).
        #[arg(long, num_args = 1.., required = true)]
        demos: Vec<PathBuf>,
        /// Number of Gaussian components (gmr, cgmr).
        #[arg(long, conflicts_with = "bic")]
        components: Option<usize>,
        /// Choose the number of components in 1..=KMAX by BIC (gmr, cgmr; default 10).
        #[arg(long, value_name = "KMAX")]
        bic: Option<usize>,
        /// Train on every n-th sample (gmr, cgmr).
        #[arg(long, default_value_t = 1)]
        subsample: usize,
        /// Number of HMM states (hmm).
        #[arg(long)]
        states: Option<usize>,
        /// Number of DMP basis functions (dmp).
        #[arg(long)]
        basis: Option<usize>,
        /// Output model (JSON).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Generate a motion from a start (CSV `t,x0..,v0..`).
    Rollout {
        /// Model file written by `fit`.
        #[arg(long)]
        model: PathBuf,
        /// Start position, comma separated.
        #[arg(
            long,
            value_delimiter = ',',
            allow_hyphen_values = true,
            required = true
        )]
        start: Vec<f64>,
        /// Goal position (default: the learned one).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        goal: Option<Vec<f64>>,
        /// Integration step (s).
        #[arg(long)]
        dt: f64,
        /// Maximum number of steps.
        #[arg(long, default_value_t = 100_000)]
        max_steps: usize,
        /// Stop within this distance of the goal (state unit).
        #[arg(long, default_value_t = 1e-3)]
        tol: f64,
        /// Output CSV.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Velocity field f(x) at the points of a CSV `x0..` (gmr, cgmr).
    Eval {
        /// Model file written by `fit`.
        #[arg(long)]
        model: PathBuf,
        /// Points CSV.
        #[arg(long)]
        points: PathBuf,
        /// Output CSV `v0..`.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Pose trajectory (CSV `t,px,py,pz,qw,qx,qy,qz`) to position-based DHB invariants, or back
    /// with `--reconstruct`.
    Dhb {
        /// Input: poses, or invariants with `--reconstruct`.
        #[arg(long)]
        pose: PathBuf,
        /// Reconstruct poses from invariants instead.
        #[arg(long)]
        reconstruct: bool,
        /// Output CSV.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Gesture templates and rejection threshold from bags with `/human/skeleton` and
    /// `/human/gesture_label` labels (the human observer's model).
    Gestures(crate::cmd::observe::LearnGesturesArgs),
}

/// Runs one `cowork learn` subcommand.
pub fn run(cmd: LearnCommand) -> Result<()> {
    match cmd {
        LearnCommand::Gestures(a) => crate::cmd::observe::learn_gestures(a)?,
        LearnCommand::Fit {
            model,
            demos,
            components,
            bic,
            subsample,
            states,
            basis,
            output,
        } => {
            let demos = demos
                .iter()
                .map(|p| {
                    read_demonstration(p)
                        .with_context(|| format!("reading demonstration {}", p.display()))
                })
                .collect::<Result<Vec<_>>>()?;
            let mut opts = FitOptions {
                subsample,
                ..FitOptions::default()
            };
            opts.components = match (components, bic) {
                (Some(k), _) => Components::Fixed(k),
                (None, Some(kmax)) => Components::Bic(kmax),
                (None, None) => Components::Bic(10),
            };
            if let Some(s) = states {
                opts.hmm.states = s;
            }
            if let Some(b) = basis {
                opts.dmp.n_basis = b;
            }
            let bar = crate::cmd::observe::spinner("fitting");
            let m = Model::fit(model, &demos, &opts).context("fitting the model");
            bar.finish_and_clear();
            let m = m?;
            m.save(&output)
                .with_context(|| format!("writing {}", output.display()))?;
            eprintln!(
                "{} model of dimension {} written to {}",
                m.kind(),
                m.dim(),
                output.display()
            );
        }
        LearnCommand::Rollout {
            model,
            start,
            goal,
            dt,
            max_steps,
            tol,
            output,
        } => {
            let m = Model::load(&model).with_context(|| format!("loading {}", model.display()))?;
            let cfg = RolloutConfig { dt, max_steps, tol };
            let tr: Trajectory = m
                .rollout(&start, goal.as_deref(), &cfg)
                .context("rollout")?;
            write_trajectory(&output, &tr)
                .with_context(|| format!("writing {}", output.display()))?;
            eprintln!("{} samples, reached the goal: {}", tr.len(), tr.reached);
        }
        LearnCommand::Eval {
            model,
            points,
            output,
        } => {
            let m = Model::load(&model).with_context(|| format!("loading {}", model.display()))?;
            let (n, pts) =
                read_points(&points).with_context(|| format!("reading {}", points.display()))?;
            if n != m.dim() {
                bail!(
                    "{}: {n} columns, the model has dimension {}",
                    points.display(),
                    m.dim()
                );
            }
            let v = m.eval(&pts).context("evaluating the velocity field")?;
            write_velocities(&output, n, &v)
                .with_context(|| format!("writing {}", output.display()))?;
        }
        LearnCommand::Dhb {
            pose,
            reconstruct,
            output,
        } => {
            if reconstruct {
                let (t, t_end, dhb) =
                    read_dhb(&pose).with_context(|| format!("reading {}", pose.display()))?;
                let poses = dhb.reconstruct_poses(1.0, &Rotation3::identity(), &Vector3::zeros());
                let mut times = t;
                times.push(t_end);
                write_poses(&output, &times, &poses)
                    .with_context(|| format!("writing {}", output.display()))?;
            } else {
                let (t, poses) =
                    read_poses(&pose).with_context(|| format!("reading {}", pose.display()))?;
                let dhb = Dhb::from_poses(&poses)
                    .with_context(|| format!("DHB invariants of {}", pose.display()))?;
                write_dhb(&output, &t, &dhb)
                    .with_context(|| format!("writing {}", output.display()))?;
            }
        }
    }
    Ok(())
}
