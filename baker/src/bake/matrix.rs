//! Transfer matrices (`bake --transfer matrix`, Sloan, Kautz & Snyder 2002, §5): per receiver
//! the n²×n² matrix
//!
//! ```text
//! M_ij = ∫ V(x, s) y_i(s) y_j(s) ds        (V = 0 below the receiver's tangent plane)
//! ```
//!
//! that maps a distant light's SH coefficients L to those of the receiver's shadowed incident
//! radiance, L′ = M·L. A glossy (or any view-dependent) BRDF is then convolved with L′ at
//! render time; the diffuse transfer vector is the special case T = (1/π) M·ĉ, ĉ the clamped
//! cosine's coefficients about the normal.
//!
//! # Why uniform hemisphere sampling
//!
//! The vector estimator draws cosine-weighted directions because its integrand carries the
//! cosine. M has no cosine: with cosine-weighted samples every ray would be weighted by
//! π / cos θ, unbounded at grazing angles (the estimator's variance, ∫ (y_i y_j)² / cos θ ds,
//! diverges logarithmically). With uniform directions over the hemisphere (density 1/2π) each
//! unblocked ray adds (2π/N)·y(s)·y(s)ᵀ, a bounded integrand, so the error falls as for the
//! vector bake. The directions are the vector bake's: the same Owen-scrambled Sobol points of
//! the same seed, in the same Hilbert order, the same per-receiver turn about the normal, the
//! same ray origins and batches — only the map from the unit square to the hemisphere
//! differs (z = 1 − u₁ instead of √(1 − u₁)).
//!
//! # How it is organised
//!
//! As in [`crate::bake::estimator`]: y(s) is tabled once per bake in the local frame (z along
//! the normal), each receiver sums the outer products of its unblocked rows in f32 per batch
//! of [`BATCH`] rays and in f64 across batches, and rotates the local matrix into world space
//! once: M_world = R · M_local · Rᵀ, with R the SH rotation of the receiver's frame (exact).
//! Only the upper triangle is summed — n²(n²+1)/2 multiply-adds per unblocked ray, 136 at
//! order 4 — as contiguous row segments `acc[i, i..] += y_i · y[i..]` that the compiler
//! vectorises; the lower triangle is mirrored at the end. A batch in which most rays are
//! unblocked is summed as its precomputed total minus its blocked rays' products (on an open
//! surface, most are unblocked). Every quantity is a pure function of (seed, receiver, sample
//! index) summed in a fixed order: bit-identical for any thread count.

use glam::{Mat3, Vec3};
use rayon::prelude::*;

use crate::bake::estimator::{DirectPass, Estimator, Visibility};
use crate::bake::receivers::RECEIVERS_PER_JOB;
use crate::math::sampling::{OwenSobol, hilbert_index, vertex_seed};
use crate::math::sh::RecurrenceRotator;
use crate::math::sh::rotation::ShRotation;
use crate::support::progress::Progress;
use crate::trace::Tracer;

/// Rays per tracer call, as in the vector estimator.
const BATCH: usize = 256;
/// Columns summed beside the outer products: cos θ (for the accessibility) and the local
/// direction times cos θ (for the bent normal).
const EXTRA: usize = 4;

/// Maps [0, 1)² to the uniform hemisphere around +z (density 1/2π): z = 1 − u₁, the
/// counterpart of [`crate::math::sampling::cosine_hemisphere`]'s √(1 − u₁).
#[inline]
pub fn uniform_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let z = 1.0 - u1;
    let r = (u1 * (2.0 - u1)).max(0.0).sqrt();
    let (s, c) = (std::f32::consts::TAU * u2).sin_cos();
    Vec3::new(r * c, r * s, z)
}

/// Length of the packed upper triangle of an n×n symmetric matrix.
#[inline]
pub fn packed_len(n: usize) -> usize {
    n * (n + 1) / 2
}

