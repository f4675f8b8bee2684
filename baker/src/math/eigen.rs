//! Eigenvectors of the symmetric scatter matrices of [`crate::math::cpca`]: every eigenpair
//! by cyclic Jacobi rotations for small matrices (a transfer vector's 16 or 48 floats), and
//! only the few leading ones by subspace iteration for large ones (a transfer matrix's n⁴
//! floats: 256 or 768 at order 4, where a full Jacobi decomposition per cluster and refinement
//! step made a 64-cluster fit of the demo scene take a quarter of an hour of CPU).
//!
//! Written here because the workspace has no linear-algebra crate and these two routines are
//! all CPCA needs; both are deterministic (no threads inside, fixed start), so a compressed
//! file does not depend on the machine's thread count.

/// Matrices of up to this many rows are diagonalised whole (Jacobi): every vector bake up to
/// order 4 in colour (48) or order 8 in grey (64), whose files stay as they were.
const JACOBI_MAX_ROWS: usize = 64;
/// Extra vectors iterated beyond the k wanted: convergence goes as (λ_{k+extra+1}/λ_k)^iterations.
const EXTRA_VECTORS: usize = 4;
/// Subspace iterations at most; they stop earlier when the leading Rayleigh quotients settle.
const MAX_ITERATIONS: usize = 2000;
/// The relative change of the sum of the k leading Rayleigh quotients at which they have settled.
const TOLERANCE: f64 = 1e-13;

/// The `k` eigenvectors of largest eigenvalue of the symmetric `n`×`n` row-major matrix `a`,
/// largest first, orthonormal (or zero where `a` has fewer than `k` non-zero eigenvalues).
pub fn leading_eigenvectors(a: &[f64], n: usize, k: usize) -> Vec<Vec<f64>> {
    if k == 0 {
        return Vec::new();
    }
    if n <= JACOBI_MAX_ROWS || k + EXTRA_VECTORS >= n {
        let (values, vectors) = symmetric_eigen(a.to_vec(), n);
        return leading(&values, n, k, |j| {
            (0..n).map(|i| vectors[i * n + j]).collect()
        });
    }
    subspace_iteration(a, n, k)
}

/// [`leading_eigenvectors`] for a matrix small enough for Jacobi (None otherwise), started
/// from `start`: an orthogonal n×n matrix, row-major with the vectors in its columns, as
/// this returns every eigenvector for the next call. Jacobi then runs on SᵀAS, nearly
/// diagonal when S diagonalises a nearby matrix (a CPCA cluster that gained or lost a few
/// members), so it needs fewer sweeps; the result is as exact.
pub fn leading_eigenvectors_from(
    a: &[f64],
    n: usize,
    k: usize,
    start: Option<&[f64]>,
) -> Option<(Vec<Vec<f64>>, Vec<f64>)> {
    if n > JACOBI_MAX_ROWS {
        return None;
    }
    let (values, vectors) = match start {
        None => symmetric_eigen(a.to_vec(), n),
        Some(s) => {
            let (aligned, rotation) = symmetric_eigen(congruence(a, s, n), n);
            (aligned, product(s, &rotation, n))
        }
    };
    let lead = leading(&values, n, k, |j| {
        (0..n).map(|i| vectors[i * n + j]).collect()
    });
    Some((lead, vectors))
}

/// SᵀAS for row-major n×n matrices, made exactly symmetric (as Jacobi expects).
fn congruence(a: &[f64], s: &[f64], n: usize) -> Vec<f64> {
    let transposed: Vec<f64> = (0..n * n).map(|ij| s[(ij % n) * n + ij / n]).collect();
    let mut b = product(&transposed, &product(a, s, n), n);
    for i in 0..n {
        for j in 0..i {
            let m = 0.5 * (b[i * n + j] + b[j * n + i]);
            b[i * n + j] = m;
            b[j * n + i] = m;
        }
    }
    b
}

/// AB for row-major n×n matrices.
fn product(a: &[f64], b: &[f64], n: usize) -> Vec<f64> {
    let mut out = vec![0.0f64; n * n];
    for i in 0..n {
        for k in 0..n {
            let aik = a[i * n + k];
            if aik == 0.0 {
                continue;
            }
            for (x, &y) in out[i * n..(i + 1) * n]
                .iter_mut()
                .zip(&b[k * n..(k + 1) * n])
            {
                *x += aik * y;
            }
        }
    }
    out
}

