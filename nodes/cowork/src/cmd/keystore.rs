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
    /// Credentials for one node (enclave): key, certificate, signed permissions (every topic,
    /// or with --policy only what the policy grants the enclave).
    Enclave {
        /// Keystore directory made by `cowork keystore create` or `ros2 security create_keystore`.
        dir: PathBuf,
        /// Enclave name(s): the node's name (`lwr_sim` → `/lwr_sim`) or a path (`/cowork`).
        #[arg(required = true, num_args = 1..)]
        names: Vec<String>,
        /// SROS2 policy file (version 0.2.0) whose enclaves say which topics each may publish
        /// and subscribe, e.g. the graph's `config/security/policy.xml`.
        #[arg(long)]
        policy: Option<PathBuf>,
    },
}

/// Runs `cowork keystore`.
pub fn run(command: KeystoreCommand) -> Result<()> {
    match command {
        KeystoreCommand::Create { dir } => {
            cowork_ros::security::create_keystore(&dir)?;
            eprintln!("keystore {} created (CA public/ca.cert.pem, enclaves/governance.p7s)", dir.display());
        }
        KeystoreCommand::Enclave { dir, names, policy } => {
            let policy = policy.as_deref().map(cowork_ros::security::Policy::from_file).transpose()?;
            for name in names {
                let enclave = cowork_ros::security::create_enclave(&dir, &name, policy.as_ref())?;
                let grants = if policy.is_some() { "the policy's topics" } else { "every topic" };
                eprintln!("enclave {} ({grants})", enclave.display());
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
