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
    from_str(&text, node, &shown)
}

/// Like [`load`] on a string; `place` names it in errors.
pub fn from_str<T: DeserializeOwned>(text: &str, node: &str, place: &str) -> Result<T, ParamsError> {
    let doc: serde_yaml_ng::Value = serde_yaml_ng::from_str(text)
        .map_err(|e| ParamsError::Syntax { path: place.to_owned(), message: e.to_string() })?;
    let key = |k: &str| serde_yaml_ng::Value::String(k.to_owned());
    let bare = node.trim_start_matches('/');
    let block = [bare.to_owned(), format!("/{bare}"), "/**".to_owned()]
        .iter()
        .find_map(|name| doc.get(key(name)))
        .and_then(|n| n.get(key("ros__parameters")))
        .cloned()
        .ok_or_else(|| ParamsError::MissingNode {
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

    #[test]
    fn missing_node_lists_what_is_there() {
        let e = from_str::<P>("other:\n  ros__parameters: {}\n", "n", "t.yaml").unwrap_err();
        assert!(e.to_string().contains("other"), "{e}");
    }
}
