//! Adaptive sampling to a stated accuracy (`--target-error E`).
//!
//! Each vertex casts rays in rounds and stops when its **estimated RMS coefficient error**
//! (the root mean square, over its n² coefficients, of the error of its transfer) is at most E,
//! or when it has cast `--samples` rays.
//!
//! # Where the error estimate comes from: independent Owen scrambles
//!
//! An Owen-scrambled Sobol point set is far from a set of independent samples: its error is
//! much smaller than σ/√N for smooth parts of the integrand, so the per-sample variance
//! (σ²/N) overstates it, often by an order of magnitude, and would make vertices cast rays they
//! do not need. The standard honest route is *randomised QMC replicates* (Owen 1997; L'Ecuyer
//! and Lemieux 2000): the bake draws [`REPLICATES`] = K independently scrambled Sobol point
//! sets. Each of them alone gives an unbiased estimate T̂_k of the vertex's transfer, the K
//! estimates are independent (given the vertex's frame), so
//!
//! ```text
//!     T̄ = (1/K) Σ_k T̂_k,      Var̂(T̄_j) = Σ_k (T̂_k,j − T̄_j)² / (K (K − 1))
//! ```
//!
//! is an unbiased estimate of the variance of the mean, whatever the points' correlations
//! within a replicate. The estimated RMS error is √((1/n²) Σ_j Var̂(T̄_j)); the SH rotation
//! into world space is orthogonal band by band, so it is the same in the local and the world
//! frame. The stored transfer is T̄, the plain average of every ray the vertex cast.
//!
//! # Rounds
//!
//! In each round every replicate adds points, doubling its count (so each replicate is a
//! whole (0,m,2)-net after each round but the last, which the `--samples` cap may cut): the
//! vertex casts K·m rays in all after a round of m points per replicate.
//!
//! The first round is large enough that a vertex does not stop early by luck:
//! * at least [`MIN_POINTS`] points per replicate, so the K-sample variance has K − 1 = 15
//!   degrees of freedom per coefficient (with 15, an estimate below 1/1.5 of the true error
//!   happens with probability ≈ 3 %, before pooling the n² coefficients);
//! * at least 1/(√(4π)·E) rays, so that a feature the first round misses entirely (one the
//!   stratified points can miss has a cosine-weighted measure p below 1/N) changes the
//!   vertex's coefficients by p·y_j(s), whose RMS over j is p/√(4π) (the addition theorem:
//!   Σ_j y_j(s)² = n²/4π) ≤ E.
//!
//! Every quantity is a pure function of (seed, vertex, sample index), and sums are formed in a
//! fixed order, so an adaptive bake is bit-identical for any number of threads.
//!
//! # Scope
//!
//! Shadowed mode with Owen–Sobol sampling only; the options refuse the rest
//! ([`BakeOptions::validate`]): unshadowed bakes cast no rays, the thesis's random sampling is the
//! baseline adaptive sampling is measured against, and in interreflected mode the bounce rows
//! would be built from a number of rays that differs per vertex (not supported yet).

use glam::{Mat3, Vec3};
use serde::Serialize;

use crate::bake::options::BakeOptions;
pub use crate::bake::options::{MIN_POINTS, REPLICATES};
use crate::math::sampling::{OwenSobol, cosine_hemisphere, hilbert_index, vertex_seed};
use crate::math::sh::Basis;
use crate::trace::Tracer;

/// Rays per tracer call.
const BATCH: usize = 256;

/// Points per replicate after each round (cumulative): doubling from the first round's
/// count to the cap of ⌊samples / K⌋.
pub fn schedule(target: f32, samples: u32) -> Vec<u32> {
    let cap = samples / REPLICATES as u32;
    let feature_rays = (1.0 / ((4.0 * std::f64::consts::PI).sqrt() * f64::from(target))).ceil();
    let feature_points = (feature_rays / REPLICATES as f64).min(f64::from(cap)) as u32;
    let mut points = feature_points.max(MIN_POINTS).next_power_of_two().min(cap);
    let mut rounds = vec![points];
    while points < cap {
        points = (points * 2).min(cap);
        rounds.push(points);
    }
    rounds
}

/// The bake's K scrambled point sets, cosine-weighted in the local frame, with y_j at every
/// point, laid out round by round: round r's rows hold every replicate's new points, sorted
/// along a Hilbert curve (close directions trace faster; the sums do not depend on the order).
pub struct Tables {
    pub target: f32,
    /// Points per replicate after each round.
    pub rounds: Vec<u32>,
    dirs: Vec<Vec3>,
    /// y_j(dirs[i]) at `[i·n² + j]`.
    sh: Vec<f32>,
    /// The replicate each row belongs to.
    replicate: Vec<u8>,
}

