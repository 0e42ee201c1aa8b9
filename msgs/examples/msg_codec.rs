//! JSON <-> CDR codec over the message registry, for cross-checks against other
//! implementations (tests/crosscheck/check_msgs.sh).
//!
//! ```text
//! msg_codec types           # JSON array: {type, msg, definition, dds_type, constants} per known type
//! msg_codec encode < in     # in:  [{type, value}]     out: [{type, cdr_hex}]
//! msg_codec decode < in     # in:  [{type, cdr_hex}]   out: [{type, value}]
//! ```

use std::io::Read;

use anyhow::{Context, Result, bail};
use cowork_msgs::{RosMessage, find_type, known_types, with_message_type};
use serde_json::{Value, json};

fn main() -> Result<()> {
    let mode = std::env::args().nth(1).unwrap_or_default();
    let out = match mode.as_str() {
        "types" => types()?,
        "encode" => encode(&read_stdin()?)?,
        "decode" => decode(&read_stdin()?)?,
        other => bail!("unknown mode {other:?}; use types, encode or decode"),
    };
    println!("{}", serde_json::to_string(&out)?);
    Ok(())
}

fn read_stdin() -> Result<Vec<Value>> {
    let mut text = String::new();
    std::io::stdin()
        .read_to_string(&mut text)
        .context("reading stdin")?;
    serde_json::from_str(&text).context("stdin is not a JSON array")
}

fn types() -> Result<Value> {
    let mut out = Vec::new();
    for info in known_types() {
        let name = info.type_name();
        let entry = with_message_type!(&name, T => json!({
            "type": name,
            "msg": T::MSG,
            "definition": T::ros2msg_definition(),
            "dds_type": T::dds_type_name(),
            "constants": T::CONSTANTS.iter().map(|c| json!([c.name, c.rust_type, c.value])).collect::<Vec<_>>(),
        }))
        .with_context(|| format!("{name} is in the registry but not dispatchable"))?;
        out.push(entry);
    }
    Ok(Value::Array(out))
}

fn field<'a>(item: &'a Value, key: &str, index: usize) -> Result<&'a str> {
    item.get(key)
        .and_then(Value::as_str)
        .with_context(|| format!("item {index}: no string field {key:?}"))
}

fn encode(items: &[Value]) -> Result<Value> {
    let mut out = Vec::with_capacity(items.len());
    for (i, item) in items.iter().enumerate() {
        let ty = field(item, "type", i)?;
        let info = find_type(ty).with_context(|| format!("item {i}: unknown type {ty}"))?;
        let value = item
            .get("value")
            .with_context(|| format!("item {i}: no value"))?;
        let bytes = (info.json_to_cdr)(value).with_context(|| format!("item {i}"))?;
        out.push(json!({ "type": ty, "cdr_hex": hex(&bytes) }));
    }
    Ok(Value::Array(out))
}

fn decode(items: &[Value]) -> Result<Value> {
    let mut out = Vec::with_capacity(items.len());
    for (i, item) in items.iter().enumerate() {
        let ty = field(item, "type", i)?;
        let info = find_type(ty).with_context(|| format!("item {i}: unknown type {ty}"))?;
        let bytes = unhex(field(item, "cdr_hex", i)?).with_context(|| format!("item {i}"))?;
        let value = (info.cdr_to_json)(&bytes).with_context(|| format!("item {i}"))?;
        out.push(json!({ "type": ty, "value": value }));
    }
    Ok(Value::Array(out))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex(text: &str) -> Result<Vec<u8>> {
    if !text.is_ascii() || !text.len().is_multiple_of(2) {
        bail!("not an even number of ASCII hex digits");
    }
    (0..text.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&text[i..i + 2], 16).with_context(|| format!("bad hex at {i}")))
        .collect()
}
