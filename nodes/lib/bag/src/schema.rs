//! Comparison of `ros2msg` schema texts by their fields, ignoring comments, blank lines,
//! spacing, the order of dependency sections and the `pkg/msg/Name` vs `pkg/Name` spelling.

use std::collections::BTreeMap;

/// The fields of a `ros2msg` schema: section name (`""` for the top-level type, `pkg/Name`
/// for each `MSG:` dependency) → normalised field and constant lines.
pub type SchemaFields = BTreeMap<String, Vec<String>>;

/// Parses a full `ros2msg` definition into its sections of normalised lines.
pub fn schema_fields(text: &str) -> SchemaFields {
    let mut out = SchemaFields::new();
    let mut section = String::new();
    out.insert(section.clone(), Vec::new());
    for raw in text.lines() {
        let trimmed = raw.trim();
        if trimmed.len() >= 3 && trimmed.chars().all(|c| c == '=') {
            continue;
        }
        if let Some(name) = trimmed.strip_prefix("MSG:") {
            section = name.trim().replace("/msg/", "/");
            out.entry(section.clone()).or_default();
            continue;
        }
        let line = normalise_line(trimmed);
        if line.is_empty() {
            continue;
        }
        out.entry(section.clone()).or_default().push(line);
    }
    out
}

/// Strips the comment (except inside a string constant's value), collapses whitespace and
/// spaces around `=`, and writes type names as `pkg/Name`.
fn normalise_line(line: &str) -> String {
    let is_string_constant = line.starts_with("string")
        && line
            .find('=')
            .is_some_and(|eq| line.find('#').is_none_or(|hash| eq < hash));
    let code = if is_string_constant {
        line
    } else {
        line.split('#').next().unwrap_or("")
    };
    let joined = code.split_whitespace().collect::<Vec<_>>().join(" ");
    joined
        .replace(" = ", "=")
        .replace(" =", "=")
        .replace("= ", "=")
        .replace("/msg/", "/")
}

/// First difference between our definition and the bag's, or `None` when every section
/// present in both has the same fields (the bag may omit or add dependency sections).
pub fn first_difference(ours: &str, bag: &str) -> Option<String> {
    let ours = schema_fields(ours);
    let bag = schema_fields(bag);
    for (section, our_lines) in &ours {
        let Some(bag_lines) = bag.get(section) else {
            continue;
        };
        if our_lines == bag_lines {
            continue;
        }
        let name = if section.is_empty() {
            "top-level type"
        } else {
            section.as_str()
        };
        let i = our_lines
            .iter()
            .zip(bag_lines)
            .position(|(a, b)| a != b)
            .unwrap_or(our_lines.len().min(bag_lines.len()));
        let ours_line = our_lines.get(i).map_or("(nothing)", String::as_str);
        let bag_line = bag_lines.get(i).map_or("(nothing)", String::as_str);
        return Some(format!(
            "{name}, field line {}: expected `{ours_line}`, bag has `{bag_line}`",
            i + 1
        ));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comments_spacing_and_section_order_are_ignored() {
        let ours = "# a\nstd_msgs/Header header  # stamp\nuint32 height\nstring S=\"a#b\"\n\
                    ================================================================================\n\
                    MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n";
        let theirs = "std_msgs/msg/Header header\n\nuint32   height\nstring S = \"a#b\"\n\
                      ================================================================================\n\
                      MSG: std_msgs/msg/Header\n# c\nbuiltin_interfaces/msg/Time stamp\nstring frame_id";
        assert_eq!(first_difference(ours, theirs), None);
    }

    #[test]
    fn a_changed_field_is_named() {
        let ours = "uint32 height\nuint32 width\n";
        let theirs = "uint32 height\nuint16 width\n";
        let d = first_difference(ours, theirs).unwrap_or_default();
        assert!(d.contains("field line 2"), "{d}");
        assert!(d.contains("uint16 width"), "{d}");
    }
}