impl Tables {
    pub fn new(options: &BakeOptions, basis: &Basis) -> Tables {
        let target = options.target_error.expect("an adaptive bake");
        let rounds = schedule(target, options.samples);
        let sets: Vec<OwenSobol> = (0..REPLICATES as u64)
            .map(|k| OwenSobol::new(vertex_seed(options.seed, u64::MAX - 1 - k)))
            .collect();
        let (mut dirs, mut replicate) = (Vec::new(), Vec::new());
        let mut done = 0;
        for &points in &rounds {
            let mut round: Vec<(u64, u8, f32, f32)> = Vec::new();
            for (k, set) in sets.iter().enumerate() {
                for i in done..points {
                    let (u1, u2) = set.point(i);
                    round.push((hilbert_index(u1, u2), k as u8, u1, u2));
                }
            }
            round.sort_by_key(|&(h, k, _, _)| (h, k));
            dirs.extend(
                round
                    .iter()
                    .map(|&(_, _, u1, u2)| cosine_hemisphere(u1, u2)),
            );
            replicate.extend(round.iter().map(|&(_, k, _, _)| k));
            done = points;
        }
        let n = basis.coeff_count();
        let mut sh = vec![0.0; dirs.len() * n];
        for (row, d) in sh.chunks_mut(n).zip(&dirs) {
            basis.eval(*d, row);
        }
        Tables {
            target,
            rounds,
            dirs,
            sh,
            replicate,
        }
    }
}

/// What one vertex's adaptive estimate gives besides its coefficients.
pub struct VertexResult {
    /// Rays cast.
    pub rays: u32,
    /// The estimated RMS coefficient error of the returned transfer.
    pub error: f64,
    /// Σ of the unblocked directions and their count (the ambient-occlusion quantities).
    pub unblocked: u32,
    pub bent: Vec3,
}

/// Per-thread buffers of the adaptive estimator.
#[derive(Default)]
pub struct AdaptiveScratch {
    dirs: Vec<Vec3>,
    occluded: Vec<bool>,
    /// Per-batch f32 sums, `[k·n² + j]`.
    batch: Vec<f32>,
    /// Per-replicate f64 sums, `[k·n² + j]`.
    totals: Vec<f64>,
}

/// Estimates vertex `v`'s local-frame transfer into `local` (n² values): rays from `origin`
/// along `frame` × the table's directions, round after round, until the estimated RMS error
/// is at most the target or the last round is done. With no tracer nothing is blocked.
pub fn receiver_transfer(
    tables: &Tables,
    n: usize,
    origin: Vec3,
    frame: &Mat3,
    tracer: Option<&dyn Tracer>,
    s: &mut AdaptiveScratch,
    local: &mut [f64],
) -> VertexResult {
    let k = REPLICATES;
    s.totals.clear();
    s.totals.resize(k * n, 0.0);
    s.batch.resize(k * n, 0.0);
    s.occluded.resize(BATCH, false);
    let (mut unblocked, mut bent) = (0u32, Vec3::ZERO);
    let (mut start, mut points, mut error) = (0usize, 0u32, f64::INFINITY);
    for &round_points in &tables.rounds {
        let end = start + k * (round_points - points) as usize;
        for batch in (start..end).step_by(BATCH) {
            let batch = batch..(batch + BATCH).min(end);
            let len = batch.len();
            s.dirs.clear();
            s.dirs
                .extend(tables.dirs[batch.clone()].iter().map(|d| *frame * *d));
            match tracer {
                Some(tracer) => tracer.occluded_from(origin, &s.dirs, &mut s.occluded[..len]),
                None => s.occluded[..len].fill(false),
            }
            s.batch.fill(0.0);
            let rows = tables.sh[batch.start * n..batch.end * n].chunks_exact(n);
            for (((row, &blocked), &r), dir) in rows
                .zip(&s.occluded[..len])
                .zip(&tables.replicate[batch.clone()])
                .zip(&s.dirs)
            {
                if !blocked {
                    let sums = &mut s.batch[usize::from(r) * n..][..n];
                    for (acc, y) in sums.iter_mut().zip(row) {
                        *acc += y;
                    }
                    unblocked += 1;
                    bent += *dir;
                }
            }
            for (total, b) in s.totals.iter_mut().zip(&s.batch) {
                *total += f64::from(*b);
            }
        }
        start = end;
        points = round_points;
        error = replicate_error(&s.totals, n, points);
        if error <= f64::from(tables.target) {
            break;
        }
    }
    let norm = 1.0 / (k as f64 * f64::from(points));
    for (j, out) in local.iter_mut().enumerate() {
        *out = (0..k).map(|r| s.totals[r * n + j]).sum::<f64>() * norm;
    }
    VertexResult {
        rays: k as u32 * points,
        error,
        unblocked,
        bent,
    }
}

/// The estimated RMS coefficient error of the mean of the replicates whose sums over
/// `points` samples each are `totals[k·n + j]`: √((1/n) Σ_j Σ_k (T̂_k,j − T̄_j)² / (K(K−1))).
pub fn replicate_error(totals: &[f64], n: usize, points: u32) -> f64 {
    let k = totals.len() / n;
    let scale = 1.0 / f64::from(points);
    let mut sum_of_variances = 0.0;
    for j in 0..n {
        let estimate = |r: usize| totals[r * n + j] * scale;
        let mean = (0..k).map(estimate).sum::<f64>() / k as f64;
        let squares: f64 = (0..k).map(|r| (estimate(r) - mean).powi(2)).sum();
        sum_of_variances += squares / (k * (k - 1)) as f64;
    }
    (sum_of_variances / n as f64).sqrt()
}

