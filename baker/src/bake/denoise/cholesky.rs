//! Small symmetric positive-definite systems, solved by Cholesky factorisation: the vertex
//! fits' 6 × 6 and the normal-mapped texels' 5 × 5. Written here rather than taken from a
//! crate: the systems are a few terms, formed and solved once per cluster on the filter's
//! hot path, where a fixed-size array on the stack is what fits.

/// The Cholesky factor L (A = L Lᵀ) of the symmetric `a` (its lower triangle read), or
/// `None` where a pivot is not finite or not above `least` (not positive definite, or too
/// near singular for the caller).
pub(super) fn factor<const N: usize>(a: &[[f64; N]; N], least: f64) -> Option<[[f64; N]; N]> {
    let mut l = [[0.0f64; N]; N];
    for i in 0..N {
        for j in 0..=i {
            let s: f64 = a[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
            if i != j {
                l[i][j] = s / l[j][j];
            } else if s.is_finite() && s > least {
                l[i][i] = s.sqrt();
            } else {
                return None;
            }
        }
    }
    Some(l)
}

/// y ← (L Lᵀ)⁻¹ y.
pub(super) fn solve<const N: usize>(l: &[[f64; N]; N], y: &mut [f64; N]) {
    for i in 0..N {
        y[i] = (y[i] - (0..i).map(|k| l[i][k] * y[k]).sum::<f64>()) / l[i][i];
    }
    for i in (0..N).rev() {
        y[i] = (y[i] - (i + 1..N).map(|k| l[k][i] * y[k]).sum::<f64>()) / l[i][i];
    }
}
