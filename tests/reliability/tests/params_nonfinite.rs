//! Every numeric parameter of every node, set to NaN, +∞ and −∞ in turn, is refused at start-up
//! with an error that names the key (issue #20 item 4): a NaN that slips through silently turns
//! a safety behaviour off (a NaN distance threshold compares false everywhere).

use std::path::Path;

use cowork_ros::params::from_str_in;
use serde_yaml_ng::Value;

/// Loads and validates the node's parameters from a file's text, as the node started in the
/// namespace (`None`: the root) reads them.
type Check = fn(&str, Option<&str>) -> Result<(), String>;

fn checks() -> Vec<(&'static str, Check)> {
    fn e(x: impl std::fmt::Display) -> String {
        x.to_string()
    }
    vec![
        ("ds_controller", |t, ns| from_str_in::<ds_controller::Params>(t, "ds_controller", ns, "test").map_err(e)?.validate("test").map_err(e)),
        ("fded_distance", |t, ns| from_str_in::<fded_distance::Params>(t, "fded_distance", ns, "test").map_err(e)?.validate("test").map_err(e)),
        ("human_observer", |t, ns| {
            from_str_in::<human_observer::Params>(t, "human_observer", ns, "test").map_err(e)?.validate("test").map_err(e)
        }),
        ("robot_manager", |t, ns| from_str_in::<robot_manager::Params>(t, "robot_manager", ns, "test").map_err(e)?.validate("test").map_err(e)),
        ("attentional_supervisor", |t, ns| {
            from_str_in::<attentional_supervisor::Params>(t, "attentional_supervisor", ns, "test").map_err(e)?.validate("test").map_err(e)
        }),
        ("lwr_sim", |t, ns| from_str_in::<lwr_sim::LwrSimConfig>(t, "lwr_sim", ns, "test").map_err(e)?.validate("test").map_err(e)),
    ]
}

/// Paths (keys and list indices) of every floating-point leaf under `v`.
fn float_leaves(v: &Value, path: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    match v {
        Value::Number(n) if n.is_f64() => out.push(path.clone()),
        Value::Mapping(m) => {
            for (k, child) in m {
                path.push(k.clone());
                float_leaves(child, path, out);
                path.pop();
            }
        }
        Value::Sequence(s) => {
            for (i, child) in s.iter().enumerate() {
                path.push(Value::Number(i.into()));
                float_leaves(child, path, out);
                path.pop();
            }
        }
        _ => {}
    }
}

fn get_mut<'a>(v: &'a mut Value, path: &[Value]) -> Option<&'a mut Value> {
    path.iter().try_fold(v, |node, k| match (node, k) {
        (Value::Mapping(m), k) => m.get_mut(k),
        (Value::Sequence(s), Value::Number(i)) => s.get_mut(i.as_u64()? as usize),
        _ => None,
    })
}

/// The namespace a node must be started in to read the block a leaf is in: `/left` for the
/// block `/left/ds_controller`, `None` for the plain block.
fn namespace_of(path: &[Value]) -> Option<String> {
    let block = path.first()?.as_str()?;
    let (ns, _node) = block.rsplit_once('/')?;
    (!ns.is_empty()).then(|| ns.to_owned())
}

/// The key a message should name: the innermost mapping key on the path.
fn key_name(path: &[Value]) -> String {
    path.iter().rev().find_map(|k| k.as_str().map(str::to_owned)).unwrap_or_default()
}

#[test]
fn every_float_parameter_set_non_finite_is_refused_naming_its_key() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut failures = Vec::new();
    let mut tried = 0;
    for (node, check) in checks() {
        let text = std::fs::read_to_string(root.join(format!("config/{node}.yaml"))).expect("parameter file");
        let doc: Value = serde_yaml_ng::from_str(&text).expect("YAML");
        let mut leaves = Vec::new();
        float_leaves(&doc, &mut Vec::new(), &mut leaves);
        assert!(!leaves.is_empty(), "{node}: no float parameter found");
        let mut namespaces: Vec<Option<String>> = leaves.iter().map(|l| namespace_of(l)).collect();
        namespaces.dedup();
        for ns in &namespaces {
            check(&text, ns.as_deref()).unwrap_or_else(|e| panic!("the bundled config/{node}.yaml must load in namespace {ns:?}: {e}"));
        }
        for leaf in &leaves {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut changed = doc.clone();
                let slot = get_mut(&mut changed, leaf).expect("leaf path");
                *slot = Value::Number(bad.into());
                let yaml = serde_yaml_ng::to_string(&changed).expect("YAML out");
                tried += 1;
                let key = key_name(leaf);
                let where_ = leaf.iter().map(|k| serde_yaml_ng::to_string(k).unwrap_or_default().trim().to_owned()).collect::<Vec<_>>().join(".");
                // Documented: `.inf` means no fading of the modulation with distance.
                let allowed = node == "ds_controller" && key == "influence_distance" && bad == f64::INFINITY;
                match check(&yaml, namespace_of(leaf).as_deref()) {
                    Ok(()) if allowed => {}
                    Ok(()) => failures.push(format!("{node}: {where_} = {bad} accepted")),
                    Err(msg) if !msg.contains(&key) => failures.push(format!("{node}: {where_} = {bad} refused without naming `{key}`: {msg}")),
                    Err(_) => {}
                }
            }
        }
    }
    println!("{tried} non-finite parameter values tried");
    assert!(failures.is_empty(), "{} of {tried}:\n{}", failures.len(), failures.join("\n"));
}
