//! Bad robot descriptions fail with one error that names the file and the element or field.

mod common;

use common::lwr_urdf;
use cowork_robot::{Error, RobotModel};
use std::path::{Path, PathBuf};

/// The LWR URDF text with mesh paths made absolute, so an edited copy can live anywhere.
fn lwr_text() -> String {
    let text = std::fs::read_to_string(lwr_urdf()).unwrap();
    let meshes = lwr_urdf().parent().unwrap().join("meshes/");
    text.replace(
        "filename=\"meshes/",
        &format!("filename=\"{}", meshes.display()),
    )
}

/// Writes `text` as `robot.urdf` in a fresh directory and loads it.
fn load(text: &str) -> (tempfile::TempDir, PathBuf, Result<RobotModel, Error>) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("robot.urdf");
    std::fs::write(&path, text).unwrap();
    let result = RobotModel::from_urdf_file(&path);
    (dir, path, result)
}

fn message_names(err: &Error, path: &Path, words: &[&str]) {
    let msg = err.to_string();
    assert!(
        msg.contains(&path.display().to_string()),
        "`{msg}` does not name {}",
        path.display()
    );
    for w in words {
        assert!(msg.contains(w), "`{msg}` does not mention `{w}`");
    }
}

#[test]
fn the_absolute_path_copy_loads() {
    let (_d, _p, r) = load(&lwr_text());
    assert_eq!(
        r.unwrap().mesh_vertex_count(),
        common::lwr().mesh_vertex_count()
    );
}

#[test]
fn missing_file() {
    let path = Path::new("/nonexistent/robot.urdf");
    let err = RobotModel::from_urdf_file(path).unwrap_err();
    assert!(matches!(err, Error::Io { ref urdf, .. } if urdf == path));
    message_names(&err, path, &[]);
}

#[test]
fn malformed_xml() {
    let text = lwr_text().replacen("</link>", "</lnk>", 1);
    let (_d, path, r) = load(&text);
    let err = r.unwrap_err();
    assert!(
        matches!(err, Error::Urdf { path: ref p, .. } if *p == path),
        "{err:?}"
    );
    message_names(&err, &path, &["malformed URDF"]);

    let (_d, path, r) = load("this is not xml");
    message_names(&r.unwrap_err(), &path, &["malformed URDF"]);
}

#[test]
fn missing_mesh_names_link_and_file() {
    let text = std::fs::read_to_string(lwr_urdf()).unwrap(); // relative paths, no meshes beside
    let (_d, path, r) = load(&text);
    let err = r.unwrap_err();
    match &err {
        Error::MissingMesh {
            urdf,
            link,
            uri,
            path: mesh,
            ..
        } => {
            assert_eq!(urdf, &path);
            assert_eq!(link, "lwr_base_link");
            assert_eq!(uri, "meshes/lwr_base_link.stl");
            assert_eq!(
                mesh,
                &path.parent().unwrap().join("meshes/lwr_base_link.stl")
            );
        }
        other => panic!("{other:?}"),
    }
    message_names(&err, &path, &["lwr_base_link", "meshes/lwr_base_link.stl"]);
}

#[test]
fn bad_mesh_files() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("junk.stl"),
        b"solid x\nfacet normal nonsense\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("arm.dae"), b"<COLLADA/>").unwrap();
    for (file, word) in [("junk.stl", "junk.stl"), ("arm.dae", "only STL")] {
        let text = lwr_text().replace(
            &format!(
                "{}/lwr_link_4.stl",
                lwr_urdf().parent().unwrap().join("meshes").display()
            ),
            &dir.path().join(file).display().to_string(),
        );
        let (_d, path, r) = load(&text);
        let err = r.unwrap_err();
        assert!(
            matches!(err, Error::BadMesh { ref link, .. } if link == "lwr_link_4"),
            "{err:?}"
        );
        message_names(&err, &path, &["lwr_link_4", word]);
    }
}

