//! Per-node access control from an SROS2 policy file (`policy version="0.2.0"`, the format
//! `ros2 security generate_artifacts -p` reads): which topics and services each enclave may
//! publish or subscribe, turned into the DDS permissions document of its enclave.
//!
//! ```xml
//! <policy version="0.2.0">
//!   <enclaves>
//!     <enclave path="/ds_controller">
//!       <profiles>
//!         <profile ns="/" node="ds_controller">
//!           <topics publish="ALLOW"><topic>/lwr/joint_velocity_command</topic></topics>
//!           <topics subscribe="ALLOW"><topic>joint_states</topic></topics>
//!         </profile>
//!       </profiles>
//!     </enclave>
//!   </enclaves>
//! </policy>
//! ```
//!
//! Names resolve as ROS 2 resolves them: relative names (`joint_states`) under the profile's
//! namespace, `~/x` under the node's name; a topic `/a/b` is the DDS topic `rt/a/b`, a service
//! `/s` the request topic `rq/sRequest` and the reply topic `rr/sReply`. Every profile may also
//! use what every ROS 2 node uses (sros2's `common/node.xml`): `rt/rosout`,
//! `rt/parameter_events`, its own parameter services, `rt/clock` and ros2-client's
//! `ros_discovery_info`. Actions and `xi:include` are refused with the place named: inline them.

use std::collections::BTreeSet;
use std::path::Path;

use anyhow::{Context as _, Result, bail};
use quick_xml::events::{BytesStart, Event};

/// Allowed or denied.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Permission {
    /// `ALLOW`.
    Allow,
    /// `DENY`.
    Deny,
}

/// What one enclave may do, as DDS topic names (`rt/joint_states`).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct EnclaveRules {
    /// DDS topics it may publish.
    pub publish: BTreeSet<String>,
    /// DDS topics it may subscribe to.
    pub subscribe: BTreeSet<String>,
    /// DDS topics it must not publish (a `DENY` wins over an `ALLOW`).
    pub deny_publish: BTreeSet<String>,
    /// DDS topics it must not subscribe to.
    pub deny_subscribe: BTreeSet<String>,
}

impl EnclaveRules {
    /// Whether the enclave may publish the ROS topic `topic` (`/joint_states`).
    pub fn may_publish(&self, topic: &str) -> bool {
        let dds = dds_topic(topic);
        !self.deny_publish.contains(&dds) && self.publish.contains(&dds)
    }

    /// Whether the enclave may subscribe to the ROS topic `topic`.
    pub fn may_subscribe(&self, topic: &str) -> bool {
        let dds = dds_topic(topic);
        !self.deny_subscribe.contains(&dds) && self.subscribe.contains(&dds)
    }
}

/// A parsed policy: enclave path (`/ds_controller`) → its rules, in file order.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Policy {
    /// The enclaves.
    pub enclaves: Vec<(String, EnclaveRules)>,
}

/// The DDS topic of the fully qualified ROS topic `/a/b`: `rt/a/b`.
pub fn dds_topic(topic: &str) -> String {
    format!("rt/{}", topic.trim_start_matches('/'))
}