/// The columns of `vectors` picked by the k largest `values` (ties by index, so the result
/// does not depend on the sort).
fn leading(
    values: &[f64],
    n: usize,
    k: usize,
    column: impl Fn(usize) -> Vec<f64>,
) -> Vec<Vec<f64>> {
    let mut order: Vec<usize> = (0..values.len().min(n)).collect();
    order.sort_by(|&a, &b| values[b].total_cmp(&values[a]).then(a.cmp(&b)));
    order.into_iter().take(k).map(column).collect()
}

/// Block power iteration on k + [`EXTRA_VECTORS`] vectors from a fixed start, then a
/// Rayleigh–Ritz step (Jacobi on the small projected matrix) so the result is the best
/// orthonormal basis of the subspace found, ordered by eigenvalue.
fn subspace_iteration(a: &[f64], n: usize, k: usize) -> Vec<Vec<f64>> {
    let p = k + EXTRA_VECTORS;
    // A fixed, well-spread start: a Weyl sequence of the golden ratio, one value per entry.
    let mut q: Vec<Vec<f64>> = (0..p)
        .map(|j| {
            (0..n)
                .map(|i| ((i * p + j + 1) as f64 * 0.618_033_988_749_894_9).fract() - 0.5)
                .collect()
        })
        .collect();
    orthonormalise(&mut q);
    let mut previous = f64::NAN;
    for _ in 0..MAX_ITERATIONS {
        let mut z: Vec<Vec<f64>> = q.iter().map(|c| times(a, n, c)).collect();
        let quotients: f64 = q.iter().zip(&z).take(k).map(|(c, ac)| dot(c, ac)).sum();
        orthonormalise(&mut z);
        q = z;
        let settled = (quotients - previous).abs() <= TOLERANCE * quotients.abs();
        previous = quotients;
        if settled {
            break;
        }
    }
    let aq: Vec<Vec<f64>> = q.iter().map(|c| times(a, n, c)).collect();
    let mut small = vec![0.0; p * p];
    for i in 0..p {
        for j in 0..p {
            small[i * p + j] = dot(&q[i], &aq[j]);
        }
    }
    // Exactly symmetric, as Jacobi expects.
    for i in 0..p {
        for j in 0..i {
            let m = 0.5 * (small[i * p + j] + small[j * p + i]);
            small[i * p + j] = m;
            small[j * p + i] = m;
        }
    }
    let (values, vectors) = symmetric_eigen(small, p);
    let mut ritz = leading(&values, p, k, |j| {
        let mut v = vec![0.0; n];
        for (i, c) in q.iter().enumerate() {
            let w = vectors[i * p + j];
            for (x, &y) in v.iter_mut().zip(c) {
                *x += w * y;
            }
        }
        v
    });
    orthonormalise(&mut ritz);
    ritz
}

