//! Prints the App. B.2 comparison of DHB, EFS and DS (Fig. B.2 and Fig. B.3 as tables);
//! `cowork bench invariants` prints the same.

fn main() -> cowork_motion::Result<()> {
    use cowork_motion::appendix_b::{format_tables, noise_sensitivity, reconstruction_errors};
    let recon = [0.1, 0.01, 0.001]
        .iter()
        .map(|dt| reconstruction_errors(*dt))
        .collect::<cowork_motion::Result<Vec<_>>>()?;
    let noise = noise_sensitivity(0.01, &[100.0, 90.0, 80.0, 70.0, 60.0, 50.0], 100, 2)?;
    print!("{}", format_tables(&recon, &noise));
    Ok(())
}
