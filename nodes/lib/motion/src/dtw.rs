//! Multi-dimensional dynamic time warping and k-nearest-neighbour classification
//! (thesis Sec. 3.1.4 and 3.2.3).
//!
//! The local cost is the squared Euclidean distance between samples; the DTW distance is the
//! square root of the accumulated cost along the optimal path (the convention of
//! `dtaidistance.dtw_ndim`). Sequences are row-major flat slices of `dim` columns.

use crate::error::{MotionError, Result, check_finite, invalid};

/// Optimal alignment of two sequences.
#[derive(Debug, Clone, PartialEq)]
pub struct Alignment {
    /// `sqrt(Σ ‖a_i − b_j‖²)` along the path.
    pub distance: f64,
    /// Index pairs `(i, j)` from `(0, 0)` to `(len_a − 1, len_b − 1)`.
    pub path: Vec<(usize, usize)>,
}

fn check(a: &[f64], b: &[f64], dim: usize) -> Result<(usize, usize)> {
    if dim == 0 {
        return Err(invalid("dim", "must be at least 1"));
    }
    for (name, s) in [("first sequence", a), ("second sequence", b)] {
        if s.len() % dim != 0 {
            return Err(MotionError::DimensionMismatch {
                what: format!("DTW {name} length vs dimension"),
                expected: dim,
                got: s.len() % dim,
            });
        }
        if s.is_empty() {
            return Err(MotionError::TooFewSamples {
                what: format!("DTW {name}"),
                needed: 1,
                got: 0,
            });
        }
        check_finite(&format!("DTW {name}"), s)?;
    }
    Ok((a.len() / dim, b.len() / dim))
}

