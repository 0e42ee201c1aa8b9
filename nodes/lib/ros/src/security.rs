//! DDS Security (SROS2) for every cowork node: the `ROS_SECURITY_*` environment read as ROS 2
//! reads it, the enclave a node takes its credentials from, and the keystore that
//! `cowork keystore create` / `cowork keystore enclave` write (the layout of
//! `ros2 security create_keystore` / `create_enclave`, so either tool's keystore works).
//!
//! | variable | as in ROS 2 (rcl) |
//! |---|---|
//! | `ROS_SECURITY_ENABLE` | exactly `true` turns security on; anything else leaves it off |
//! | `ROS_SECURITY_STRATEGY` | exactly `Enforce`: no credentials, no node; anything else is Permissive |
//! | `ROS_SECURITY_KEYSTORE` | the keystore root; the node's credentials are in `enclaves/<enclave>` |
//! | `ROS_SECURITY_ENCLAVE_OVERRIDE` | the enclave (`/lwr_sim`); default: `/` + the node's name |
//!
//! The enclave directory must hold the six files of an SROS2 enclave ([`ENCLAVE_FILES`]).
//! Enforce with any of them missing, unreadable or refused by the DDS security plugins → the
//! node does not start and says which file and where. Permissive → a warning, and the node runs
//! without security (as ROS 2 does).
//!
//! Creating keystores needs the `openssl` command (Debian package `openssl`); joining a secured
//! domain needs this crate built with its `security` feature (RustDDS's DDS Security plugins:
//! authentication, access control, AES-GCM encryption).

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context as _, Result, bail};

pub mod policy;

pub use policy::Policy;

/// The files of an enclave, as ROS 2's rmw layers look for them.
pub const ENCLAVE_FILES: [&str; 6] = [
    "identity_ca.cert.pem",
    "cert.pem",
    "key.pem",
    "permissions_ca.cert.pem",
    "governance.p7s",
    "permissions.p7s",
];

/// What `ROS_SECURITY_STRATEGY` asks when credentials are missing or refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Strategy {
    /// No credentials → the node refuses to start.
    Enforce,
    /// No credentials → a warning, and the node runs unsecured.
    Permissive,
}

/// The security settings of one node, from the environment.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SecuritySettings {
    /// Enforce or Permissive.
    pub strategy: Strategy,
    /// `ROS_SECURITY_KEYSTORE`, `None` when unset or empty.
    pub keystore: Option<PathBuf>,
    /// The enclave's name, `/lwr_sim`.
    pub enclave: String,
}

/// Reads `ROS_SECURITY_*` for a node named `node_name` (in `namespace`); `None` when
/// `ROS_SECURITY_ENABLE` is not exactly `true`.
pub fn from_env(namespace: &str, node_name: &str) -> Option<SecuritySettings> {
    let var = |k: &str| std::env::var(k).ok();
    settings(
        var("ROS_SECURITY_ENABLE").as_deref(),
        var("ROS_SECURITY_STRATEGY").as_deref(),
        var("ROS_SECURITY_KEYSTORE").as_deref(),
        var("ROS_SECURITY_ENCLAVE_OVERRIDE").as_deref(),
        namespace,
        node_name,
    )
}

/// [`from_env`] on given values (testable).
pub fn settings(
    enable: Option<&str>,
    strategy: Option<&str>,
    keystore: Option<&str>,
    enclave_override: Option<&str>,
    namespace: &str,
    node_name: &str,
) -> Option<SecuritySettings> {
    if enable != Some("true") {
        return None;
    }
    let strategy = if strategy == Some("Enforce") { Strategy::Enforce } else { Strategy::Permissive };
    let keystore = keystore.filter(|k| !k.trim().is_empty()).map(PathBuf::from);
    let enclave = match enclave_override.filter(|e| !e.is_empty()) {
        Some(e) => e.to_owned(),
        None => {
            let ns = namespace.trim_end_matches('/');
            format!("{ns}/{node_name}")
        }
    };
    Some(SecuritySettings { strategy, keystore, enclave })
}