#[test]
fn wrong_number_of_joints() {
    // Freeze A7: six actuated joints.
    let text = lwr_text().replace(
        "<joint name=\"lwr_joint_7\" type=\"revolute\">",
        "<joint name=\"lwr_joint_7\" type=\"fixed\">",
    );
    let (_d, path, r) = load(&text);
    let err = r.unwrap_err();
    assert!(
        matches!(
            err,
            Error::DofMismatch {
                found: 6,
                required: 7,
                ..
            }
        ),
        "{err:?}"
    );
    message_names(&err, &path, &["lwr_base_link", "lwr_ee_link", "6", "7"]);

    // Make the tool joint revolute: eight.
    let text = lwr_text().replace(
        "<joint name=\"lwr_ee_joint\" type=\"fixed\">",
        "<joint name=\"lwr_ee_joint\" type=\"revolute\"><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" velocity=\"1\"/>",
    );
    let (_d, _path, r) = load(&text);
    assert!(matches!(
        r.unwrap_err(),
        Error::DofMismatch {
            found: 8,
            required: 7,
            ..
        }
    ));
}

/// Replaces the `<limit>` of `joint` in the LWR text.
fn with_limit(joint: &str, limit: &str) -> String {
    let text = lwr_text();
    let start = text.find(&format!("<joint name=\"{joint}\"")).unwrap();
    let l0 = start + text[start..].find("<limit").unwrap();
    let l1 = l0 + text[l0..].find("/>").unwrap() + 2;
    format!("{}{limit}{}", &text[..l0], &text[l1..])
}

#[test]
fn nan_inverted_and_missing_limits() {
    let cases = [
        (
            "<limit lower=\"nan\" upper=\"1\" effort=\"1\" velocity=\"1\"/>",
            "lower",
        ),
        (
            "<limit lower=\"-1\" upper=\"NaN\" effort=\"1\" velocity=\"1\"/>",
            "upper",
        ),
        (
            "<limit lower=\"-1\" upper=\"inf\" effort=\"1\" velocity=\"1\"/>",
            "upper",
        ),
        (
            "<limit lower=\"1\" upper=\"-1\" effort=\"1\" velocity=\"1\"/>",
            "lower",
        ),
        (
            "<limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"nan\"/>",
            "velocity",
        ),
        (
            "<limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"-2\"/>",
            "velocity",
        ),
        ("", "lower"), // no <limit> at all: urdf-rs reads zeros, an empty range
    ];
    for (limit, field) in cases {
        let (_d, path, r) = load(&with_limit("lwr_joint_3", limit));
        let err = r.unwrap_err();
        match &err {
            Error::BadLimit {
                joint, field: f, ..
            } => {
                assert_eq!(joint, "lwr_joint_3");
                assert_eq!(*f, field, "{limit}");
            }
            other => panic!("{limit}: {other:?}"),
        }
        message_names(&err, &path, &["lwr_joint_3", field]);
    }
}

#[test]
fn bad_axis_and_origin() {
    let text = lwr_text().replacen("<axis xyz=\"0 1 0\"/>", "<axis xyz=\"0 0 0\"/>", 1);
    let (_d, path, r) = load(&text);
    let err = r.unwrap_err();
    assert!(
        matches!(err, Error::BadAxis { ref joint, .. } if joint == "lwr_joint_2"),
        "{err:?}"
    );
    message_names(&err, &path, &["lwr_joint_2", "axis"]);

    let text = lwr_text().replacen(
        "<origin xyz=\"0 0 0.2\" rpy=\"0 0 0\"/>",
        "<origin xyz=\"0 0 0.2\" rpy=\"0 nan 0\"/>",
        1,
    );
    let (_d, path, r) = load(&text);
    let err = r.unwrap_err();
    assert!(
        matches!(err, Error::NonFinite { field: "rpy", .. }),
        "{err:?}"
    );
    message_names(&err, &path, &["lwr_joint_2", "rpy"]);
}