#[inline]
fn sq(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

fn band(window: Option<usize>, n: usize, m: usize) -> usize {
    window.map_or(usize::MAX, |w| w.max(n.abs_diff(m)))
}

/// DTW distance with an optional Sakoe–Chiba band `|i − j| ≤ window` (widened to the length
/// difference, as dtaidistance does). O(n·m) time, O(m) memory.
pub fn dtw_distance(a: &[f64], b: &[f64], dim: usize, window: Option<usize>) -> Result<f64> {
    let (n, m) = check(a, b, dim)?;
    let w = band(window, n, m);
    let mut prev = vec![f64::INFINITY; m + 1];
    let mut cur = vec![f64::INFINITY; m + 1];
    prev[0] = 0.0;
    for i in 1..=n {
        cur.iter_mut().for_each(|v| *v = f64::INFINITY);
        let lo = if i > w { i - w } else { 1 };
        let hi = m.min(i.saturating_add(w));
        for j in lo..=hi {
            let c = sq(&a[(i - 1) * dim..i * dim], &b[(j - 1) * dim..j * dim]);
            cur[j] = c + prev[j - 1].min(prev[j]).min(cur[j - 1]);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    Ok(prev[m].sqrt())
}

/// DTW with the optimal warping path. O(n·m) time and memory.
pub fn dtw_align(a: &[f64], b: &[f64], dim: usize, window: Option<usize>) -> Result<Alignment> {
    let (n, m) = check(a, b, dim)?;
    let w = band(window, n, m);
    let cols = m + 1;
    let mut acc = vec![f64::INFINITY; (n + 1) * cols];
    acc[0] = 0.0;
    for i in 1..=n {
        let lo = if i > w { i - w } else { 1 };
        let hi = m.min(i.saturating_add(w));
        for j in lo..=hi {
            let c = sq(&a[(i - 1) * dim..i * dim], &b[(j - 1) * dim..j * dim]);
            acc[i * cols + j] = c + acc[(i - 1) * cols + j - 1]
                .min(acc[(i - 1) * cols + j])
                .min(acc[i * cols + j - 1]);
        }
    }
    let mut path = vec![(n - 1, m - 1)];
    let (mut i, mut j) = (n, m);
    while i > 1 || j > 1 {
        let diag = acc[(i - 1) * cols + j - 1];
        let up = acc[(i - 1) * cols + j];
        let left = acc[i * cols + j - 1];
        if diag <= up && diag <= left {
            i -= 1;
            j -= 1;
        } else if up <= left {
            i -= 1;
        } else {
            j -= 1;
        }
        path.push((i - 1, j - 1));
    }
    path.reverse();
    Ok(Alignment {
        distance: acc[n * cols + m].sqrt(),
        path,
    })
}

fn triangle_area(p: &[f64], q: &[f64], r: &[f64]) -> f64 {
    let (mut uu, mut vv, mut uv) = (0.0, 0.0, 0.0);
    for k in 0..p.len() {
        let u = q[k] - p[k];
        let v = r[k] - p[k];
        uu += u * u;
        vv += v * v;
        uv += u * v;
    }
    0.5 * (uu * vv - uv * uv).max(0.0).sqrt()
}

/// Area between two trajectories after DTW alignment (Sec. 3.1.4): the sum, over consecutive
/// aligned pairs, of the two triangles spanned by the quadrilateral `a_i, a_i', b_j', b_j`.
/// Unit: (state unit)².
pub fn area_between(a: &[f64], b: &[f64], dim: usize) -> Result<f64> {
    let al = dtw_align(a, b, dim, None)?;
    let p = |s: &[f64], i: usize| -> Vec<f64> { s[i * dim..(i + 1) * dim].to_vec() };
    let mut area = 0.0;
    for w in al.path.windows(2) {
        let ((i0, j0), (i1, j1)) = (w[0], w[1]);
        let (a0, a1, b0, b1) = (p(a, i0), p(a, i1), p(b, j0), p(b, j1));
        area += triangle_area(&a0, &a1, &b1) + triangle_area(&a0, &b1, &b0);
    }
    Ok(area)
}

/// k-nearest-neighbour classifier over labelled template sequences with the DTW distance.
#[derive(Debug, Clone, Default)]
pub struct Knn {
    dim: usize,
    templates: Vec<(String, Vec<f64>)>,
    /// Sakoe–Chiba band (samples), `None` for unconstrained DTW.
    pub window: Option<usize>,
}

impl Knn {
    /// Empty classifier for sequences of `dim` columns.
    pub fn new(dim: usize, window: Option<usize>) -> Self {
        Self {
            dim,
            templates: Vec::new(),
            window,
        }
    }

    /// Adds a labelled template (row-major, `dim` columns).
    pub fn add(&mut self, label: impl Into<String>, seq: Vec<f64>) -> Result<()> {
        check(&seq, &seq, self.dim)?;
        self.templates.push((label.into(), seq));
        Ok(())
    }

    /// Number of templates.
    pub fn len(&self) -> usize {
        self.templates.len()
    }
    /// True when no template was added.
    pub fn is_empty(&self) -> bool {
        self.templates.is_empty()
    }

    /// Majority label among the `k` nearest templates (ties go to the label with the nearest
    /// member) and the distance to the nearest template.
    pub fn classify(&self, query: &[f64], k: usize) -> Result<(String, f64)> {
        if self.templates.is_empty() {
            return Err(MotionError::TooFewSamples {
                what: "k-NN templates".into(),
                needed: 1,
                got: 0,
            });
        }
        if k == 0 {
            return Err(invalid("k", "must be at least 1"));
        }
        let mut d: Vec<(f64, usize)> = self
            .templates
            .iter()
            .enumerate()
            .map(|(i, (_, s))| dtw_distance(query, s, self.dim, self.window).map(|d| (d, i)))
            .collect::<Result<_>>()?;
        d.sort_by(|a, b| a.0.total_cmp(&b.0));
        let near = &d[..k.min(d.len())];
        let mut votes: Vec<(&str, usize, f64)> = Vec::new();
        for (dist, i) in near {
            let label = self.templates[*i].0.as_str();
            match votes.iter_mut().find(|v| v.0 == label) {
                Some(v) => v.1 += 1,
                None => votes.push((label, 1, *dist)),
            }
        }
        let best = votes
            .iter()
            .max_by(|a, b| a.1.cmp(&b.1).then(b.2.total_cmp(&a.2)))
            .map(|v| v.0.to_string())
            .unwrap_or_default();
        Ok((best, d[0].0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_and_shifted_sequences() {
        let a: Vec<f64> = (0..50).map(|i| (i as f64 * 0.2).sin()).collect();
        assert_eq!(dtw_distance(&a, &a, 1, None).expect("dtw"), 0.0);
        // A time-stretched copy aligns with zero cost.
        let b: Vec<f64> = a.iter().flat_map(|v| [*v, *v]).collect();
        assert!(dtw_distance(&a, &b, 1, None).expect("dtw") < 1e-12);
        let al = dtw_align(&a, &b, 1, None).expect("align");
        assert_eq!(al.path[0], (0, 0));
        assert_eq!(*al.path.last().expect("path"), (49, 99));
        assert!(al.distance < 1e-12);
    }

    #[test]
    fn path_distance_matches_band_free_distance() {
        let a = [0.0, 1.0, 2.0, 3.0, 1.0, 1.0];
        let b = [0.0, 0.0, 2.0, 2.0, 1.0, 0.0, 5.0, 5.0];
        let d = dtw_distance(&a, &b, 2, None).expect("d");
        let al = dtw_align(&a, &b, 2, None).expect("al");
        assert!((d - al.distance).abs() < 1e-12);
        let s: f64 = al
            .path
            .iter()
            .map(|&(i, j)| sq(&a[i * 2..i * 2 + 2], &b[j * 2..j * 2 + 2]))
            .sum();
        assert!((s.sqrt() - d).abs() < 1e-12);
    }

    #[test]
    fn area_of_parallel_lines() {
        let a: Vec<f64> = (0..=10).flat_map(|i| [i as f64, 0.0]).collect();
        let b: Vec<f64> = (0..=10).flat_map(|i| [i as f64, 1.0]).collect();
        assert!((area_between(&a, &b, 2).expect("area") - 10.0).abs() < 1e-12);
    }

    #[test]
    fn knn_classifies_by_shape() {
        let mut knn = Knn::new(1, None);
        for s in [0.9, 1.0, 1.1] {
            knn.add("sin", (0..40).map(|i| (i as f64 * 0.2 * s).sin()).collect())
                .expect("add");
            knn.add("ramp", (0..40).map(|i| i as f64 * 0.05 * s).collect())
                .expect("add");
        }
        let q: Vec<f64> = (0..45).map(|i| (i as f64 * 0.19).sin()).collect();
        assert_eq!(knn.classify(&q, 3).expect("knn").0, "sin");
        assert!(knn.classify(&[f64::NAN], 1).is_err());
    }
}