impl SecuritySettings {
    /// The enclave directory `KEYSTORE/enclaves/<enclave>`, checked to hold every file of
    /// [`ENCLAVE_FILES`] as a readable regular file (symbolic links followed); the error names
    /// what is missing and where.
    pub fn enclave_dir(&self) -> Result<PathBuf> {
        let Some(keystore) = &self.keystore else {
            bail!("ROS_SECURITY_ENABLE=true but ROS_SECURITY_KEYSTORE is not set");
        };
        let dir = enclave_path(keystore, &self.enclave)?;
        if !dir.is_dir() {
            bail!(
                "no enclave {} in keystore {}: {} is not a directory (create it with `cowork keystore enclave {} {}`)",
                self.enclave,
                keystore.display(),
                dir.display(),
                keystore.display(),
                self.enclave
            );
        }
        check_enclave_files(&dir)?;
        Ok(dir)
    }
}

/// Every file of [`ENCLAVE_FILES`] present in `dir`, a non-empty regular file we can read.
pub fn check_enclave_files(dir: &Path) -> Result<()> {
    for f in ENCLAVE_FILES {
        let p = dir.join(f);
        let meta = std::fs::metadata(&p).with_context(|| format!("enclave file {} is missing", p.display()))?;
        if !meta.is_file() || meta.len() == 0 {
            bail!("enclave file {} is not a non-empty regular file", p.display());
        }
        std::fs::File::open(&p).with_context(|| format!("cannot read enclave file {}", p.display()))?;
    }
    Ok(())
}

/// `KEYSTORE/enclaves/<enclave>` for an enclave name such as `/lwr_sim` or
/// `/talker_listener/talker`; names with empty, `.` or `..` components, or characters outside
/// ROS names (`[A-Za-z0-9_]`), are refused.
pub fn enclave_path(keystore: &Path, enclave: &str) -> Result<PathBuf> {
    let parts = enclave_components(enclave)?;
    let mut dir = keystore.join("enclaves");
    for p in parts {
        dir.push(p);
    }
    Ok(dir)
}

fn enclave_components(enclave: &str) -> Result<Vec<&str>> {
    let Some(rest) = enclave.strip_prefix('/') else {
        bail!("enclave {enclave:?}: must start with '/' (e.g. /lwr_sim)");
    };
    let parts: Vec<&str> = rest.split('/').collect();
    for p in &parts {
        if p.is_empty() || !p.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') || p.starts_with(|c: char| c.is_ascii_digit()) {
            bail!("enclave {enclave:?}: each part must be a ROS name ([A-Za-z_][A-Za-z0-9_]*)");
        }
    }
    Ok(parts)
}

/// An enclave name from what a user types: `lwr_sim` → `/lwr_sim`.
pub fn normalise_enclave(name: &str) -> Result<String> {
    let name = if name.starts_with('/') { name.to_owned() } else { format!("/{name}") };
    enclave_components(&name)?;
    Ok(name)
}

/// Whether this build can join a secured domain (the crate's `security` feature).
pub const SUPPORTED: bool = cfg!(feature = "security");

/// Days the certificates and documents of a new keystore are valid (as sros2: 10 years).
const VALIDITY_DAYS: u32 = 3650;

/// The governance: no unauthenticated participants, join access control, discovery and
/// liveliness encrypted, every RTPS message encrypted and authenticated
/// (`rtps_protection_kind` ENCRYPT: each message between two participants, with their session
/// keys), and on every topic read and write access control.
///
/// sros2 writes RTPS SIGN with `metadata_protection_kind` and `data_protection_kind` ENCRYPT
/// (each submessage, then each payload, protected per writer). RustDDS 0.15.1 fails those
/// between processes ("The ring crypto library gives 'Unspecified' error"), measured one kind at
/// a time on 2026-12-06: payload protection loses every sample; submessage protection works for
/// a lone talker but loses all of lwr_sim's `/clock` and two thirds of its `/joint_states`.
/// Message-level encryption delivers every topic at full rate, so both per-endpoint kinds are
/// NONE here; a keystore made by `ros2 security` needs the same change (see the README).
pub fn governance_xml(domain_min: u16, domain_max: u16) -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains>
        <id_range>
          <min>{domain_min}</min>
          <max>{domain_max}</max>
        </id_range>
      </domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>ENCRYPT</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>NONE</metadata_protection_kind>
          <data_protection_kind>NONE</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