/// Order statistics of a per-vertex quantity, as `inspect` prints them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Distribution {
    pub min: f64,
    pub median: f64,
    pub p95: f64,
    pub max: f64,
    pub mean: f64,
}

impl Distribution {
    /// Nearest-rank quantiles; `None` for no values.
    pub fn of(values: impl Iterator<Item = f64>) -> Option<Distribution> {
        let mut sorted: Vec<f64> = values.collect();
        if sorted.is_empty() {
            return None;
        }
        sorted.sort_by(f64::total_cmp);
        let rank =
            |q: f64| sorted[((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len()) - 1];
        Some(Distribution {
            min: sorted[0],
            median: rank(0.5),
            p95: rank(0.95),
            max: sorted[sorted.len() - 1],
            mean: sorted.iter().sum::<f64>() / sorted.len() as f64,
        })
    }
}

/// The per-vertex record of an adaptive bake, summarised.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    pub rays_per_vertex: Distribution,
    pub estimated_error: Distribution,
    /// Vertices that reached `--samples` with an estimated error still above the target.
    pub vertices_above_target: usize,
}

impl Summary {
    pub fn new(target: f32, rays: &[u32], errors: &[f32]) -> Option<Summary> {
        Some(Summary {
            rays_per_vertex: Distribution::of(rays.iter().map(|&r| f64::from(r)))?,
            estimated_error: Distribution::of(errors.iter().map(|&e| f64::from(e)))?,
            vertices_above_target: errors.iter().filter(|&&e| e > target).count(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::options::Mode;
    use crate::math::sampling::Sampling;
    use crate::support::error::Error;

    #[test]
    fn the_schedule_doubles_from_the_first_round_to_the_cap() {
        // E = 0.01: 1/(√(4π)·0.01) = 29 rays, below the 16 × 16 minimum.
        assert_eq!(schedule(0.01, 10_000), [16, 32, 64, 128, 256, 512, 625]);
        assert_eq!(schedule(0.01, 4096), [16, 32, 64, 128, 256]);
        // E = 1e-4: 2,821 rays, 177 per replicate, so the first round has 256 per replicate.
        assert_eq!(schedule(1e-4, 1 << 16), [256, 512, 1024, 2048, 4096]);
        // The cap wins over the first round's size.
        assert_eq!(schedule(1e-6, 1000), [62]);
        assert_eq!(schedule(0.5, 256), [16]);
    }

    #[test]
    fn the_replicate_error_is_the_standard_error_of_the_mean() {
        // Two coefficients, four replicates of 2 points: estimates 1, 2, 3, 4 (variance of
        // the mean (5/3)/4) and all 5 (zero).
        let totals = [2.0, 10.0, 4.0, 10.0, 6.0, 10.0, 8.0, 10.0];
        let expected = ((5.0 / 3.0 / 4.0 + 0.0) / 2.0f64).sqrt();
        assert!((replicate_error(&totals, 2, 2) - expected).abs() < 1e-15);
    }

    #[test]
    fn distributions_use_nearest_ranks() {
        let d = Distribution::of((1..=100).map(f64::from)).unwrap();
        assert_eq!((d.min, d.median, d.p95, d.max), (1.0, 50.0, 95.0, 100.0));
        assert_eq!(d.mean, 50.5);
        assert!(Distribution::of(std::iter::empty()).is_none());
    }

    #[test]
    fn unsupported_combinations_are_refused() {
        let adaptive = BakeOptions {
            target_error: Some(1e-3),
            samples: 4096,
            ..BakeOptions::default()
        };
        assert!(adaptive.validate().is_ok());
        for (options, message) in [
            (
                BakeOptions {
                    mode: Mode::Interreflected,
                    bounces: 1,
                    ..adaptive.clone()
                },
                "needs --mode shadowed",
            ),
            (
                BakeOptions {
                    mode: Mode::Unshadowed,
                    ..adaptive.clone()
                },
                "needs --mode shadowed",
            ),
            (
                BakeOptions {
                    sampling: Sampling::ThesisRandom,
                    ..adaptive.clone()
                },
                "needs --sampling owen-sobol",
            ),
            (
                BakeOptions {
                    samples: 255,
                    ..adaptive.clone()
                },
                "at least 256",
            ),
            (
                BakeOptions {
                    target_error: Some(0.0),
                    ..adaptive.clone()
                },
                "positive",
            ),
            (
                BakeOptions {
                    target_error: Some(f32::NAN),
                    ..adaptive.clone()
                },
                "positive",
            ),
        ] {
            match options.validate() {
                Err(Error::InvalidOption(m)) => assert!(m.contains(message), "{m}"),
                other => panic!("{options:?}: {other:?}"),
            }
        }
    }
}