/// `acc += sign · y yᵀ` over the packed upper triangle (row i holds columns i..n). Each row is
/// one contiguous multiply-add of `y[i..]` scaled by `y[i]`, which the compiler vectorises.
#[inline]
pub fn add_outer(acc: &mut [f32], y: &[f32], sign: f32) {
    let mut rest = acc;
    for (i, &yi) in y.iter().enumerate() {
        let (row, tail) = rest.split_at_mut(y.len() - i);
        let s = sign * yi;
        for (a, &yj) in row.iter_mut().zip(&y[i..]) {
            *a += s * yj;
        }
        rest = tail;
    }
}

/// The bake's tables: the local directions, y at each, the extra columns, and per batch the
/// sum of its outer products and extras.
pub(crate) struct MatrixTables {
    n: usize,
    local_dirs: Vec<Vec3>,
    /// Row r (width n²): y_j(local_dirs[r]).
    rows: Vec<f32>,
    /// Row r: cos θ, then the local direction times cos θ.
    extras: Vec<[f32; EXTRA]>,
    /// Per batch: the packed sum of its rows' outer products, then its extras' sum.
    batch_totals: Vec<f32>,
}

impl MatrixTables {
    pub(crate) fn new(estimator: &Estimator) -> MatrixTables {
        let options = &estimator.options;
        let basis = &estimator.basis;
        let n = basis.coeff_count();
        // The vector bake's point set and order ([`Estimator::for_receivers`]).
        let points = OwenSobol::new(vertex_seed(options.seed, u64::MAX));
        let mut uv: Vec<(f32, f32)> = (0..options.samples).map(|i| points.point(i)).collect();
        uv.sort_by_key(|&(u1, u2)| hilbert_index(u1, u2));
        let local_dirs: Vec<Vec3> = uv
            .iter()
            .map(|&(u1, u2)| uniform_hemisphere(u1, u2))
            .collect();
        let mut rows = vec![0.0f32; local_dirs.len() * n];
        for (row, d) in rows.chunks_mut(n).zip(&local_dirs) {
            basis.eval(*d, row);
        }
        let extras: Vec<[f32; EXTRA]> = local_dirs
            .iter()
            .map(|d| [d.z, d.x * d.z, d.y * d.z, d.z * d.z])
            .collect();
        let width = packed_len(n) + EXTRA;
        let mut batch_totals = Vec::new();
        for start in (0..local_dirs.len()).step_by(BATCH) {
            let end = (start + BATCH).min(local_dirs.len());
            let mut total = vec![0.0f32; width];
            for r in start..end {
                add_outer(&mut total[..width - EXTRA], &rows[r * n..(r + 1) * n], 1.0);
                add_extras(&mut total[width - EXTRA..], &extras[r], 1.0);
            }
            batch_totals.extend(total);
        }
        MatrixTables {
            n,
            local_dirs,
            rows,
            extras,
            batch_totals,
        }
    }
}

#[inline]
fn add_extras(acc: &mut [f32], e: &[f32; EXTRA], sign: f32) {
    for (a, x) in acc.iter_mut().zip(e) {
        *a += sign * x;
    }
}

/// Per-thread buffers, reused across receivers.
struct MatrixScratch {
    dirs: Vec<Vec3>,
    occluded: Vec<bool>,
    batch_sum: Vec<f32>,
    total: Vec<f64>,
    local: Vec<f64>,
    column: Vec<f64>,
    rotated: Vec<f64>,
}

impl MatrixScratch {
    fn new(n: usize) -> MatrixScratch {
        MatrixScratch {
            dirs: Vec::with_capacity(BATCH),
            occluded: vec![false; BATCH],
            batch_sum: vec![0.0; packed_len(n) + EXTRA],
            total: vec![0.0; packed_len(n) + EXTRA],
            local: vec![0.0; n * n],
            column: vec![0.0; n],
            rotated: vec![0.0; n],
        }
    }
}