"#
    )
}

/// The permissions of one enclave: its subject `CN=<enclave>` may publish and subscribe every
/// topic on domains `domain_min..=domain_max` from `not_before` to `not_after`
/// (`YYYY-MM-DDThh:mm:ss`, UTC); everything else denied.
pub fn permissions_xml(enclave: &str, domain_min: u16, domain_max: u16, not_before: &str, not_after: &str) -> String {
    let every = || std::iter::once("*".to_owned()).collect();
    let rules = policy::EnclaveRules { publish: every(), subscribe: every(), ..Default::default() };
    policy::render_permissions(enclave, &rules, (domain_min, domain_max), not_before, not_after)
}

/// Domains a new keystore's governance and permissions cover (every valid `ROS_DOMAIN_ID`).
pub const DOMAINS: (u16, u16) = (0, 232);

fn openssl(args: &[&str], what: &str) -> Result<String> {
    let out = Command::new("openssl")
        .args(args)
        .output()
        .with_context(|| format!("{what}: cannot run `openssl` (Debian package `openssl`)"))?;
    if !out.status.success() {
        bail!(
            "{what}: `openssl {}` failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

fn path_str(p: &Path) -> Result<&str> {
    p.to_str().with_context(|| format!("path {} is not UTF-8", p.display()))
}

fn new_key(path: &Path) -> Result<()> {
    openssl(
        &["genpkey", "-algorithm", "EC", "-pkeyopt", "ec_paramgen_curve:P-256", "-out", path_str(path)?],
        &format!("creating key {}", path.display()),
    )?;
    restrict(path)
}

#[cfg(unix)]
fn restrict(path: &Path) -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o600))
        .with_context(|| format!("cannot restrict {} to its owner", path.display()))
}

#[cfg(not(unix))]
fn restrict(_path: &Path) -> Result<()> {
    Ok(())
}

fn sign(input: &Path, output: &Path, ca_cert: &Path, ca_key: &Path) -> Result<()> {
    openssl(
        &[
            "smime", "-sign", "-text", "-in", path_str(input)?, "-out", path_str(output)?,
            "-signer", path_str(ca_cert)?, "-inkey", path_str(ca_key)?,
        ],
        &format!("signing {}", input.display()),
    )?;
    Ok(())
}

#[cfg(unix)]
fn link(target: &str, at: &Path) -> Result<()> {
    if std::fs::symlink_metadata(at).is_ok() {
        std::fs::remove_file(at).with_context(|| format!("cannot replace {}", at.display()))?;
    }
    std::os::unix::fs::symlink(target, at).with_context(|| format!("cannot link {} -> {target}", at.display()))
}

#[cfg(not(unix))]
fn link(target: &str, at: &Path) -> Result<()> {
    let from = at.parent().unwrap_or(Path::new(".")).join(target);
    std::fs::copy(&from, at).map(|_| ()).with_context(|| format!("cannot copy {} to {}", from.display(), at.display()))
}

