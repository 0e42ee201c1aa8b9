//! Small dense helpers on row-major flat slices, used in the per-step evaluation paths so that
//! they need no heap allocation (nalgebra's `DMatrix` allocates on every product).

/// Cholesky factor `L` (lower, row-major `d×d`) of the symmetric positive definite `a`.
/// Returns `false` if `a` is not positive definite. Cost O(d³/6).
pub(crate) fn cholesky(a: &[f64], d: usize, l: &mut [f64]) -> bool {
    for v in l.iter_mut().take(d * d) {
        *v = 0.0;
    }
    for i in 0..d {
        for j in 0..=i {
            let mut s = a[i * d + j];
            for k in 0..j {
                s -= l[i * d + k] * l[j * d + k];
            }
            if i == j {
                if !(s > 0.0) || !s.is_finite() {
                    return false;
                }
                l[i * d + i] = s.sqrt();
            } else {
                l[i * d + j] = s / l[j * d + j];
            }
        }
    }
    true
}

/// Solves `L z = b` in place (forward substitution), `L` lower triangular row-major `d×d`.
#[inline]
pub(crate) fn solve_lower(l: &[f64], d: usize, b: &mut [f64]) {
    for i in 0..d {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i * d + k] * b[k];
        }
        b[i] = s / l[i * d + i];
    }
}

/// Solves `Lᵀ z = b` in place (back substitution).
#[inline]
pub(crate) fn solve_upper_t(l: &[f64], d: usize, b: &mut [f64]) {
    for i in (0..d).rev() {
        let mut s = b[i];
        for k in i + 1..d {
            s -= l[k * d + i] * b[k];
        }
        b[i] = s / l[i * d + i];
    }
}

/// `ln det(A)` from its Cholesky factor.
pub(crate) fn chol_logdet(l: &[f64], d: usize) -> f64 {
    (0..d).map(|i| 2.0 * l[i * d + i].ln()).sum()
}

/// Inverse of an SPD matrix from its Cholesky factor, written to `inv` (row-major `d×d`).
pub(crate) fn chol_inverse(l: &[f64], d: usize, inv: &mut [f64]) {
    let mut col = vec![0.0; d];
    for j in 0..d {
        col.iter_mut().for_each(|v| *v = 0.0);
        col[j] = 1.0;
        solve_lower(l, d, &mut col);
        solve_upper_t(l, d, &mut col);
        for i in 0..d {
            inv[i * d + j] = col[i];
        }
    }
}

/// `ln Σ exp(v)` computed stably.
pub(crate) fn logsumexp(v: &[f64]) -> f64 {
    let m = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !m.is_finite() {
        return m;
    }
    m + v.iter().map(|x| (x - m).exp()).sum::<f64>().ln()
}

/// `ln 2π`.
pub(crate) const LN_2PI: f64 = 1.837_877_066_409_345_3;
