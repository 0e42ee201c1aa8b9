//! `cowork keystore create DIR` / `cowork keystore enclave DIR NODE`: an SROS2 keystore for DDS
//! Security, as `ros2 security create_keystore` / `create_enclave` write it (see
//! `cowork_ros::security`). Needs the `openssl` command.

use std::path::PathBuf;

use anyhow::Result;

/// Subcommands of `cowork keystore`.
#[derive(Debug, clap::Subcommand)]
pub enum KeystoreCommand {
    /// A new keystore: one P-256 CA (identity + permissions), signed governance (every topic
    /// encrypted and access-controlled, no unauthenticated participants).
    Create {
        /// Keystore directory (created; refused if it already holds a CA).
        dir: PathBuf,
    },
    /// Credentials for one node (enclave): key, certificate, signed permissions (all topics).
    Enclave {
        /// Keystore directory made by `cowork keystore create` or `ros2 security create_keystore`.
        dir: PathBuf,
        /// Enclave name(s): the node's name (`lwr_sim` → `/lwr_sim`) or a path (`/cowork`).
        #[arg(required = true, num_args = 1..)]
        names: Vec<String>,
    },
}

/// Runs `cowork keystore`.
pub fn run(command: KeystoreCommand) -> Result<()> {
    match command {
        KeystoreCommand::Create { dir } => {
            cowork_ros::security::create_keystore(&dir)?;
            eprintln!("keystore {} created (CA public/ca.cert.pem, enclaves/governance.p7s)", dir.display());
        }
        KeystoreCommand::Enclave { dir, names } => {
            for name in names {
                let enclave = cowork_ros::security::create_enclave(&dir, &name)?;
                eprintln!("enclave {}", enclave.display());
            }
            if !cowork_ros::security::SUPPORTED {
                eprintln!(
                    "note: this cowork was built without DDS security; build the nodes with `--features cowork_ros/security` to use it"
                );
            }
        }
    }
    Ok(())
}