/// `ros2 security create_keystore DIR`: `public/ca.cert.pem` (one self-signed P-256 CA, CN
/// `sros2testCA`, also linked as the identity and permissions CA), `private/ca.key.pem` (mode
/// 600), `enclaves/governance.xml` and its signed `governance.p7s`. An existing keystore is
/// left as it is (an error names it), so its CA is never replaced by accident.
pub fn create_keystore(dir: &Path) -> Result<()> {
    let (public, private, enclaves) = (dir.join("public"), dir.join("private"), dir.join("enclaves"));
    if public.join("ca.cert.pem").exists() || private.join("ca.key.pem").exists() {
        bail!("{} already holds a keystore (public/ca.cert.pem); not replacing its CA", dir.display());
    }
    for d in [&public, &private, &enclaves] {
        std::fs::create_dir_all(d).with_context(|| format!("cannot create {}", d.display()))?;
    }
    let (ca_key, ca_cert) = (private.join("ca.key.pem"), public.join("ca.cert.pem"));
    new_key(&ca_key)?;
    openssl(
        &[
            "req", "-new", "-x509", "-sha256", "-key", path_str(&ca_key)?, "-out", path_str(&ca_cert)?,
            "-days", &VALIDITY_DAYS.to_string(), "-subj", "/CN=sros2testCA", "-utf8",
            "-addext", "basicConstraints=critical,CA:TRUE,pathlen:1",
        ],
        "creating the keystore CA",
    )?;
    for role in ["identity_ca", "permissions_ca"] {
        link("ca.cert.pem", &public.join(format!("{role}.cert.pem")))?;
        link("ca.key.pem", &private.join(format!("{role}.key.pem")))?;
    }
    let gov_xml = enclaves.join("governance.xml");
    cowork_write(&gov_xml, governance_xml(DOMAINS.0, DOMAINS.1).as_bytes())?;
    sign(
        &gov_xml,
        &enclaves.join("governance.p7s"),
        &public.join("permissions_ca.cert.pem"),
        &private.join("permissions_ca.key.pem"),
    )
}

fn cowork_write(path: &Path, bytes: &[u8]) -> Result<()> {
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

/// `ros2 security create_enclave DIR NAME`: `enclaves/<name>/` with a new P-256 key
/// (`key.pem`, mode 600), its certificate `cert.pem` (subject `CN=<name>`, signed by the
/// identity CA), `permissions.xml` / `permissions.p7s` (signed by the permissions CA: every
/// topic, or with a `policy` only the topics it grants the enclave; every domain), and links
/// to the keystore's CA certificates and governance. Returns the enclave directory. An
/// existing enclave's key and certificate are replaced. An enclave the policy does not list
/// is refused before anything is written.
pub fn create_enclave(keystore: &Path, name: &str, policy: Option<&Policy>) -> Result<PathBuf> {
    let name = normalise_enclave(name)?;
    if let Some(p) = policy {
        p.listed(&name)?;
    }
    let (public, private, enclaves) = (keystore.join("public"), keystore.join("private"), keystore.join("enclaves"));
    for f in [public.join("identity_ca.cert.pem"), public.join("permissions_ca.cert.pem"),
              private.join("identity_ca.key.pem"), private.join("permissions_ca.key.pem"),
              enclaves.join("governance.p7s")] {
        if !f.is_file() {
            bail!("{} is not a keystore: {} is missing (create one with `cowork keystore create {}`)",
                keystore.display(), f.display(), keystore.display());
        }
    }
    let dir = enclave_path(keystore, &name)?;
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    // Relative links, as sros2 makes them: the keystore can be moved.
    let depth = name.matches('/').count(); // enclaves/<a>/<b>: ../../ up to enclaves/
    let up_to_enclaves = "../".repeat(depth);
    let up_to_root = "../".repeat(depth + 1);
    link(&format!("{up_to_root}public/identity_ca.cert.pem"), &dir.join("identity_ca.cert.pem"))?;
    link(&format!("{up_to_root}public/permissions_ca.cert.pem"), &dir.join("permissions_ca.cert.pem"))?;
    link(&format!("{up_to_enclaves}governance.p7s"), &dir.join("governance.p7s"))?;
    let (key, csr, cert) = (dir.join("key.pem"), dir.join("req.csr.pem"), dir.join("cert.pem"));
    new_key(&key)?;
    let subject = format!("/CN={}", name.replace('/', "\\/"));
    openssl(
        &["req", "-new", "-sha256", "-key", path_str(&key)?, "-out", path_str(&csr)?, "-subj", &subject, "-utf8"],
        &format!("creating the certificate request of enclave {name}"),
    )?;
    let serial = format!("0x{:016x}{:08x}", rand_u64(), std::process::id());
    let signed = openssl(
        &[
            "x509", "-req", "-sha256", "-in", path_str(&csr)?, "-CA", path_str(&public.join("identity_ca.cert.pem"))?,
            "-CAkey", path_str(&private.join("identity_ca.key.pem"))?, "-set_serial", &serial,
            "-days", &VALIDITY_DAYS.to_string(), "-out", path_str(&cert)?,
        ],
        &format!("signing the certificate of enclave {name}"),
    );
    let _ = std::fs::remove_file(&csr);
    signed?;
    let dates = openssl(&["x509", "-in", path_str(&cert)?, "-noout", "-startdate", "-enddate"], "reading certificate dates")?;
    let (not_before, not_after) = xml_dates(&dates)?;
    let perm_xml = dir.join("permissions.xml");
    let permissions = match policy {
        Some(p) => p.permissions_xml(&name, DOMAINS, &not_before, &not_after)?,
        None => permissions_xml(&name, DOMAINS.0, DOMAINS.1, &not_before, &not_after),
    };
    cowork_write(&perm_xml, permissions.as_bytes())?;
    sign(
        &perm_xml,
        &dir.join("permissions.p7s"),
        &public.join("permissions_ca.cert.pem"),
        &private.join("permissions_ca.key.pem"),
    )?;
    check_enclave_files(&dir)?;
    Ok(dir)
}

fn rand_u64() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u128(std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default().as_nanos());
    h.finish() & 0x7fff_ffff_ffff_ffff
}

