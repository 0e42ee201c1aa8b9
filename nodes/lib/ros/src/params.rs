//! ROS 2-shaped YAML parameter files:
//!
//! ```yaml
//! lwr_sim:
//!   ros__parameters:
//!     step_s: 0.001
//! ```
//!
//! The block under `<node>: ros__parameters:` is deserialised into the node's typed config
//! (which should use `#[serde(deny_unknown_fields, default)]`), so an unknown or mistyped key
//! fails with the file, the node and the key in the message. `/**` (all nodes) is accepted too.
//!
//! A node started in a namespace (`--ros-args -r __ns:=/left`) also reads the block of its fully
//! qualified name, `/left/ds_controller: ros__parameters:`, laid over the plain one key by key
//! (mappings merged, anything else replaced): one file holds the defaults and what differs per
//! arm.

use std::path::Path;

use serde::de::DeserializeOwned;

/// Why a parameter file was rejected.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ParamsError {
    #[error("cannot read parameter file {path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("parameter file {path}: {message}")]
    Syntax { path: String, message: String },
    #[error("parameter file {path}: no `{node}: ros__parameters:` block (found: {found})")]
    MissingNode { path: String, node: String, found: String },
    #[error("parameter file {path}, node {node}: {message}")]
    Invalid { path: String, node: String, message: String },
}

/// Loads the parameters of `node` from a ROS 2 parameter YAML file. A relative
/// `config/...` path that does not exist from the working directory is looked up in the
/// bundled config directory ([`crate::config::resolve`]), so a node starts from anywhere.
pub fn load<T: DeserializeOwned>(path: &Path, node: &str) -> Result<T, ParamsError> {
    let path = &crate::config::resolve(path);
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|source| ParamsError::Io { path: shown.clone(), source })?;
    let args = crate::ros_args();
    let node = args.node_name.as_deref().unwrap_or(node);
    from_str_in(&text, node, args.namespace.as_deref(), &shown)
}

/// Like [`load`] on a string, for a node in the root namespace; `place` names it in errors.
pub fn from_str<T: DeserializeOwned>(text: &str, node: &str, place: &str) -> Result<T, ParamsError> {
    from_str_in(text, node, None, place)
}

/// Like [`from_str`] for a node in `namespace` (`/left`; `None` or `/` for the root): the
/// block `/left/<node>` is laid over the plain one (see the module docs).
pub fn from_str_in<T: DeserializeOwned>(text: &str, node: &str, namespace: Option<&str>, place: &str) -> Result<T, ParamsError> {
    let namespace = namespace.map(|n| n.trim_end_matches('/')).filter(|n| !n.is_empty());
    let Some(ns) = namespace else { return plain_block(text, node, place) };
    let doc: serde_yaml_ng::Value = serde_yaml_ng::from_str(text)
        .map_err(|e| ParamsError::Syntax { path: place.to_owned(), message: e.to_string() })?;
    let bare = node.trim_start_matches('/');
    let qualified = format!("{ns}/{bare}");
    let key = |k: &str| serde_yaml_ng::Value::String(k.to_owned());
    let Some(overlay) = [qualified.clone(), qualified.trim_start_matches('/').to_owned()]
        .iter()
        .find_map(|name| doc.get(key(name)))
        .and_then(|n| n.get(key("ros__parameters")))
        .cloned()
    else {
        return plain_block(text, node, place);
    };
    let mut block = match block_of(&doc, bare) {
        Some(b) => b,
        None => serde_yaml_ng::Value::Mapping(Default::default()),
    };
    merge(&mut block, overlay);
    serde_yaml_ng::from_value(block).map_err(|e| ParamsError::Invalid { path: place.to_owned(), node: qualified, message: e.to_string() })
}

/// The `ros__parameters` of `bare`, `/bare` or `/**`.
fn block_of(doc: &serde_yaml_ng::Value, bare: &str) -> Option<serde_yaml_ng::Value> {
    let key = |k: &str| serde_yaml_ng::Value::String(k.to_owned());
    [bare.to_owned(), format!("/{bare}"), "/**".to_owned()]
        .iter()
        .find_map(|name| doc.get(key(name)))
        .and_then(|n| n.get(key("ros__parameters")))
        .cloned()
}

