//! DS modulation for reactive obstacle avoidance (thesis eq. 5.4–5.8) and the escape from
//! spurious attractors (Algorithm 5).
//!
//! All vectors are in the robot base frame; distances in m, velocities in m/s. The obstacle is
//! described by its closest point only (distance D and unit normal n̂ pointing away from the
//! obstacle), as fDED gives it, so no analytic surface is needed (Sec. 5.1.1, [136, 137]).

use nalgebra::{Matrix3, Unit, Vector3};

/// ε of eq. 5.6: the normal eigenvalue tends to ε as D → 0.
pub const EPSILON: f64 = 1e-5;

/// Orthonormal basis V = [n̂, t̂₁, t̂₂] (columns) of 3-D space with n̂ first.
///
/// Eq. 5.5's tangents `[−n₂, n₁, 0]`, `[−n₃, 0, n₁]` are orthogonal to n̂ but neither unit nor
/// mutually orthogonal, and vanish when n₁ = 0; so t̂₁ is built from the cross product of n̂ with
/// the coordinate axis least aligned with it (|component| smallest, hence never parallel) and
/// t̂₂ = n̂ × t̂₁. Right-handed, exact to rounding for any unit n̂.
pub fn orthonormal_basis(n: &Unit<Vector3<f64>>) -> Matrix3<f64> {
    let a = n.abs();
    let axis = if a.x <= a.y && a.x <= a.z {
        Vector3::x()
    } else if a.y <= a.z {
        Vector3::y()
    } else {
        Vector3::z()
    };
    let t1 = n.cross(&axis).normalize();
    let t2 = n.cross(&t1);
    Matrix3::from_columns(&[n.into_inner(), t1, t2])
}

/// Eigenvalues of eq. 5.6 for distance `d` (m; negative values count as 0): normal λ₁ =
/// 1 − (1 − ε)/(D + 1), tangential λᵢ = 1 + 1/(D + 1).
pub fn eigenvalues(d: f64, epsilon: f64) -> Vector3<f64> {
    let k = 1.0 / (d.max(0.0) + 1.0);
    let lt = 1.0 + k;
    Vector3::new(1.0 - (1.0 - epsilon) * k, lt, lt)
}

/// Modulation matrix M = V E V⁻¹ (eq. 5.7) with V from [`orthonormal_basis`] (so V⁻¹ = Vᵀ and M
/// is symmetric positive definite) and E from [`eigenvalues`].
pub fn modulation_matrix(n: &Unit<Vector3<f64>>, d: f64, epsilon: f64) -> Matrix3<f64> {
    let v = orthonormal_basis(n);
    modulation_matrix_in_basis(&v, d, epsilon)
}

/// [`modulation_matrix`] for an already built basis `v` (columns n̂, t̂₁, t̂₂).
pub fn modulation_matrix_in_basis(v: &Matrix3<f64>, d: f64, epsilon: f64) -> Matrix3<f64> {
    let e = eigenvalues(d, epsilon);
    v * Matrix3::from_diagonal(&e) * v.transpose()
}

/// Weight w(D) ∈ [0, 1] that fades the modulation out with distance: 1 up to `full` (m), a
/// cosine ramp to 0 at `zero` (m), 0 beyond. `zero` = ∞ gives 1 everywhere (eq. 5.6 as is).
///
/// Why: eq. 5.6 modulates at any distance (λ₁ = 0.5 at 1 m), so an obstacle that has passed
/// and flies away keeps dragging the robot through the (I − M) ẋ_O term of eq. 5.8, and a far
/// wall slows every motion. Fading M to I keeps M symmetric positive definite (eigenvalues
/// 1 + w (λ − 1) lie between λ and 1), so the equilibria are untouched, and keeps M continuous
/// in D, unlike a hard cut-off.
pub fn influence_weight(d: f64, full: f64, zero: f64) -> f64 {
    if d <= full {
        1.0
    } else if d >= zero {
        0.0
    } else {
        let s = (d - full) / (zero - full);
        0.5 * (1.0 + (std::f64::consts::PI * s).cos())
    }
}