#[test]
fn structure_errors() {
    // Prismatic joint on the chain.
    let text = lwr_text().replace(
        "<joint name=\"lwr_joint_5\" type=\"revolute\">",
        "<joint name=\"lwr_joint_5\" type=\"prismatic\">",
    );
    let (_d, path, r) = load(&text);
    let err = r.unwrap_err();
    assert!(
        matches!(err, Error::UnsupportedJoint { ref kind, .. } if kind == "prismatic"),
        "{err:?}"
    );
    message_names(&err, &path, &["lwr_joint_5", "prismatic"]);

    // A joint naming a link that does not exist.
    let text = lwr_text().replace(
        "<parent link=\"lwr_link_3\"/>",
        "<parent link=\"lwr_link_33\"/>",
    );
    let (_d, path, r) = load(&text);
    let err = r.unwrap_err();
    assert!(
        matches!(err, Error::BadJointLink { field: "parent", ref link, .. } if link == "lwr_link_33"),
        "{err:?}"
    );
    message_names(&err, &path, &["lwr_joint_4", "lwr_link_33"]);

    // Two roots.
    let text = lwr_text().replace("</robot>", "<link name=\"floating\"/></robot>");
    let (_d, path, r) = load(&text);
    let err = r.unwrap_err();
    assert!(
        matches!(err, Error::Root { ref roots, .. } if roots.len() == 2),
        "{err:?}"
    );
    message_names(&err, &path, &["floating"]);

    // Two equally deep tips.
    let text = lwr_text().replace(
        "</robot>",
        "<link name=\"camera\"/><joint name=\"cam\" type=\"fixed\"><parent link=\"lwr_link_7\"/><child link=\"camera\"/></joint></robot>",
    );
    let (_d, path, r) = load(&text);
    let err = r.unwrap_err();
    assert!(matches!(err, Error::AmbiguousTip { .. }), "{err:?}");
    message_names(&err, &path, &["camera", "lwr_ee_link"]);
    // ...which naming the tip resolves.
    let m = RobotModel::from_urdf_file_with_tip(&path, "camera").unwrap();
    assert_eq!(m.link_names().last().unwrap(), "camera");
    let err = RobotModel::from_urdf_file_with_tip(&path, "nope").unwrap_err();
    assert!(matches!(err, Error::UnknownTip { .. }));
    message_names(&err, &path, &["nope"]);
}

#[test]
fn package_uris_resolve_beside_or_above_the_urdf() {
    // Beside: config/robot/lwr4plus.urdf with package://cowork_description/meshes/...
    let text = std::fs::read_to_string(lwr_urdf()).unwrap().replace(
        "filename=\"meshes/",
        "filename=\"package://cowork_description/meshes/",
    );
    let m = RobotModel::from_urdf_str(&text, lwr_urdf().parent().unwrap()).unwrap();
    assert_eq!(m.mesh_vertex_count(), common::lwr().mesh_vertex_count());
    // Above (ROS layout): the other arm's URDF in urdf/ and its mesh in ../meshes.
    assert!(common::other().link_mesh(6).is_some());
    // Unresolvable: the error names the URI and the first candidate.
    let dir = tempfile::tempdir().unwrap();
    let err = RobotModel::from_urdf_str(&text, dir.path()).unwrap_err();
    match &err {
        Error::MissingMesh {
            uri, path, urdf, ..
        } => {
            assert_eq!(uri, "package://cowork_description/meshes/lwr_base_link.stl");
            assert_eq!(path, &dir.path().join("meshes/lwr_base_link.stl"));
            assert_eq!(urdf, &dir.path().join("<inline URDF>"));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn primitive_capsule_and_bad_sizes() {
    let text = lwr_text().replacen(
        &format!(
            "<mesh filename=\"{}/lwr_link_2.stl\"/>",
            lwr_urdf().parent().unwrap().join("meshes").display()
        ),
        "<capsule radius=\"0.07\" length=\"0.2\"/>",
        2,
    );
    let (_d, _path, r) = load(&text);
    let m = r.unwrap();
    let (lo, hi) = m.link_mesh(2).unwrap().aabb().unwrap();
    assert!(
        (hi.z - 0.17).abs() < 1e-12 && (lo.z + 0.17).abs() < 1e-12,
        "{lo} {hi}"
    );

    let text = lwr_text().replacen(
        &format!(
            "<mesh filename=\"{}/lwr_link_2.stl\"/>",
            lwr_urdf().parent().unwrap().join("meshes").display()
        ),
        "<sphere radius=\"-1\"/>",
        2,
    );
    let (_d, path, r) = load(&text);
    let err = r.unwrap_err();
    assert!(
        matches!(
            err,
            Error::NonFinite {
                field: "radius",
                ..
            }
        ),
        "{err:?}"
    );
    message_names(&err, &path, &["lwr_link_2", "radius"]);
}