impl Policy {
    /// Reads and parses the policy file `path`.
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).with_context(|| format!("cannot read policy {}", path.display()))?;
        Self::parse(&text).with_context(|| format!("policy {}", path.display()))
    }

    /// The rules of enclave `path` (`/ds_controller`), if the policy has it.
    pub fn enclave(&self, path: &str) -> Option<&EnclaveRules> {
        self.enclaves.iter().find(|(p, _)| p == path).map(|(_, r)| r)
    }

    /// The rules of enclave `path`, or an error naming the enclaves the policy lists.
    pub fn listed(&self, path: &str) -> Result<&EnclaveRules> {
        self.enclave(path).with_context(|| {
            format!(
                "the policy has no enclave {path} (it lists {})",
                self.enclaves.iter().map(|(p, _)| p.as_str()).collect::<Vec<_>>().join(", ")
            )
        })
    }

    /// Parses a policy document (see the module docs).
    pub fn parse(text: &str) -> Result<Self> {
        let mut reader = quick_xml::Reader::from_str(text);
        reader.config_mut().trim_text(true);
        let mut policy = Policy::default();
        // Open elements, outermost first, for the place in errors and the grammar below.
        let mut stack: Vec<String> = Vec::new();
        let mut enclave: Option<(String, EnclaveRules)> = None;
        let mut profile: Option<(String, String)> = None; // (namespace, node)
        let mut list: Option<List> = None;
        let mut seen_policy = false;
        loop {
            let at = reader.buffer_position();
            let place = |stack: &[String]| format!("at byte {at} (in <{}>)", stack.join("><"));
            let event = reader.read_event().map_err(|e| anyhow::anyhow!("not well-formed XML at byte {at}: {e}"))?;
            let (start, empty) = match &event {
                Event::Start(e) => (Some(e), false),
                Event::Empty(e) => (Some(e), true),
                _ => (None, false),
            };
            if let Some(e) = start {
                let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
                let parent = stack.last().map(String::as_str);
                match (parent, name.as_str()) {
                    (None, "policy") => {
                        let version = attr(e, "version")?.unwrap_or_default();
                        if version != "0.2.0" {
                            bail!("<policy version={version:?}>: only SROS2 policy version 0.2.0 is read");
                        }
                        seen_policy = true;
                    }
                    (Some("policy"), "enclaves") | (Some("enclave"), "profiles") => {}
                    (Some("enclaves"), "enclave") => {
                        let path = attr(e, "path")?
                            .with_context(|| format!("<enclave> without a path attribute {}", place(&stack)))?;
                        let path = super::normalise_enclave(&path).with_context(|| format!("<enclave path={path:?}>"))?;
                        if policy.enclaves.iter().any(|(p, _)| *p == path) {
                            bail!("enclave {path} is listed twice {}", place(&stack));
                        }
                        enclave = Some((path, EnclaveRules::default()));
                    }
                    (Some("profiles"), "profile") => {
                        let ns = attr(e, "ns")?.unwrap_or_else(|| "/".to_owned());
                        let node = attr(e, "node")?
                            .with_context(|| format!("<profile> without a node attribute {}", place(&stack)))?;
                        if !ns.starts_with('/') || node.is_empty() || node.contains('/') {
                            bail!("<profile ns={ns:?} node={node:?}>: ns must be absolute and node a plain name {}", place(&stack));
                        }
                        let rules = &mut enclave.as_mut().context("<profile> outside an <enclave>")?.1;
                        common_node_rules(&ns, &node, rules);
                        profile = Some((ns, node));
                    }
                    (Some("profile"), "topics" | "services") => {
                        list = Some(List::open(e, &name).with_context(|| place(&stack))?);
                    }
                    (Some("topics"), "topic") | (Some("services"), "service") => {}
                    (_, "actions") => bail!("<actions> are not supported {}: list their topics and services", place(&stack)),
                    (_, n) if n.starts_with("xi:") => bail!("<{n}> is not supported {}: inline the included file", place(&stack)),
                    (p, n) => bail!("unexpected <{n}> in <{}> {}", p.unwrap_or("document"), place(&stack)),
                }
                if !empty {
                    stack.push(name);
                }
                continue;
            }
            match event {
                Event::Text(t) => {
                    let what = stack.last().map(String::as_str);
                    if !matches!(what, Some("topic" | "service")) {
                        bail!("text outside <topic>/<service> {}", place(&stack));
                    }
                    let raw = t.decode().map_err(|e| anyhow::anyhow!("{e} {}", place(&stack)))?;
                    let (ns, node) = profile.as_ref().context("a name outside a <profile>")?;
                    let full = resolve(raw.trim(), ns, node).with_context(|| place(&stack))?;
                    let rules = &mut enclave.as_mut().context("a name outside an <enclave>")?.1;
                    list.as_ref().context("a name outside <topics>/<services>")?.grant(&full, rules);
                }
                Event::End(e) => {
                    let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
                    match name.as_str() {
                        "enclave" => policy.enclaves.extend(enclave.take()),
                        "profile" => profile = None,
                        "topics" | "services" => list = None,
                        _ => {}
                    }
                    stack.pop();
                }
                Event::Eof => break,
                Event::GeneralRef(_) => bail!("entity references are not supported {}", place(&stack)),
                // Declarations, comments, processing instructions.
                _ => {}
            }
        }
        if !seen_policy {
            bail!("no <policy> element");
        }
        if policy.enclaves.is_empty() {
            bail!("the policy lists no enclave");
        }
        Ok(policy)
    }

    /// The DDS permissions document of `enclave` (subject `CN=<enclave>`, domains
    /// `domains.0..=domains.1`, valid `not_before..not_after`, XML dateTimes): one allow rule
    /// with its topics, a deny rule before it when the policy denies any, everything else
    /// denied. Errors when the policy has no such enclave.
    pub fn permissions_xml(&self, enclave: &str, domains: (u16, u16), not_before: &str, not_after: &str) -> Result<String> {
        Ok(render_permissions(enclave, self.listed(enclave)?, domains, not_before, not_after))
    }
}