/// [`eigenvalues`] faded by weight `w` ∈ [0, 1]: 1 + w (λ − 1).
pub fn weighted_eigenvalues(d: f64, epsilon: f64, w: f64) -> Vector3<f64> {
    eigenvalues(d, epsilon).map(|l| 1.0 + w * (l - 1.0))
}

/// M = V E_w Vᵀ with the faded eigenvalues of [`weighted_eigenvalues`].
pub fn weighted_modulation_matrix_in_basis(
    v: &Matrix3<f64>,
    d: f64,
    epsilon: f64,
    w: f64,
) -> Matrix3<f64> {
    v * Matrix3::from_diagonal(&weighted_eigenvalues(d, epsilon, w)) * v.transpose()
}

/// Modulated velocity with a moving obstacle, eq. 5.8: ẋ = M f + (I − M) ẋ_O, where `f` is the
/// (scaled) DS velocity and `obstacle_velocity` ẋ_O the velocity of the closest obstacle point
/// (m/s). With ẋ_O = 0 this is eq. 5.4.
pub fn modulate(
    m: &Matrix3<f64>,
    f: &Vector3<f64>,
    obstacle_velocity: &Vector3<f64>,
) -> Vector3<f64> {
    m * f + obstacle_velocity - m * obstacle_velocity
}

/// Parameters of Algorithm 5.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EscapeConfig {
    /// Apply the escape at all.
    pub enabled: bool,
    /// τ_ε: a modulated speed at or below this counts as stuck, a normal (or chosen tangential)
    /// speed above it as escaped (m/s).
    pub speed_threshold: f64,
    /// Distance at or below which the robot counts as on the obstacle surface, "D = 0" (m).
    pub contact_distance: f64,
    /// γ: speed of the tangential perturbation (m/s).
    pub perturbation_speed: f64,
}

impl Default for EscapeConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            speed_threshold: 1e-3,
            contact_distance: 0.01,
            perturbation_speed: 0.05,
        }
    }
}

/// State of Algorithm 5 across control steps.
///
/// Stuck: modulated speed ‖ẋ‖ ≤ τ_ε on the surface (D ≤ contact distance) while the DS itself
/// still wants to move (‖α f‖ > 2 τ_ε, so neither the goal nor a stop holds it). Then γ v̂ is
/// added along a tangential direction v̂ (that of f's tangential part, else t̂₁) until the
/// modulated velocity has n̂ᵀẋ > τ_ε or v̂ᵀẋ > τ_ε (Algorithm 5, lines 7–8; the strict "> 0"
/// of line 7 is taken with the same threshold so rounding cannot end the escape at once).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Escape {
    direction: Option<Vector3<f64>>,
}

impl Escape {
    /// Not escaping.
    pub fn new() -> Self {
        Self::default()
    }

    /// `true` while the perturbation is applied.
    pub fn active(&self) -> bool {
        self.direction.is_some()
    }

    /// Stops any escape in progress (e.g. on a new command).
    pub fn reset(&mut self) {
        self.direction = None;
    }