/// `notBefore=Dec  2 14:00:00 2026 GMT` / `notAfter=...` → XML dateTimes (UTC).
fn xml_dates(openssl_out: &str) -> Result<(String, String)> {
    let mut before = None;
    let mut after = None;
    for line in openssl_out.lines() {
        if let Some(v) = line.strip_prefix("notBefore=") {
            before = Some(openssl_date_to_xml(v)?);
        } else if let Some(v) = line.strip_prefix("notAfter=") {
            after = Some(openssl_date_to_xml(v)?);
        }
    }
    match (before, after) {
        (Some(b), Some(a)) => Ok((b, a)),
        _ => bail!("openssl printed no certificate dates: {openssl_out:?}"),
    }
}

fn openssl_date_to_xml(v: &str) -> Result<String> {
    // "Dec  2 14:00:00 2026 GMT"
    let f: Vec<&str> = v.split_whitespace().collect();
    let bad = || anyhow::anyhow!("unexpected certificate date {v:?}");
    if f.len() != 5 || f[4] != "GMT" {
        return Err(bad());
    }
    const MONTHS: [&str; 12] = ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"];
    let month = MONTHS.iter().position(|m| *m == f[0]).ok_or_else(bad)? + 1;
    let day: u32 = f[1].parse().map_err(|_| bad())?;
    let year: u32 = f[3].parse().map_err(|_| bad())?;
    if f[2].len() != 8 {
        return Err(bad());
    }
    Ok(format!("{year:04}-{month:02}-{day:02}T{}", f[2]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn environment_read_as_ros2_reads_it() {
        assert_eq!(settings(None, Some("Enforce"), Some("/k"), None, "/", "n"), None);
        assert_eq!(settings(Some("True"), Some("Enforce"), Some("/k"), None, "/", "n"), None, "only exactly `true`");
        let s = settings(Some("true"), Some("Enforce"), Some("/k"), None, "/", "lwr_sim").unwrap();
        assert_eq!(s, SecuritySettings { strategy: Strategy::Enforce, keystore: Some("/k".into()), enclave: "/lwr_sim".into() });
        let s = settings(Some("true"), Some("enforce"), Some(""), Some("/a/b"), "/", "n").unwrap();
        assert_eq!((s.strategy, s.keystore, s.enclave.as_str()), (Strategy::Permissive, None, "/a/b"));
        let s = settings(Some("true"), None, Some("/k"), None, "/robot", "lwr_sim").unwrap();
        assert_eq!(s.enclave, "/robot/lwr_sim");
    }

    #[test]
    fn enclave_paths_stay_inside_the_keystore() {
        let k = Path::new("/k");
        assert_eq!(enclave_path(k, "/lwr_sim").unwrap(), Path::new("/k/enclaves/lwr_sim"));
        assert_eq!(enclave_path(k, "/a/b").unwrap(), Path::new("/k/enclaves/a/b"));
        for bad in ["lwr_sim", "/", "/..", "/a/../b", "/a//b", "/a b", "/1a", "/a/"] {
            assert!(enclave_path(k, bad).is_err(), "{bad}");
        }
        assert_eq!(normalise_enclave("lwr_sim").unwrap(), "/lwr_sim");
    }

    #[test]
    fn missing_keystore_or_enclave_is_named() {
        let s = settings(Some("true"), Some("Enforce"), None, None, "/", "n").unwrap();
        assert!(s.enclave_dir().unwrap_err().to_string().contains("ROS_SECURITY_KEYSTORE is not set"));
        let dir = tempfile::tempdir().unwrap();
        let s = SecuritySettings { strategy: Strategy::Enforce, keystore: Some(dir.path().into()), enclave: "/n".into() };
        let e = s.enclave_dir().unwrap_err().to_string();
        assert!(e.contains("no enclave /n") && e.contains("enclaves/n"), "{e}");
        std::fs::create_dir_all(dir.path().join("enclaves/n")).unwrap();
        std::fs::write(dir.path().join("enclaves/n/identity_ca.cert.pem"), "x").unwrap();
        let e = format!("{:#}", s.enclave_dir().unwrap_err());
        assert!(e.contains("cert.pem is missing"), "{e}");
    }

    #[test]
    fn a_policy_enclave_grants_its_topics_only_and_an_unlisted_one_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let ks = dir.path().join("ks");
        create_keystore(&ks).unwrap();
        let policy = Policy::from_file(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../config/security/policy.xml")).unwrap();
        let e = create_enclave(&ks, "human_observer", Some(&policy)).unwrap();
        let xml = std::fs::read_to_string(e.join("permissions.xml")).unwrap();
        assert!(xml.contains("<topic>rt/human/state</topic>") && !xml.contains("<topic>*</topic>"), "{xml}");
        assert!(!xml.contains("rt/lwr/joint_velocity_command"), "{xml}");
        assert!(e.join("permissions.p7s").is_file());
        let err = format!("{:#}", create_enclave(&ks, "stranger", Some(&policy)).unwrap_err());
        assert!(err.contains("no enclave /stranger"), "{err}");
        assert!(!ks.join("enclaves/stranger").exists(), "nothing written for a refused enclave");
    }

    #[test]
    fn without_a_policy_an_enclave_may_use_every_topic() {
        let xml = permissions_xml("/n", 0, 232, "2026-12-04T00:00:00", "2036-12-01T00:00:00");
        assert!(xml.contains("<subject_name>CN=/n</subject_name>") && xml.contains("<default>DENY</default>"), "{xml}");
        assert_eq!(xml.matches("<topic>*</topic>").count(), 2, "publish and subscribe: {xml}");
        assert!(xml.contains("<min>0</min>") && xml.contains("<max>232</max>") && !xml.contains("deny_rule"), "{xml}");
    }

    #[test]
    fn certificate_dates_become_xml_dates() {
        let (b, a) = xml_dates("notBefore=Dec  2 14:00:00 2026 GMT\nnotAfter=Nov 30 14:00:05 2036 GMT\n").unwrap();
        assert_eq!((b.as_str(), a.as_str()), ("2026-12-02T14:00:00", "2036-11-30T14:00:05"));
        assert!(openssl_date_to_xml("yesterday").is_err());
    }
}