/// The transfer matrices of the receivers `receivers` (results indexed from its start):
/// `coefficients[(r · n² + i) · n² + j]`, one channel. `tracer` is `None` in unshadowed mode
/// (V = 1 over the hemisphere).
pub(crate) fn matrix_pass(
    estimator: &Estimator,
    tracer: Option<&dyn Tracer>,
    receivers: std::ops::Range<usize>,
    progress: &dyn Progress,
) -> DirectPass {
    let tables = MatrixTables::new(estimator);
    let n = tables.n;
    let width = n * n;
    let rotator = RecurrenceRotator::new(estimator.options.order);
    let rays_per_receiver = match tracer {
        Some(_) => u64::from(estimator.options.samples),
        None => 0,
    };
    progress.begin("matrix", receivers.len() as u64, rays_per_receiver);
    let mut coefficients = vec![0.0f32; receivers.len() * width];
    let mut visibility = vec![Visibility::default(); receivers.len()];
    coefficients
        .par_chunks_mut(RECEIVERS_PER_JOB * width)
        .zip(visibility.par_chunks_mut(RECEIVERS_PER_JOB))
        .enumerate()
        .for_each_init(
            || MatrixScratch::new(n),
            |scratch, (job, (out, vis))| {
                let first = receivers.start + job * RECEIVERS_PER_JOB;
                for (k, (out, vis)) in out.chunks_mut(width).zip(vis.iter_mut()).enumerate() {
                    *vis = receiver_matrix(
                        estimator,
                        &tables,
                        &rotator,
                        first + k,
                        tracer,
                        scratch,
                        out,
                    );
                }
                progress.advance(vis.len() as u64);
            },
        );
    progress.finish();
    DirectPass {
        coefficients,
        visibility,
    }
}

/// The matrices of the receivers `receivers` alone, n⁴ floats each, row-major (the oracle
/// tests bake one vertex of a large scene): [`matrix_pass`] without progress.
pub fn receiver_matrices(
    estimator: &Estimator,
    tracer: Option<&dyn Tracer>,
    receivers: std::ops::Range<usize>,
) -> Vec<f32> {
    let silent = crate::support::progress::Silent;
    matrix_pass(estimator, tracer, receivers, &silent).coefficients
}

/// Receiver `v`'s matrix into `out` (n⁴ floats, row-major), and its visibility quantities.
fn receiver_matrix(
    estimator: &Estimator,
    tables: &MatrixTables,
    rotator: &RecurrenceRotator,
    v: usize,
    tracer: Option<&dyn Tracer>,
    s: &mut MatrixScratch,
    out: &mut [f32],
) -> Visibility {
    let n = tables.n;
    let packed = packed_len(n);
    let frame: Mat3 = estimator.vertex_frame(v);
    let origin = estimator.origin(v);
    s.total.fill(0.0);
    let samples = tables.local_dirs.len();
    for (b, start) in (0..samples).step_by(BATCH).enumerate() {
        let end = (start + BATCH).min(samples);
        let len = end - start;
        let occluded = &mut s.occluded[..len];
        match tracer {
            Some(tracer) => {
                s.dirs.clear();
                s.dirs
                    .extend(tables.local_dirs[start..end].iter().map(|d| frame * *d));
                tracer.occluded_from(origin, &s.dirs, occluded);
            }
            None => occluded.fill(false),
        }
        let blocked = occluded.iter().filter(|&&b| b).count();
        let total = &tables.batch_totals[b * (packed + EXTRA)..(b + 1) * (packed + EXTRA)];
        // The total minus the blocked rays, or the sum of the unblocked ones: the fewer terms.
        let (want_blocked, sign) = if 2 * blocked <= len {
            s.batch_sum.copy_from_slice(total);
            (true, -1.0)
        } else {
            s.batch_sum.fill(0.0);
            (false, 1.0)
        };
        let (outer, extra) = s.batch_sum.split_at_mut(packed);
        for (r, _) in (start..end)
            .zip(occluded.iter())
            .filter(|(_, b)| **b == want_blocked)
        {
            add_outer(outer, &tables.rows[r * n..(r + 1) * n], sign);
            add_extras(extra, &tables.extras[r], sign);
        }
        for (t, b) in s.total.iter_mut().zip(&s.batch_sum) {
            *t += f64::from(*b);
        }
    }
    // Uniform over the hemisphere: each ray stands for 2π/N steradians.
    let norm = std::f64::consts::TAU / samples as f64;
    unpack_symmetric(&s.total[..packed], n, norm, &mut s.local);
    let rotation = rotator.rotation(frame.as_dmat3());
    rotate_symmetric(&rotation, n, s);
    for (o, w) in out.iter_mut().zip(&s.local) {
        *o = *w as f32;
    }
    let extra = &s.total[packed..];
    // (1/π) ∫ V cos θ ds and the cosine-weighted mean unblocked direction, from the same rays.
    let local_bent = glam::DVec3::new(extra[1], extra[2], extra[3]).as_vec3();
    Visibility {
        accessibility: ((extra[0] * norm / std::f64::consts::PI) as f32).clamp(0.0, 1.0),
        bent_normal: (frame * local_bent)
            .try_normalize()
            .unwrap_or(estimator.normals[v]),
        rays: if tracer.is_some() { samples as u32 } else { 0 },
        error_estimate: 0.0,
    }
}