/// `over` laid over `base`: mappings merged key by key, anything else replaced.
fn merge(base: &mut serde_yaml_ng::Value, over: serde_yaml_ng::Value) {
    match (base, over) {
        (serde_yaml_ng::Value::Mapping(b), serde_yaml_ng::Value::Mapping(o)) => {
            for (k, v) in o {
                match b.get_mut(&k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (slot, v) => *slot = v,
    }
}

fn plain_block<T: DeserializeOwned>(text: &str, node: &str, place: &str) -> Result<T, ParamsError> {
    let doc: serde_yaml_ng::Value = serde_yaml_ng::from_str(text)
        .map_err(|e| ParamsError::Syntax { path: place.to_owned(), message: e.to_string() })?;
    let bare = node.trim_start_matches('/');
    let block = block_of(&doc, bare).ok_or_else(|| ParamsError::MissingNode {
            path: place.to_owned(),
            node: bare.to_owned(),
            found: match &doc {
                serde_yaml_ng::Value::Mapping(m) => m
                    .keys()
                    .filter_map(|k| k.as_str().map(str::to_owned))
                    .collect::<Vec<_>>()
                    .join(", "),
                _ => "not a mapping".to_owned(),
            },
        })?;
    serde_yaml_ng::from_value(block).map_err(|e| ParamsError::Invalid {
        path: place.to_owned(),
        node: bare.to_owned(),
        message: e.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, serde::Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct P {
        rate_hz: f64,
    }

    #[test]
    fn reads_the_node_block() {
        let p: P = from_str("n:\n  ros__parameters:\n    rate_hz: 5.0\n", "n", "t.yaml").unwrap();
        assert_eq!(p, P { rate_hz: 5.0 });
    }

    #[test]
    fn names_the_unknown_key_and_the_file() {
        let e = from_str::<P>("n:\n  ros__parameters:\n    rate: 5.0\n", "n", "t.yaml").unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("t.yaml") && msg.contains("rate"), "{msg}");
    }

    #[derive(Debug, serde::Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct Nested {
        rate_hz: f64,
        limits: Limits,
    }

    #[derive(Debug, serde::Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct Limits {
        lower: f64,
        upper: f64,
    }

    #[test]
    fn a_namespaced_block_is_laid_over_the_plain_one() {
        let text = "n:\n  ros__parameters:\n    rate_hz: 5.0\n    limits: { lower: -1.0, upper: 1.0 }\n\
                    /left/n:\n  ros__parameters:\n    limits: { upper: 2.0 }\n";
        let plain: Nested = from_str_in(text, "n", None, "t.yaml").unwrap();
        assert_eq!(plain, Nested { rate_hz: 5.0, limits: Limits { lower: -1.0, upper: 1.0 } });
        let left: Nested = from_str_in(text, "n", Some("/left"), "t.yaml").unwrap();
        assert_eq!(left, Nested { rate_hz: 5.0, limits: Limits { lower: -1.0, upper: 2.0 } });
        let right: Nested = from_str_in(text, "n", Some("/right"), "t.yaml").unwrap();
        assert_eq!(right, plain, "no block for /right/n: the plain one");
        let bad = "n:\n  ros__parameters:\n    rate_hz: 5.0\n    limits: { lower: -1.0, upper: 1.0 }\n/left/n:\n  ros__parameters:\n    limits: { uper: 2.0 }\n";
        let e = from_str_in::<Nested>(bad, "n", Some("/left"), "t.yaml").unwrap_err().to_string();
        assert!(e.contains("/left/n") && e.contains("uper"), "{e}");
    }

    #[test]
    fn missing_node_lists_what_is_there() {
        let e = from_str::<P>("other:\n  ros__parameters: {}\n", "n", "t.yaml").unwrap_err();
        assert!(e.to_string().contains("other"), "{e}");
    }
}
