//! `sensor_msgs/JointState` → joint positions in a model's order.

use cowork_msgs::sensor_msgs::JointState;

/// Fills `q` with the positions of the joints `names` (model order, rad) from `msg`, matched
/// by name, or by position when the message names none (then it must have exactly `q.len()`).
/// Errors say what is wrong: a missing joint, names and positions of different lengths, a
/// non-finite position.
pub fn joint_positions(names: &[String], msg: &JointState, q: &mut [f64]) -> Result<(), String> {
    if msg.name.is_empty() {
        if msg.position.len() != q.len() {
            return Err(format!("{} positions without names, expected {}", msg.position.len(), q.len()));
        }
        q.copy_from_slice(&msg.position);
    } else {
        if msg.name.len() != msg.position.len() {
            return Err(format!("{} names but {} positions", msg.name.len(), msg.position.len()));
        }
        for (j, want) in names.iter().enumerate().take(q.len()) {
            let Some(i) = msg.name.iter().position(|n| n == want) else {
                return Err(format!("joint {want} missing"));
            };
            q[j] = msg.position[i];
        }
    }
    if let Some((j, v)) = q.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(format!("position of {} is {v}", names.get(j).map_or("?", String::as_str)));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn by_name_by_position_and_the_errors() {
        let names: Vec<String> = ["a", "b"].iter().map(|s| (*s).to_owned()).collect();
        let mut q = [0.0; 2];
        let msg = |n: &[&str], p: &[f64]| JointState {
            name: n.iter().map(|s| (*s).to_owned()).collect(),
            position: p.to_vec(),
            ..JointState::default()
        };
        joint_positions(&names, &msg(&["b", "a"], &[2.0, 1.0]), &mut q).expect("by name");
        assert_eq!(q, [1.0, 2.0]);
        joint_positions(&names, &msg(&[], &[3.0, 4.0]), &mut q).expect("by position");
        assert_eq!(q, [3.0, 4.0]);
        assert!(joint_positions(&names, &msg(&["a"], &[1.0]), &mut q).expect_err("missing").contains("joint b missing"));
        assert!(joint_positions(&names, &msg(&["a", "b"], &[1.0]), &mut q).expect_err("lengths").contains("2 names but 1"));
        assert!(joint_positions(&names, &msg(&[], &[1.0, f64::NAN]), &mut q).expect_err("nan").contains("position of b"));
    }
}