/// The DDS permissions document granting `rules` to subject `CN=<enclave>` (see
/// [`Policy::permissions_xml`]).
pub(super) fn render_permissions(enclave: &str, rules: &EnclaveRules, domains: (u16, u16), not_before: &str, not_after: &str) -> String {
    {
        let topics = |set: &BTreeSet<String>, indent: &str| {
            set.iter().map(|t| format!("{indent}<topic>{t}</topic>\n")).collect::<String>()
        };
        let domains_xml = format!(
            "        <domains>\n          <id_range>\n            <min>{}</min>\n            <max>{}</max>\n          </id_range>\n        </domains>\n",
            domains.0, domains.1
        );
        let rule = |kind: &str, publish: &BTreeSet<String>, subscribe: &BTreeSet<String>| {
            let mut r = format!("      <{kind}>\n{domains_xml}");
            for (tag, set) in [("publish", publish), ("subscribe", subscribe)] {
                if !set.is_empty() {
                    r += &format!("        <{tag}>\n          <topics>\n{}          </topics>\n        </{tag}>\n", topics(set, "            "));
                }
            }
            r + &format!("      </{kind}>\n")
        };
        let mut rules_xml = String::new();
        if !rules.deny_publish.is_empty() || !rules.deny_subscribe.is_empty() {
            rules_xml += &rule("deny_rule", &rules.deny_publish, &rules.deny_subscribe);
        }
        rules_xml += &rule("allow_rule", &rules.publish, &rules.subscribe);
        format!(
            r#"<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="{enclave}">
      <subject_name>CN={enclave}</subject_name>
      <validity>
        <not_before>{not_before}</not_before>
        <not_after>{not_after}</not_after>
      </validity>
{rules_xml}      <default>DENY</default>
    </grant>
  </permissions>
</dds>
"#
        )
    }
}

/// One open `<topics>` or `<services>` list: what its names are granted.
#[derive(Debug)]
enum List {
    /// `<topics publish=".." subscribe="..">`.
    Topics { publish: Option<Permission>, subscribe: Option<Permission> },
    /// `<services request=".." reply="..">` (request: call it; reply: serve it).
    Services { request: Option<Permission>, reply: Option<Permission> },
}

impl List {
    fn open(e: &BytesStart<'_>, name: &str) -> Result<Self> {
        let perm = |key: &str| -> Result<Option<Permission>> {
            match attr(e, key)?.as_deref() {
                None => Ok(None),
                Some("ALLOW") => Ok(Some(Permission::Allow)),
                Some("DENY") => Ok(Some(Permission::Deny)),
                Some(v) => bail!("<{name} {key}={v:?}>: must be ALLOW or DENY"),
            }
        };
        let list = if name == "topics" {
            List::Topics { publish: perm("publish")?, subscribe: perm("subscribe")? }
        } else {
            List::Services { request: perm("request")?, reply: perm("reply")? }
        };
        if matches!(list, List::Topics { publish: None, subscribe: None } | List::Services { request: None, reply: None }) {
            bail!("<{name}> grants nothing: give publish/subscribe (topics) or request/reply (services)");
        }
        Ok(list)
    }

    /// Grants the fully qualified `name` under this list's permissions.
    fn grant(&self, name: &str, rules: &mut EnclaveRules) {
        let mut put = |perm: Option<Permission>, topic: String, publish: bool| {
            let set = match (perm, publish) {
                (None, _) => return,
                (Some(Permission::Allow), true) => &mut rules.publish,
                (Some(Permission::Allow), false) => &mut rules.subscribe,
                (Some(Permission::Deny), true) => &mut rules.deny_publish,
                (Some(Permission::Deny), false) => &mut rules.deny_subscribe,
            };
            set.insert(topic);
        };
        match *self {
            List::Topics { publish, subscribe } => {
                put(publish, dds_topic(name), true);
                put(subscribe, dds_topic(name), false);
            }
            List::Services { request, reply } => {
                let (rq, rr) = service_topics(name);
                put(request, rq.clone(), true);
                put(request, rr.clone(), false);
                put(reply, rq, false);
                put(reply, rr, true);
            }
        }
    }
}

