//! The Rust structs, the `.msg` files and the declared dependencies agree, and the full
//! `ros2msg` definitions have the shape rosbag2 writes.

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use common::{Kind, parse_msg, record_fields};
use cowork_msgs::{
    DEFINITION_SEPARATOR, RosMessage, known_types, msg, sensor_msgs, std_msgs, with_message_type,
};

fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Rust type of a `.msg` constant type.
fn rust_constant_type(msg_type: &str) -> &'static str {
    match msg_type {
        "bool" => "bool",
        "byte" | "char" | "uint8" => "u8",
        "int8" => "i8",
        "uint16" => "u16",
        "int16" => "i16",
        "uint32" => "u32",
        "int32" => "i32",
        "uint64" => "u64",
        "int64" => "i64",
        "float32" => "f32",
        "float64" => "f64",
        "string" => "&'static str",
        _ => "<not a constant type>",
    }
}

/// Every mismatch between `T` and its `.msg`, as readable lines.
fn check_type<T: RosMessage>() -> Vec<String> {
    let mut problems = Vec::new();
    let ty = T::type_name();
    let spec = match parse_msg(T::MSG) {
        Ok(spec) => spec,
        Err(e) => return vec![format!("{ty}: .msg does not parse: {e}")],
    };

    // Dependencies: exactly the non-primitive field types.
    let used: BTreeSet<String> = spec
        .fields
        .iter()
        .filter_map(|f| f.dependency(T::PACKAGE))
        .collect();
    let declared: BTreeSet<String> = T::DEPENDENCIES
        .iter()
        .map(|d| format!("{}/{}", d.package, d.name))
        .collect();
    if T::DEPENDENCIES.len() != declared.len() {
        problems.push(format!(
            "{ty}: a dependency is declared twice: {declared:?}"
        ));
    }
    for missing in used.difference(&declared) {
        problems.push(format!(
            "{ty}: field type {missing} is not a declared dependency"
        ));
    }
    for extra in declared.difference(&used) {
        problems.push(format!(
            "{ty}: declared dependency {extra} is not used by any field"
        ));
    }

    // Fields: same names, order and kinds.
    match record_fields(&T::default()) {
        Err(e) => problems.push(format!("{ty}: cannot record fields: {e}")),
        Ok((struct_name, fields)) => {
            if struct_name != T::NAME {
                problems.push(format!("{ty}: Rust struct is called {struct_name}"));
            }
            let rust_names: Vec<&str> = fields.iter().map(|(n, _)| *n).collect();
            let msg_names: Vec<&str> = spec.fields.iter().map(|f| f.name.as_str()).collect();
            if rust_names != msg_names {
                problems.push(format!(
                    "{ty}: Rust fields {rust_names:?} != .msg fields {msg_names:?}"
                ));
            } else {
                for ((name, kind), field) in fields.iter().zip(&spec.fields) {
                    let expected = Kind::expected(field);
                    if !expected.contains(kind) {
                        problems.push(format!(
                            "{ty}.{name}: Rust serialises as {kind:?}, .msg type {}{:?} wants {expected:?}",
                            field.base, field.array
                        ));
                    }
                }
            }
        }
    }

    // Constants: same names, types and values, in .msg order.
    let msg_constants: Vec<(String, &str, String)> = spec
        .constants
        .iter()
        .map(|c| (c.name.clone(), rust_constant_type(&c.ty), c.value.clone()))
        .collect();
    let rust_constants: Vec<(String, &str, String)> = T::CONSTANTS
        .iter()
        .map(|c| (c.name.to_string(), c.rust_type, c.value.to_string()))
        .collect();
    if msg_constants != rust_constants {
        problems.push(format!(
            "{ty}: constants differ:\n  .msg: {msg_constants:?}\n  Rust: {rust_constants:?}"
        ));
    }
    problems
}

#[test]
fn every_struct_matches_its_msg_file() {
    let mut problems = Vec::new();
    for info in known_types() {
        let found = with_message_type!(&info.type_name(), T => check_type::<T>());
        match found {
            Some(p) => problems.extend(p),
            None => problems.push(format!(
                "{} is in known_types but not dispatchable",
                info.type_name()
            )),
        }
    }
    assert!(
        problems.is_empty(),
        "{} problems:\n{}",
        problems.len(),
        problems.join("\n")
    );
}