/// A·x for the row-major `n`×`n` matrix A.
fn times(a: &[f64], n: usize, x: &[f64]) -> Vec<f64> {
    a.chunks_exact(n).map(|row| dot(row, x)).collect()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Modified Gram–Schmidt, twice over for orthogonality to rounding; a vector that is
/// (numerically) in the span of those before it becomes zero.
fn orthonormalise(vectors: &mut [Vec<f64>]) {
    for j in 0..vectors.len() {
        let before = dot(&vectors[j], &vectors[j]).sqrt();
        for _pass in 0..2 {
            for i in 0..j {
                let (done, rest) = vectors.split_at_mut(j);
                let w = dot(&done[i], &rest[0]);
                for (x, &y) in rest[0].iter_mut().zip(&done[i]) {
                    *x -= w * y;
                }
            }
        }
        let norm = dot(&vectors[j], &vectors[j]).sqrt();
        let scale = if norm > 1e-12 * before && norm > 0.0 {
            1.0 / norm
        } else {
            0.0
        };
        vectors[j].iter_mut().for_each(|x| *x *= scale);
    }
}

/// Eigenvalues and eigenvectors (the columns of the returned row-major matrix) of a symmetric
/// `n`×`n` matrix, by cyclic Jacobi rotations: slow for large n, but exact to rounding and
/// orthonormal, which the weights (plain projections) rely on.
pub fn symmetric_eigen(mut a: Vec<f64>, n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut v = vec![0.0f64; n * n];
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    let norm: f64 = a.iter().map(|x| x * x).sum();
    for _sweep in 0..60 {
        let mut off = 0.0;
        for p in 0..n {
            for q in p + 1..n {
                off += a[p * n + q] * a[p * n + q];
            }
        }
        if off <= 1e-30 * norm || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                let theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                // A ← Jᵀ A J with J the rotation in the (p, q) plane.
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (v[k * n + p], v[k * n + q]);
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    ((0..n).map(|i| a[i * n + i]).collect(), v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_warm_start_gives_the_cold_result() {
        // Start from the eigenvectors of a nearby matrix, as a CPCA cluster that changed a
        // few members does: same leading eigenvectors (up to sign), orthonormal frame.
        let n = 12;
        let matrix = |shift: f64| -> Vec<f64> {
            let mut a = vec![0.0; n * n];
            for p in 0..n {
                for q in 0..n {
                    a[p * n + q] = 1.0 / (1 + p + q) as f64
                        + if p == q {
                            (n - p) as f64
                        } else {
                            shift * ((p * q) % 3) as f64
                        };
                }
            }
            a
        };
        let (near, a) = (matrix(0.0), matrix(0.01));
        let (_, start) = leading_eigenvectors_from(&near, n, 3, None).unwrap();
        let (warm, frame) = leading_eigenvectors_from(&a, n, 3, Some(&start)).unwrap();
        let cold = leading_eigenvectors(&a, n, 3);
        for (w, c) in warm.iter().zip(&cold) {
            assert!((dot(w, c).abs() - 1.0).abs() < 1e-12, "{w:?} {c:?}");
        }
        for i in 0..n {
            for j in 0..n {
                let d: f64 = (0..n).map(|k| frame[k * n + i] * frame[k * n + j]).sum();
                assert!((d - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn jacobi_diagonalises() {
        let n = 5;
        let mut a = vec![0.0; n * n];
        for p in 0..n {
            for q in 0..n {
                a[p * n + q] = 1.0 / (1 + p + q) as f64 + if p == q { 1.0 } else { 0.0 };
            }
        }
        let (values, vectors) = symmetric_eigen(a.clone(), n);
        for j in 0..n {
            for i in 0..n {
                let av: f64 = (0..n).map(|k| a[i * n + k] * vectors[k * n + j]).sum();
                assert!((av - values[j] * vectors[i * n + j]).abs() < 1e-12);
            }
        }
    }

    /// A 200×200 scatter matrix of 300 vectors with 6 dominant directions and noise: the
    /// subspace iteration's 4 vectors span what Jacobi's 4 leading eigenvectors span, and
    /// capture the same variance, to rounding.
    #[test]
    fn subspace_iteration_finds_the_leading_eigenvectors() {
        let n = 200;
        let mut seed = 1u64;
        let mut unit = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let dirs: Vec<Vec<f64>> = (0..6).map(|_| (0..n).map(|_| unit()).collect()).collect();
        let mut a = vec![0.0; n * n];
        for _ in 0..300 {
            let w: Vec<f64> = (0..6).map(|j| unit() / (1 + j) as f64).collect();
            let x: Vec<f64> = (0..n)
                .map(|i| 0.01 * unit() + (0..6).map(|j| w[j] * dirs[j][i]).sum::<f64>())
                .collect();
            for p in 0..n {
                for q in 0..n {
                    a[p * n + q] += x[p] * x[q];
                }
            }
        }
        let fast = subspace_iteration(&a, n, 4);
        let (values, vectors) = symmetric_eigen(a.clone(), n);
        let exact = leading(&values, n, 4, |j| {
            (0..n).map(|i| vectors[i * n + j]).collect()
        });
        let captured =
            |basis: &[Vec<f64>]| -> f64 { basis.iter().map(|b| dot(b, &times(&a, n, b))).sum() };
        let (c_fast, c_exact) = (captured(&fast), captured(&exact));
        assert!(
            (c_fast - c_exact).abs() <= 1e-10 * c_exact,
            "{c_fast} against {c_exact}"
        );
        for (i, f) in fast.iter().enumerate() {
            // Each vector lies in the exact leading subspace, and is orthonormal to the others.
            let inside: f64 = exact.iter().map(|e| dot(e, f).powi(2)).sum();
            assert!((inside - 1.0).abs() < 1e-9, "vector {i}: {inside}");
            for (j, g) in fast.iter().enumerate() {
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((dot(f, g) - expected).abs() < 1e-12);
            }
        }
    }
}