/// Request and reply DDS topics of the service `/a/s`: `rq/a/sRequest`, `rr/a/sReply`.
fn service_topics(service: &str) -> (String, String) {
    let s = service.trim_start_matches('/');
    (format!("rq/{s}Request"), format!("rr/{s}Reply"))
}

/// What every ROS 2 node uses (sros2's `common/node.xml`), plus `/clock` (sim time) and
/// ros2-client's graph topic.
fn common_node_rules(ns: &str, node: &str, rules: &mut EnclaveRules) {
    for t in ["ros_discovery_info", "rt/parameter_events"] {
        rules.publish.insert(t.to_owned());
        rules.subscribe.insert(t.to_owned());
    }
    rules.publish.insert("rt/rosout".to_owned());
    rules.subscribe.insert("rt/clock".to_owned());
    let base = if ns == "/" { format!("/{node}") } else { format!("{ns}/{node}") };
    for s in ["describe_parameters", "get_parameter_types", "get_parameters", "list_parameters", "set_parameters", "set_parameters_atomically"] {
        List::Services { request: None, reply: Some(Permission::Allow) }.grant(&format!("{base}/{s}"), rules);
    }
}

/// The fully qualified name of `name` in namespace `ns` for node `node` (`~/x` → `/ns/node/x`,
/// `x` → `/ns/x`); names with characters ROS 2 refuses are errors.
fn resolve(name: &str, ns: &str, node: &str) -> Result<String> {
    let ns = ns.trim_end_matches('/');
    let full = if let Some(rest) = name.strip_prefix("~/") {
        format!("{ns}/{node}/{rest}")
    } else if name.starts_with('/') {
        name.to_owned()
    } else {
        format!("{ns}/{name}")
    };
    let ok = full.len() > 1
        && !full.ends_with('/')
        && !full.contains("//")
        && full.split('/').skip(1).all(|t| {
            t.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                && t.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        });
    if !ok {
        bail!("{name:?} is not a valid ROS name (letters, digits and _ in /-separated tokens, not starting with a digit)");
    }
    Ok(full)
}