fn msg_files(dir: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "msg"))
        .collect();
    out.sort();
    out
}

#[test]
fn every_msg_file_is_a_known_type_and_vice_versa() {
    let root = manifest_dir();
    let mut files: Vec<(String, PathBuf)> = msg_files(&root.join("msg"))
        .into_iter()
        .map(|p| ("cowork_msgs".to_string(), p))
        .collect();
    for pkg in std::fs::read_dir(root.join("ros_std")).expect("ros_std") {
        let pkg = pkg.expect("entry").path();
        let name = pkg
            .file_name()
            .and_then(|n| n.to_str())
            .expect("utf-8 name")
            .to_string();
        files.extend(
            msg_files(&pkg.join("msg"))
                .into_iter()
                .map(|p| (name.clone(), p)),
        );
    }
    let mut from_files = BTreeSet::new();
    for (pkg, path) in &files {
        let name = path
            .file_stem()
            .and_then(|n| n.to_str())
            .expect("utf-8 name");
        let type_name = format!("{pkg}/msg/{name}");
        let text = std::fs::read_to_string(path).expect("read .msg");
        let own = with_message_type!(&type_name, T => T::MSG.to_string());
        assert_eq!(
            own.as_deref(),
            Some(text.as_str()),
            "{} is not the MSG of a known type {type_name}",
            path.display()
        );
        from_files.insert(type_name);
    }
    let known: BTreeSet<String> = known_types().iter().map(|t| t.type_name()).collect();
    assert_eq!(from_files, known);
    assert_eq!(known.len(), known_types().len(), "a type is listed twice");
}

#[test]
fn colcon_package_lists_every_custom_msg_and_dependency() {
    let root = manifest_dir();
    let cmake = std::fs::read_to_string(root.join("CMakeLists.txt")).expect("CMakeLists.txt");
    let package_xml = std::fs::read_to_string(root.join("package.xml")).expect("package.xml");
    let listed: BTreeSet<String> = cmake
        .lines()
        .map(str::trim)
        .filter_map(|l| l.strip_prefix("\"msg/").and_then(|l| l.strip_suffix('"')))
        .map(str::to_string)
        .collect();
    let files: BTreeSet<String> = msg_files(&root.join("msg"))
        .iter()
        .filter_map(|p| p.file_name().and_then(|n| n.to_str()).map(str::to_string))
        .collect();
    assert_eq!(listed, files, "CMakeLists.txt msg_files != msg/*.msg");

    let deps_line = cmake
        .lines()
        .find_map(|l| l.trim().strip_prefix("DEPENDENCIES "))
        .expect("DEPENDENCIES line");
    let cmake_deps: BTreeSet<&str> = deps_line.split_whitespace().collect();
    let mut used = BTreeSet::new();
    for info in known_types().iter().filter(|t| t.package == "cowork_msgs") {
        let deps = with_message_type!(&info.type_name(), T => T::DEPENDENCIES).expect("known");
        used.extend(
            deps.iter()
                .map(|d| d.package)
                .filter(|p| *p != "cowork_msgs"),
        );
    }
    for pkg in &used {
        assert!(
            cmake_deps.contains(pkg),
            "{pkg} missing from rosidl DEPENDENCIES"
        );
        assert!(
            cmake.contains(&format!("find_package({pkg} REQUIRED)")),
            "find_package({pkg}) missing"
        );
        assert!(
            package_xml.contains(&format!("<depend>{pkg}</depend>")),
            "<depend>{pkg}</depend> missing"
        );
    }
    assert!(package_xml.contains("<member_of_group>rosidl_interface_packages</member_of_group>"));
    assert!(package_xml.contains("<package format=\"3\">"));
}

/// Splits a full definition into (section name, text); the first section is the root ("").
fn sections(def: &str) -> Vec<(String, String)> {
    let mut out = vec![(String::new(), String::new())];
    let mut lines = def.split('\n').peekable();
    while let Some(line) = lines.next() {
        if line == DEFINITION_SEPARATOR {
            let header = lines.next().expect("MSG: line after the separator");
            let name = header.strip_prefix("MSG: ").expect("MSG: prefix");
            out.push((name.to_string(), String::new()));
        } else if let Some((_, text)) = out.last_mut() {
            text.push_str(line);
            text.push('\n');
        }
    }
    out
}

