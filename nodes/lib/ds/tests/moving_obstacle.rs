//! Fig. 5.5 (hold the end effector while a sphere flies through it) at 0.7 m/s: the hand is
//! never hit and the goal is regained. The speed sweep is `examples/moving_sphere.rs`.

#[allow(dead_code)]
#[path = "../examples/moving_sphere.rs"]
mod moving_sphere;

mod common;

#[test]
fn sphere_at_0_7_m_s_is_avoided_and_goal_regained() {
    let model = common::lwr();
    let r = moving_sphere::pass(&model, 0.7, 0.1);
    eprintln!(
        "0.7 m/s: hand min {:.4} m, arm min {:.4} m, final goal error {:.4} m",
        r.hand_min, r.arm_min, r.final_error
    );
    assert!(r.hand_min > 0.0, "hand hit: {} m", r.hand_min);
    assert!(
        r.final_error < 0.01,
        "goal not regained: {} m",
        r.final_error
    );
}