    /// One step of Algorithm 5: returns the velocity to command (m/s) given the modulated
    /// velocity `modulated`, the unmodulated scaled DS velocity `f`, the basis `v` of the
    /// closest obstacle and its distance `d` (m).
    pub fn step(
        &mut self,
        cfg: &EscapeConfig,
        v: &Matrix3<f64>,
        d: f64,
        f: &Vector3<f64>,
        modulated: &Vector3<f64>,
    ) -> Vector3<f64> {
        if !cfg.enabled {
            self.direction = None;
            return *modulated;
        }
        let tau = cfg.speed_threshold;
        let n = v.column(0).into_owned();
        let wants_to_move = f.norm() > 2.0 * tau;
        let on_surface = d <= cfg.contact_distance;
        if let Some(dir) = self.direction {
            // Keep v̂ tangent as the normal turns along the surface.
            let t = dir - n * n.dot(&dir);
            let escaped = n.dot(modulated) > tau || t.dot(modulated) > tau;
            if escaped || !wants_to_move || !on_surface || t.norm() < 1e-6 {
                self.direction = None;
            } else {
                let t = t.normalize();
                self.direction = Some(t);
                return modulated + t * cfg.perturbation_speed;
            }
        } else if on_surface && wants_to_move && modulated.norm() <= tau {
            let tangential = f - n * n.dot(f);
            let t = if tangential.norm() > tau {
                tangential.normalize()
            } else {
                v.column(1).into_owned()
            };
            self.direction = Some(t);
            return modulated + t * cfg.perturbation_speed;
        }
        *modulated
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_orthonormal_for_axes_and_diagonals() {
        for n in [
            Vector3::x(),
            Vector3::y(),
            -Vector3::z(),
            Vector3::new(1.0, 1.0, 1.0),
            Vector3::new(0.0, 1e-12, -1.0),
        ] {
            let n = Unit::new_normalize(n);
            let v = orthonormal_basis(&n);
            assert!(
                (v.transpose() * v - Matrix3::identity()).norm() < 1e-12,
                "{n:?}"
            );
            assert!((v.column(0) - n.into_inner()).norm() < 1e-15);
            assert!((v.determinant() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn influence_weight_is_continuous_and_bounded() {
        assert_eq!(influence_weight(0.2, 0.5, 1.0), 1.0);
        assert_eq!(influence_weight(1.2, 0.5, 1.0), 0.0);
        assert!((influence_weight(0.75, 0.5, 1.0) - 0.5).abs() < 1e-12);
        assert!((influence_weight(0.5 + 1e-9, 0.5, 1.0) - 1.0).abs() < 1e-9);
        assert!(influence_weight(1.0 - 1e-9, 0.5, 1.0) < 1e-9);
        assert_eq!(influence_weight(1e6, 0.5, f64::INFINITY), 1.0);
        let l = weighted_eigenvalues(0.0, EPSILON, 0.0);
        assert_eq!(l, Vector3::new(1.0, 1.0, 1.0));
    }

    #[test]
    fn eigenvalues_limits() {
        let e0 = eigenvalues(0.0, EPSILON);
        assert!((e0.x - EPSILON).abs() < 1e-15);
        assert_eq!(e0.y, 2.0);
        let far = eigenvalues(1e9, EPSILON);
        assert!((far.x - 1.0).abs() < 1e-8 && (far.y - 1.0).abs() < 1e-8);
        assert_eq!(eigenvalues(-0.5, EPSILON), e0);
    }

    #[test]
    fn moving_obstacle_velocity_is_followed_along_the_normal() {
        let n = Unit::new_normalize(Vector3::z());
        let m = modulation_matrix(&n, 0.0, EPSILON);
        let xo = Vector3::new(0.0, 0.0, 1.0);
        let v = modulate(&m, &Vector3::zeros(), &xo);
        // On the surface the robot moves away with the obstacle (1 − ε) along n̂.
        assert!((v.z - (1.0 - EPSILON)).abs() < 1e-12);
    }

    #[test]
    fn escape_leaves_a_spurious_attractor() {
        let cfg = EscapeConfig::default();
        let n = Unit::new_normalize(Vector3::z());
        let v = orthonormal_basis(&n);
        let m = modulation_matrix_in_basis(&v, 0.0, EPSILON);
        // DS pointing straight into the obstacle: modulated velocity ≈ 0.
        let f = Vector3::new(0.0, 0.0, -0.3);
        let xm = modulate(&m, &f, &Vector3::zeros());
        assert!(xm.norm() <= cfg.speed_threshold);
        let mut esc = Escape::new();
        let out = esc.step(&cfg, &v, 0.0, &f, &xm);
        assert!(esc.active());
        assert!((out.norm() - cfg.perturbation_speed).abs() < 1e-4);
        assert!(n.dot(&out).abs() < 1e-5);
        // Once the DS has a tangential component along v̂, the escape ends.
        let dir = out.normalize();
        let f2 = f + dir * 0.01;
        let out2 = esc.step(&cfg, &v, 0.0, &f2, &modulate(&m, &f2, &Vector3::zeros()));
        assert!(!esc.active());
        assert!((out2 - m * f2).norm() < 1e-15);
    }
}