#[test]
fn joint_state_definition_has_header_and_time_sections() {
    let def = sensor_msgs::JointState::ros2msg_definition();
    assert!(def.starts_with(sensor_msgs::JointState::MSG));
    assert!(def.contains("\n================================================================================\nMSG: std_msgs/Header\n"));
    assert!(def.contains("\nMSG: builtin_interfaces/Time\n"));
    let names: Vec<String> = sections(&def).into_iter().map(|(n, _)| n).collect();
    assert_eq!(names, ["", "std_msgs/Header", "builtin_interfaces/Time"]);
}

#[test]
fn definition_order_is_rosbag2_order_and_deduplicated() {
    // RobotStream -> {cowork_msgs/ActionEvent, cowork_msgs/ActionSegment, geometry_msgs/Pose,
    // std_msgs/Header}, each type's dependencies visited in byte order, depth-first, once.
    let def = msg::RobotStream::ros2msg_definition();
    let names: Vec<String> = sections(&def).into_iter().map(|(n, _)| n).collect();
    assert_eq!(
        names,
        [
            "",
            "cowork_msgs/ActionEvent",
            "cowork_msgs/ActionSegment",
            "builtin_interfaces/Time",
            "geometry_msgs/Pose",
            "geometry_msgs/Point",
            "geometry_msgs/Quaternion",
            "std_msgs/Header",
        ]
    );
    // geometry_msgs/Pose's own text uses unqualified names, still resolved in its package.
    let pose = sections(&def)
        .into_iter()
        .find(|(n, _)| n == "geometry_msgs/Pose")
        .expect("Pose");
    assert!(pose.1.contains("Point position"));
}

#[test]
fn every_definition_has_each_transitive_dependency_exactly_once() {
    fn transitive(d: &cowork_msgs::TypeDescription, out: &mut BTreeSet<String>) {
        for dep in d.dependencies {
            if out.insert(format!("{}/{}", dep.package, dep.name)) {
                transitive(dep, out);
            }
        }
    }
    for info in known_types() {
        let (desc, def) =
            with_message_type!(&info.type_name(), T => (T::DESCRIPTION, T::ros2msg_definition()))
                .expect("known");
        let mut expected = BTreeSet::new();
        transitive(&desc, &mut expected);
        let secs = sections(&def);
        let names: Vec<&str> = secs.iter().skip(1).map(|(n, _)| n.as_str()).collect();
        let unique: BTreeSet<String> = names.iter().map(|n| n.to_string()).collect();
        assert_eq!(
            unique.len(),
            names.len(),
            "{}: duplicate sections {names:?}",
            info.type_name()
        );
        assert_eq!(unique, expected, "{}", info.type_name());
        assert_eq!(def, (info.definition)(), "registry definition differs");
        // Each section's text is that type's own .msg text.
        for (name, text) in secs.iter().skip(1) {
            let own = with_message_type!(name, T => T::MSG).expect("section names a known type");
            let mut own_text = own.to_string();
            if !own_text.ends_with('\n') {
                own_text.push('\n');
            }
            assert!(
                text.starts_with(own) && text.len() <= own_text.len() + 1,
                "{name} section of {}",
                info.type_name()
            );
        }
    }
}

#[test]
fn type_and_dds_names() {
    assert_eq!(std_msgs::String::type_name(), "std_msgs/msg/String");
    assert_eq!(
        std_msgs::String::dds_type_name(),
        "std_msgs::msg::dds_::String_"
    );
    assert_eq!(
        msg::LinkDistances::type_name(),
        "cowork_msgs/msg/LinkDistances"
    );
    assert_eq!(
        msg::LinkDistances::dds_type_name(),
        "cowork_msgs::msg::dds_::LinkDistances_"
    );
    assert_eq!(msg::Skeleton::XSENS_SEGMENTS.len(), 11);
    assert_eq!(cowork_msgs::geometry_msgs::Quaternion::default().w, 1.0);
}