/// The full n×n matrix, times `scale`, from its packed upper triangle.
fn unpack_symmetric(packed: &[f64], n: usize, scale: f64, out: &mut [f64]) {
    let mut k = 0;
    for i in 0..n {
        for j in i..n {
            let x = packed[k] * scale;
            out[i * n + j] = x;
            out[j * n + i] = x;
            k += 1;
        }
    }
}

/// `s.local` ← R · `s.local` · Rᵀ (symmetric in, symmetric out: the result's two halves are
/// averaged, so it is exactly symmetric).
fn rotate_symmetric(rotation: &ShRotation, n: usize, s: &mut MatrixScratch) {
    let m = &mut s.local;
    // Rows: B = M·Rᵀ, row i of B being R applied to row i of M.
    for i in 0..n {
        rotation.apply(&m[i * n..(i + 1) * n], &mut s.rotated);
        m[i * n..(i + 1) * n].copy_from_slice(&s.rotated);
    }
    // Columns: R·B, column j being R applied to column j of B.
    for j in 0..n {
        for i in 0..n {
            s.column[i] = m[i * n + j];
        }
        rotation.apply(&s.column, &mut s.rotated);
        for i in 0..n {
            m[i * n + j] = s.rotated[i];
        }
    }
    for i in 0..n {
        for j in i + 1..n {
            let mean = 0.5 * (m[i * n + j] + m[j * n + i]);
            m[i * n + j] = mean;
            m[j * n + i] = mean;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_outer_products_match_the_full_ones() {
        let y = [0.5f32, -1.0, 2.0, 0.25];
        let mut acc = vec![0.0f32; packed_len(4)];
        add_outer(&mut acc, &y, 1.0);
        add_outer(&mut acc, &y, 1.0);
        add_outer(&mut acc, &y, -1.0);
        let mut full = vec![0.0f64; 16];
        let packed: Vec<f64> = acc.iter().map(|&x| f64::from(x)).collect();
        unpack_symmetric(&packed, 4, 1.0, &mut full);
        for i in 0..4 {
            for j in 0..4 {
                assert_eq!(full[i * 4 + j], f64::from(y[i] * y[j]), "({i}, {j})");
            }
        }
    }

    #[test]
    fn uniform_hemisphere_points_are_unit_and_above_the_horizon() {
        for (u1, u2) in [(0.0, 0.0), (0.999_999, 0.5), (0.5, 0.25), (1e-7, 0.9)] {
            let d = uniform_hemisphere(u1, u2);
            assert!((d.length() - 1.0).abs() < 1e-6 && d.z > 0.0, "{d}");
        }
    }
}
