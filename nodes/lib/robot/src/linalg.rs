//! Damped least-squares pseudo-inverse and null-space projector for 7-column Jacobians.
//!
//! Allocation-free: every size is a compile-time constant.

use crate::model::{
    DOF, Jacobian, JacobianPinv, JointMatrix, PositionJacobian, PositionJacobianPinv,
};
use nalgebra::{Matrix3, Matrix6, SMatrix};

/// Damped pseudo-inverse of a 6×7 Jacobian: `J† = Jᵀ (J Jᵀ + λ² I)⁻¹`, λ = `damping`.
///
/// Why this form: the 7-DoF arm is redundant, so `J Jᵀ` is only 6×6 and a Cholesky solve of
/// `J Jᵀ + λ² I` is the cheapest exact way to get the minimum-norm solution. With λ > 0 the
/// matrix is positive definite and the solve always succeeds; near singularities the result
/// trades accuracy for bounded joint rates (Nakamura/Wampler damped least squares).
///
/// `damping` = 0 gives the plain Moore–Penrose pseudo-inverse. When λ² does not dominate the
/// rounding in `J Jᵀ` (λ = 0, or λ² below about 10⁻¹¹ of the largest diagonal entry of `J Jᵀ`)
/// or Cholesky fails, the result comes from the eigen-decomposition of `J Jᵀ + λ² I` instead,
/// treating eigenvalues below `6 · 10 ε · max eigenvalue` as zero; since `J Jᵀ` squares the
/// singular values, that ignores directions with σ below about 4·10⁻⁷ σ_max, so an exactly
/// singular `J` (stretched arm) gets the rank-deficient pseudo-inverse, not rounding noise
/// blown up. Both paths are allocation-free; the eigen path costs a few times more.
///
/// `damping` must be finite and ≥ 0 (units of J's entries; the position rows are m/rad, so mixing
/// rows makes λ a compromise); a NaN or ∞ in `J` or `damping` gives an all-NaN result.
pub fn damped_pseudo_inverse(j: &Jacobian, damping: f64) -> JacobianPinv {
    damped_pinv!(j, damping, Matrix6, JacobianPinv, 6)
}

/// Damped pseudo-inverse of a 3×7 position Jacobian (link-point tasks): `Jᵀ (J Jᵀ + λ² I)⁻¹`,
/// with the same rules as [`damped_pseudo_inverse`]. λ is in m/rad.
pub fn damped_pseudo_inverse_3(j: &PositionJacobian, damping: f64) -> PositionJacobianPinv {
    damped_pinv!(j, damping, Matrix3, PositionJacobianPinv, 3)
}

/// The body of both pseudo-inverses: one algorithm, instantiated for R = 6 and R = 3 rows
/// (nalgebra's Cholesky and symmetric eigen-decomposition need concrete sizes).
macro_rules! damped_pinv {
    ($j:expr, $damping:expr, $square:ident, $pinv:ident, $rows:literal) => {{
        let j = $j;
        let damping = $damping;
        let mut a: $square<f64> = j * j.transpose();
        for i in 0..$rows {
            a[(i, i)] += damping * damping;
        }
        // The iterative eigen solver is not meant for NaN/∞; answer NaN at once.
        if !a.iter().all(|x| x.is_finite()) {
            return $pinv::from_element(f64::NAN);
        }
        let cholesky = if damping_dominates_rounding(damping, a.diagonal().as_slice()) {
            a.cholesky()
        } else {
            None
        };
        match cholesky {
            Some(ch) => ch.solve(j).transpose(),
            None => {
                let eig = a.symmetric_eigen();
                let inv = pinv_from_eigen(eig.eigenvalues.as_slice(), $rows);
                let a_pinv = eig.eigenvectors
                    * $square::from_diagonal(&inv.fixed_rows::<$rows>(0).into_owned())
                    * eig.eigenvectors.transpose();
                j.transpose() * a_pinv
            }
        }
    }};
}
use damped_pinv;

/// Relative threshold below which an eigenvalue of `J Jᵀ` (a squared singular value) counts as
/// zero: rounding in forming `J Jᵀ` is of order ε·max eigenvalue.
const RANK_TOL: f64 = 10.0 * f64::EPSILON;

/// `true` when λ² is well above the rounding in `J Jᵀ`, so `J Jᵀ + λ² I` is safely positive
/// definite and Cholesky is accurate. Otherwise (λ = 0 or tiny) the matrix may be singular up
/// to rounding, where a Cholesky factorisation can still "succeed" on a noise-sized pivot and
/// return huge entries; the eigen path decides the rank instead.
fn damping_dominates_rounding(damping: f64, a_diag: &[f64]) -> bool {
    let scale = a_diag.iter().fold(0.0_f64, |m, &d| m.max(d));
    damping * damping > 1e3 * a_diag.len() as f64 * RANK_TOL * scale
}

/// Reciprocal eigenvalues with the small ones zeroed (first `n` entries used).
fn pinv_from_eigen(eigenvalues: &[f64], n: usize) -> nalgebra::SVector<f64, 6> {
    let max = eigenvalues.iter().fold(0.0_f64, |m, &e| m.max(e.abs()));
    let tol = n as f64 * RANK_TOL * max;
    let mut inv = nalgebra::SVector::<f64, 6>::zeros();
    for (i, &e) in eigenvalues.iter().enumerate().take(n) {
        if e > tol {
            inv[i] = 1.0 / e;
        }
    }
    inv
}

/// Null-space projector `N = I − J† J` (7×7) for a Jacobian with any number of rows `R` and its
/// (damped) pseudo-inverse. Joint rates `N q̇₀` do not disturb the task of `J` (exactly so only
/// for an undamped `J†`; with damping, to first order in λ²).
pub fn null_space_projector<const R: usize>(
    j: &SMatrix<f64, R, DOF>,
    j_pinv: &SMatrix<f64, DOF, R>,
) -> JointMatrix {
    JointMatrix::identity() - j_pinv * j
}
