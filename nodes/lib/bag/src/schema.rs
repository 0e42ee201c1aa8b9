//! Comparison of `ros2msg` schemas by their resolved layout, not their text.
//!
//! Two definitions describe the same bytes when, field by field, they have the same type and
//! array shape once each type is resolved to `pkg/Name` — whatever the comments, blank lines,
//! spacing, constants, default values, order of the `MSG:` dependency sections, and whether a
//! type is written `pkg/msg/Name`, `pkg/Name` or package-relative (`RegionOfInterest` inside
//! `sensor_msgs/CameraInfo`, `Header` for `std_msgs/Header`). Bounds (`string<=10`, `T[<=3]`)
//! do not change the CDR layout and are dropped; `byte` and `char` are the `uint8` they are on
//! the wire. A definition that differs reports the type, the field and both declarations.

use std::collections::BTreeMap;

/// Nesting deeper than this is refused (a definition naming itself would never end).
const MAX_DEPTH: usize = 32;

/// One field as declared: resolved type (`uint32`, `pkg/Name`), array shape, name, and the line
/// it came from.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Field {
    ty: String,
    array: Array,
    name: String,
    line: String,
}

/// Array shape of a field; bounded sequences are plain sequences on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Array {
    None,
    Fixed(usize),
    Sequence,
}

/// Every type a definition declares: `pkg/Name` → fields (constants left out).
type Types = BTreeMap<String, Vec<Field>>;

const PRIMITIVES: &[&str] = &[
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
    "uint64", "string", "wstring",
];

/// `pkg/Name` for a type name as the bag spells it (`pkg/msg/Name`, `pkg/Name`, DDS `pkg::msg::dds_::Name_`).
fn canonical_type(name: &str) -> String {
    let name = name.trim();
    if let Some(rest) = name.strip_suffix('_')
        && rest.contains("::dds_::")
    {
        return rest.replace("::msg::dds_::", "/").replace("::", "/");
    }
    name.replace("/msg/", "/")
}

/// Resolves a field's base type written inside package `pkg`.
fn resolve(base: &str, pkg: &str) -> String {
    let base = base.split_once("<=").map_or(base, |(b, _)| b);
    match base {
        "byte" | "char" => "uint8".to_owned(),
        b if PRIMITIVES.contains(&b) => b.to_owned(),
        "Header" => "std_msgs/Header".to_owned(),
        b if b.contains('/') => canonical_type(b),
        b => format!("{pkg}/{b}"),
    }
}

/// Parses one declaration line (comment already stripped); `None` for constants.
fn parse_field(code: &str, pkg: &str, line: &str) -> Option<Field> {
    let mut words = code.split_whitespace();
    let ty = words.next()?;
    let rest: Vec<&str> = words.collect();
    let name_part = rest.first()?;
    // `TYPE NAME=VALUE` / `TYPE NAME = VALUE` is a constant: no bytes on the wire.
    if constant_eq(name_part).is_some() || rest.get(1).is_some_and(|w| w.starts_with('=')) {
        return None;
    }
    let (base, array) = match ty.split_once('[') {
        None => (ty, Array::None),
        Some((base, dims)) => {
            let dims = dims.trim_end_matches(']');
            let array = if dims.is_empty() || dims.starts_with("<=") {
                Array::Sequence
            } else {
                dims.parse().map_or(Array::Sequence, Array::Fixed)
            };
            (base, array)
        }
    };
    Some(Field { ty: resolve(base, pkg), array, name: (*name_part).to_owned(), line: line.to_owned() })
}

/// Position of the `=` of a constant (not the one of a `<=` bound).
fn constant_eq(line: &str) -> Option<usize> {
    line.char_indices().find(|&(i, c)| c == '=' && !line[..i].ends_with('<')).map(|(i, _)| i)
}

/// Drops a comment; a string constant (whose value may hold a `#`) is dropped whole, as
/// every constant is: constants have no bytes on the wire.
fn strip_comment(line: &str) -> &str {
    let is_string_constant = line.starts_with("string")
        && constant_eq(line).is_some_and(|eq| line.find('#').is_none_or(|hash| eq < hash));
    if is_string_constant { "" } else { line.split('#').next().unwrap_or("") }
}

/// Every type a full `ros2msg` definition of `top` declares.
fn parse(text: &str, top: &str) -> Types {
    let mut types = Types::new();
    let mut section = canonical_type(top);
    types.insert(section.clone(), Vec::new());
    for raw in text.lines() {
        let trimmed = raw.trim();
        if trimmed.len() >= 3 && trimmed.chars().all(|c| c == '=') {
            continue;
        }
        if let Some(name) = trimmed.strip_prefix("MSG:") {
            section = canonical_type(name);
            types.entry(section.clone()).or_default();
            continue;
        }
        let pkg = section.split('/').next().unwrap_or("").to_owned();
        if let Some(f) = parse_field(strip_comment(trimmed), &pkg, trimmed) {
            types.entry(section.clone()).or_default().push(f);
        }
    }
    types
}