/// The unescaped value of attribute `key`, if present.
fn attr(e: &BytesStart<'_>, key: &str) -> Result<Option<String>> {
    match e.try_get_attribute(key) {
        Ok(Some(a)) => Ok(Some(a.unescape_value().map_err(|err| anyhow::anyhow!("attribute {key}: {err}"))?.into_owned())),
        Ok(None) => Ok(None),
        Err(err) => bail!("attribute {key}: {err}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const POLICY: &str = r#"<?xml version="1.0"?>
<policy version="0.2.0">
  <!-- a comment -->
  <enclaves>
    <enclave path="/ds_controller">
      <profiles>
        <profile ns="/" node="ds_controller">
          <topics publish="ALLOW"><topic>/lwr/joint_velocity_command</topic><topic>motion/status</topic></topics>
          <topics subscribe="ALLOW"><topic>joint_states</topic></topics>
          <topics publish="DENY"><topic>/speech_command</topic></topics>
          <services request="ALLOW"><service>~/helper</service></services>
        </profile>
      </profiles>
    </enclave>
    <enclave path="/robot/observer">
      <profiles>
        <profile ns="/robot" node="human_observer">
          <topics publish="ALLOW" subscribe="ALLOW"><topic>human/state</topic></topics>
        </profile>
      </profiles>
    </enclave>
  </enclaves>
</policy>"#;

    #[test]
    fn names_resolve_as_ros2_resolves_them() {
        let p = Policy::parse(POLICY).unwrap();
        let ds = p.enclave("/ds_controller").unwrap();
        assert!(ds.may_publish("/lwr/joint_velocity_command"));
        assert!(ds.may_publish("/motion/status"));
        assert!(!ds.may_publish("/joint_states") && ds.may_subscribe("/joint_states"));
        assert!(!ds.may_publish("/speech_command") && ds.deny_publish.contains("rt/speech_command"));
        assert!(ds.publish.contains("rq/ds_controller/helperRequest") && ds.subscribe.contains("rr/ds_controller/helperReply"));
        // What every node uses.
        assert!(ds.may_subscribe("/clock") && ds.publish.contains("rt/rosout") && ds.publish.contains("ros_discovery_info"));
        assert!(ds.subscribe.contains("rq/ds_controller/get_parametersRequest"));
        let obs = p.enclave("/robot/observer").unwrap();
        assert!(obs.may_publish("/robot/human/state") && obs.may_subscribe("/robot/human/state"));
        assert!(!obs.may_publish("/lwr/joint_velocity_command"));
        assert!(p.enclave("/lwr_sim").is_none());
    }

    #[test]
    fn permissions_list_the_enclaves_topics_only() {
        let p = Policy::parse(POLICY).unwrap();
        let xml = p.permissions_xml("/ds_controller", (0, 232), "2026-12-04T00:00:00", "2036-12-01T00:00:00").unwrap();
        assert!(xml.contains("<subject_name>CN=/ds_controller</subject_name>"), "{xml}");
        assert!(xml.contains("<topic>rt/lwr/joint_velocity_command</topic>"), "{xml}");
        assert!(!xml.contains("<topic>*</topic>"), "{xml}");
        assert!(!xml.contains("rt/human/state"), "{xml}");
        // The deny rule comes first (DDS Security applies the first rule that matches).
        let deny = xml.find("<deny_rule>").expect("a deny rule");
        assert!(deny < xml.find("<allow_rule>").unwrap() && xml[deny..].contains("rt/speech_command"));
        let e = p.permissions_xml("/lwr_sim", (0, 232), "a", "b").unwrap_err().to_string();
        assert!(e.contains("no enclave /lwr_sim") && e.contains("/ds_controller, /robot/observer"), "{e}");
    }

    #[test]
    fn bad_policies_are_refused_with_the_place() {
        for (bad, says) in [
            ("<policy version=\"0.1.0\"><enclaves/></policy>", "version"),
            ("<policy version=\"0.2.0\"><enclaves></enclaves></policy>", "no enclave"),
            ("<policy version=\"0.2.0\"><enclaves><enclave><profiles/></enclave></enclaves></policy>", "without a path"),
            ("<policy version=\"0.2.0\"><enclaves><enclave path=\"/a\"><profiles><profile node=\"a\"><actions call=\"ALLOW\"/></profile></profiles></enclave></enclaves></policy>", "<actions> are not supported"),
            ("<policy version=\"0.2.0\"><enclaves><enclave path=\"/a\"><profiles><profile node=\"a\"><topics publish=\"MAYBE\"><topic>x</topic></topics></profile></profiles></enclave></enclaves></policy>", "ALLOW or DENY"),
            ("<policy version=\"0.2.0\"><enclaves><enclave path=\"/a\"><profiles><profile node=\"a\"><topics publish=\"ALLOW\"><topic>1x</topic></topics></profile></profiles></enclave></enclaves></policy>", "not a valid ROS name"),
            ("<policy version=\"0.2.0\"><enclaves><enclave path=\"/a\"><profiles><profile node=\"a\"><topics publish=\"ALLOW\"><topic>x</topic></profile></profiles></enclave></enclaves></policy>", "not well-formed"),
            ("<policy version=\"0.2.0\"><enclaves><enclave path=\"/a\"><profiles><profile node=\"a\"/></profiles></enclave><enclave path=\"/a\"><profiles/></enclave></enclaves></policy>", "listed twice"),
            ("<policy version=\"0.2.0\"><enclaves><enclave path=\"/a\"><profiles><xi:include href=\"x\"/></profiles></enclave></enclaves></policy>", "inline"),
            ("<other/>", "unexpected <other>"),
        ] {
            let e = format!("{:#}", Policy::parse(bad).unwrap_err());
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn the_shipped_graph_policy_parses_and_only_ds_controller_commands_the_arm() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../config/security/policy.xml");
        let p = Policy::from_file(&path).unwrap();
        let commanders: Vec<&str> = p
            .enclaves
            .iter()
            .filter(|(_, r)| r.may_publish("/lwr/joint_velocity_command"))
            .map(|(e, _)| e.as_str())
            .collect();
        assert_eq!(commanders, ["/ds_controller", "/cowork"], "who may command the arm");
        let speed: Vec<&str> = p.enclaves.iter().filter(|(_, r)| r.may_publish("/human/state")).map(|(e, _)| e.as_str()).collect();
        assert_eq!(speed, ["/human_observer", "/cowork"], "who may set the allowed speed");
    }
}