fn shape(a: Array) -> String {
    match a {
        Array::None => String::new(),
        Array::Fixed(n) => format!("[{n}]"),
        Array::Sequence => "[]".to_owned(),
    }
}

/// Compares type `ty` field by field, descending into nested types both sides declare.
fn compare(ty: &str, ours: &Types, bag: &Types, depth: usize) -> Option<String> {
    if depth > MAX_DEPTH {
        return Some(format!("{ty}: nested more than {MAX_DEPTH} levels deep (a type that contains itself?)"));
    }
    // A type the bag does not spell out cannot contradict ours (it may omit dependencies).
    let (Some(o), Some(b)) = (ours.get(ty), bag.get(ty)) else { return None };
    for i in 0..o.len().max(b.len()) {
        match (o.get(i), b.get(i)) {
            (Some(of), Some(bf)) if of.ty == bf.ty && of.array == bf.array => {
                if !PRIMITIVES.contains(&of.ty.as_str())
                    && of.ty != "uint8"
                    && let Some(d) = compare(&of.ty, ours, bag, depth + 1)
                {
                    return Some(d);
                }
            }
            (of, bf) => {
                let decl = |f: Option<&Field>| {
                    f.map_or("(nothing)".to_owned(), |f| format!("{} (resolved: {}{} {})", f.line, f.ty, shape(f.array), f.name))
                };
                let name = of.or(bf).map_or("?", |f| f.name.as_str());
                return Some(format!(
                    "{ty}, field {} `{name}`: expected `{}`, bag has `{}`",
                    i + 1,
                    decl(of),
                    decl(bf)
                ));
            }
        }
    }
    None
}

/// First layout difference between our definition of `type_name` and the bag's, or `None`
/// when they describe the same bytes (see the module doc for what does not count).
pub fn first_difference(type_name: &str, ours: &str, bag: &str) -> Option<String> {
    let top = canonical_type(type_name);
    compare(&top, &parse(ours, &top), &parse(bag, &top), 0)
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
        assert_eq!(first_difference("sensor_msgs/msg/Image", ours, theirs), None);
    }

    /// What `rosbags` and other writers emit for the same types: package-relative or full
    /// names, defaults left out, bounds, `Header` alone.
    #[test]
    fn relative_names_defaults_and_bounds_are_the_same_layout() {
        let ours = "std_msgs/Header header\nRegionOfInterest roi\nfloat64[9] k\nstring<=8 frame\nint32[<=3] v\n\
                    ================================================================================\n\
                    MSG: sensor_msgs/RegionOfInterest\nuint32 x_offset 0\nbool do_rectify false\n\
                    ================================================================================\n\
                    MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n";
        let theirs = "Header header\nsensor_msgs/RegionOfInterest roi\nfloat64[9] k\nstring frame\nint32[] v\n\
                      ================================================================================\n\
                      MSG: std_msgs/Header\nbuiltin_interfaces/msg/Time stamp\nstring frame_id\n\
                      ================================================================================\n\
                      MSG: sensor_msgs/msg/RegionOfInterest\nuint32 x_offset\nbool do_rectify\n";
        assert_eq!(first_difference("sensor_msgs/msg/CameraInfo", ours, theirs), None);
    }

    #[test]
    fn a_changed_field_is_named_with_both_declarations() {
        let ours = "uint32 height\nuint32 width\n";
        let theirs = "uint32 height\nuint16 width\n";
        let d = first_difference("pkg/msg/T", ours, theirs).unwrap_or_default();
        assert!(d.contains("pkg/T, field 2 `width`"), "{d}");
        assert!(d.contains("expected `uint32 width") && d.contains("bag has `uint16 width"), "{d}");
    }

    #[test]
    fn a_difference_inside_a_nested_type_names_that_type() {
        let ours = "RegionOfInterest roi\nMSG: sensor_msgs/RegionOfInterest\nuint32 x_offset\nuint32 y_offset\n";
        let theirs = "RegionOfInterest roi\nMSG: sensor_msgs/RegionOfInterest\nuint32 x_offset\n";
        let d = first_difference("sensor_msgs/CameraInfo", ours, theirs).unwrap_or_default();
        assert!(d.contains("sensor_msgs/RegionOfInterest, field 2 `y_offset`") && d.contains("(nothing)"), "{d}");
        // Array shape matters: a fixed array is not a sequence.
        let d = first_difference("p/T", "float64[9] k\n", "float64[] k\n").unwrap_or_default();
        assert!(d.contains("float64[9] k") && d.contains("float64[] k"), "{d}");
    }

    #[test]
    fn constants_and_string_constants_with_hashes_are_not_fields() {
        let ours = "uint8 A=1\nstring S=\"x#y\"\nuint8 a\n";
        let theirs = "uint8 a  # the field\nuint8 A = 1\n";
        assert_eq!(first_difference("p/T", ours, theirs), None);
    }

    #[test]
    fn a_self_referencing_definition_is_refused_not_followed_forever() {
        let text = "p/T next\n";
        let d = first_difference("p/T", text, text).unwrap_or_default();
        assert!(d.contains("nested more than"), "{d}");
    }
}
