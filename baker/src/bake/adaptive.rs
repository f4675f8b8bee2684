//! Adaptive sampling to a stated accuracy (`--target-error E`).
//!
//! Each receiver (vertex or texel) casts a small **pilot**, predicts from it how many points
//! **one** Owen-scrambled Sobol net needs for its RMS coefficient error (the root mean square,
//! over its n² coefficients, of the error of its transfer) to be at most E, and casts that net,
//! which extends the pilot's first replicate (nested: no point is cast twice). `--samples` caps
//! the rays.
//!
//! # Why one net, and why a pilot of replicates
//!
//! An Owen-scrambled Sobol net is far more accurate than independent samples: its variance
//! falls as N^-1.5 where the integrand has edges (shadows) and faster where it is smooth, so
//! the per-sample variance σ²/N overstates its error. Its error can be estimated honestly only
//! from *independent replicates* (Owen 1997; L'Ecuyer and Lemieux 2000): K independently
//! scrambled sets, each giving an unbiased T̂_k, with
//!
//! ```text
//!     T̄ = (1/K) Σ_k T̂_k,      Var̂(T̄_j) = Σ_k (T̂_k,j − T̄_j)² / (K (K − 1)).
//! ```
//!
//! But K nets of m points are much less accurate than one net of K·m (variance K^-1 against
//! K^-1.5): the previous design, 16 replicates doubling to the end, cast 1.8 × the rays of the
//! fixed bake it matched. Here only the pilot is replicated:
//!
//! 1. **Pilot**: [`REPLICATES`] = 4 scrambles of m = [`MIN_POINTS`] = 64 points (256 rays).
//!    Their spread gives one replicate's RMS error s (√K × the replicate error above; the SH
//!    rotation into world space is orthogonal band by band, so local and world agree). If
//!    their mean is within E (s/√K ≤ E), the receiver stops: the stored transfer is T̄ and the
//!    stored estimate s/√K, exactly the replicate estimate.
//! 2. **Net**: otherwise the first replicate is extended to the smallest N = m·2^r with
//!    [`predicted_error`] s·(m/N)^(RATE/2) ≤ E, RATE = 1.5; the stored transfer is that net's
//!    mean, and the stored estimate the predicted error at N. The other replicates' 3m rays
//!    are not used in the transfer (they would change it by a few per cent of its variance).
//! 3. **Features**: every receiver casts at least 1/(√(4π)·E) rays ([`feature_rays`]): a
//!    feature that no ray hits then changes its coefficients by at most E in RMS. Without this
//!    floor, a demo-scene vertex with an unseen sliver of sky stopped at the pilot with an
//!    estimate of 0 and a true error of 2.4e-3.
//!
//! The prediction's rate is a model; the oracle test (`tests/adaptive.rs`) holds it to the
//! truth (true error ≤ 1.5 E at ≥ 95 % of trials, RMS estimate close to the RMS true error),
//! and `examples/adaptive_vs_fixed.rs` measures it against fixed bakes (docs/performance.md).
//!
//! Every quantity is a pure function of (seed, receiver, sample index), and sums are formed in
//! a fixed order, so an adaptive bake is bit-identical for any number of threads.
//!
//! # Scope
//!
//! Shadowed mode with Owen–Sobol sampling only, vertices or lightmap texels; the options
//! refuse the rest ([`BakeOptions::validate`]): unshadowed bakes cast no rays, the thesis's
//! random sampling is the baseline adaptive sampling is measured against, and in
//! interreflected mode the bounce rows would be built from a number of rays that differs per
//! receiver (not supported yet).

use glam::{Mat3, Vec3};
use serde::Serialize;

use crate::bake::options::BakeOptions;
pub use crate::bake::options::{MIN_POINTS, RATE, REPLICATES};
use crate::math::sampling::{OwenSobol, cosine_hemisphere, hilbert_index, vertex_seed};
use crate::math::sh::Basis;
use crate::trace::Tracer;

/// Rays per tracer call.
const BATCH: usize = 256;

/// The pilot's points per replicate: [`MIN_POINTS`], or what the cap leaves each replicate.
pub fn pilot_points(samples: u32) -> u32 {
    MIN_POINTS.min(samples / REPLICATES as u32)
}

/// Rays that see any feature worth more than E: a feature no ray hits (one whose
/// cosine-weighted measure p is below 1/N for N stratified points) changes the receiver's
/// coefficients by p·y_j(s), whose RMS over j is p/√(4π) (the addition theorem:
/// Σ_j y_j(s)² = n²/4π), so N ≥ 1/(√(4π)·E) keeps it ≤ E.
pub fn feature_rays(target: f32) -> u32 {
    (1.0 / ((4.0 * std::f64::consts::PI).sqrt() * f64::from(target))).ceil() as u32
}

/// The bake's point sets, cosine-weighted in the local frame, with y_j at every point: first
/// the pilot (K replicates of m points, independently scrambled), then the extension of
/// replicate 0 round by round (its points m..2m, 2m..4m, …, up to the cap), each block sorted
/// along a Hilbert curve (close directions trace faster; sums do not depend on the order).
pub struct Tables {
    pub target: f32,
    /// Points of each pilot replicate (m).
    pub pilot: u32,
    /// Points of replicate 0 (the net) after each block: m, 2m, 4m, …, the cap.
    pub rounds: Vec<u32>,
    /// The least net: with the pilot's other replicates, 1/(√(4π)·E) rays in all.
    pub feature_net: u32,
    dirs: Vec<Vec3>,
    /// y_j(dirs[i]) at `[i·n² + j]`.
    sh: Vec<f32>,
    /// The replicate each pilot row belongs to.
    replicate: Vec<u8>,
}

impl Tables {
    pub fn new(options: &BakeOptions, basis: &Basis) -> Tables {
        let target = options.target_error.expect("an adaptive bake");
        let k = REPLICATES;
        let m = pilot_points(options.samples);
        let net_cap = options.samples - (k as u32 - 1) * m;
        let mut rounds = vec![m];
        while *rounds.last().unwrap() < net_cap {
            rounds.push((rounds.last().unwrap() * 2).min(net_cap));
        }
        let sets: Vec<OwenSobol> = (0..k as u64)
            .map(|r| OwenSobol::new(vertex_seed(options.seed, u64::MAX - 1 - r)))
            .collect();
        let (mut dirs, mut replicate) = (Vec::new(), Vec::new());
        let mut block: Vec<(u64, u8, f32, f32)> = Vec::new();
        for (r, set) in sets.iter().enumerate() {
            for i in 0..m {
                let (u1, u2) = set.point(i);
                block.push((hilbert_index(u1, u2), r as u8, u1, u2));
            }
        }
        let mut push = |block: &mut Vec<(u64, u8, f32, f32)>| {
            block.sort_by_key(|&(h, r, _, _)| (h, r));
            dirs.extend(
                block
                    .iter()
                    .map(|&(_, _, u1, u2)| cosine_hemisphere(u1, u2)),
            );
            replicate.extend(block.iter().map(|&(_, r, _, _)| r));
            block.clear();
        };
        push(&mut block);
        for pair in rounds.windows(2) {
            for i in pair[0]..pair[1] {
                let (u1, u2) = sets[0].point(i);
                block.push((hilbert_index(u1, u2), 0, u1, u2));
            }
            push(&mut block);
        }
        let n = basis.coeff_count();
        let mut sh = vec![0.0; dirs.len() * n];
        for (row, d) in sh.chunks_mut(n).zip(&dirs) {
            basis.eval(*d, row);
        }
        let feature_net = feature_rays(target).saturating_sub((k as u32 - 1) * m);
        Tables {
            target,
            pilot: m,
            rounds,
            feature_net,
            dirs,
            sh,
            replicate,
        }
    }

    /// The net size (an entry of `rounds`) predicted to reach the target from the pilot's
    /// per-replicate RMS error `spread` at m points: the smallest m·2^r of at least
    /// `feature_net` points with [`predicted_error`] ≤ E, or the cap.
    pub fn net_points(&self, spread: f64) -> u32 {
        for &points in &self.rounds {
            if predicted_error(spread, self.pilot, points) <= f64::from(self.target)
                && self.feature_net <= points
            {
                return points;
            }
        }
        *self.rounds.last().expect("at least the pilot")
    }
}

/// The RMS error of one net of `points` points predicted from the RMS error `spread` of one
/// replicate of `pilot` points: spread·(pilot/points)^(RATE/2).
pub fn predicted_error(spread: f64, pilot: u32, points: u32) -> f64 {
    spread * (f64::from(pilot) / f64::from(points)).powf(0.5 * RATE)
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

/// Casts rows `rows` of the tables from `origin` along `frame`, adding each unblocked row's
/// y_j to its replicate's totals.
#[allow(clippy::too_many_arguments)]
fn cast(
    tables: &Tables,
    n: usize,
    rows: std::ops::Range<usize>,
    origin: Vec3,
    frame: &Mat3,
    tracer: Option<&dyn Tracer>,
    s: &mut AdaptiveScratch,
    unblocked: &mut u32,
    bent: &mut Vec3,
) {
    for batch in rows.clone().step_by(BATCH) {
        let batch = batch..(batch + BATCH).min(rows.end);
        let len = batch.len();
        s.dirs.clear();
        s.dirs
            .extend(tables.dirs[batch.clone()].iter().map(|d| *frame * *d));
        match tracer {
            Some(tracer) => tracer.occluded_from(origin, &s.dirs, &mut s.occluded[..len]),
            None => s.occluded[..len].fill(false),
        }
        s.batch.fill(0.0);
        let sh = tables.sh[batch.start * n..batch.end * n].chunks_exact(n);
        for (((row, &blocked), &r), dir) in sh
            .zip(&s.occluded[..len])
            .zip(&tables.replicate[batch.clone()])
            .zip(&s.dirs)
        {
            if !blocked {
                let sums = &mut s.batch[usize::from(r) * n..][..n];
                for (acc, y) in sums.iter_mut().zip(row) {
                    *acc += y;
                }
                *unblocked += 1;
                *bent += *dir;
            }
        }
        for (total, b) in s.totals.iter_mut().zip(&s.batch) {
            *total += f64::from(*b);
        }
    }
}

/// Estimates vertex `v`'s local-frame transfer into `local` (n² values): the pilot, then, if
/// its mean is not yet within the target, one net of the predicted size. With no tracer
/// nothing is blocked.
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
    let m = tables.pilot;
    s.totals.clear();
    s.totals.resize(k * n, 0.0);
    s.batch.resize(k * n, 0.0);
    s.occluded.resize(BATCH, false);
    let (mut unblocked, mut bent) = (0u32, Vec3::ZERO);
    let pilot_rows = k * m as usize;
    cast(
        tables,
        n,
        0..pilot_rows,
        origin,
        frame,
        tracer,
        s,
        &mut unblocked,
        &mut bent,
    );
    let mean_error = replicate_error(&s.totals, n, m);
    let spread = mean_error * (k as f64).sqrt();
    let net = tables.net_points(spread);
    if (mean_error <= f64::from(tables.target) && tables.feature_net <= m) || net == m {
        let norm = 1.0 / (k as f64 * f64::from(m));
        for (j, out) in local.iter_mut().enumerate() {
            *out = (0..k).map(|r| s.totals[r * n + j]).sum::<f64>() * norm;
        }
        return VertexResult {
            rays: k as u32 * m,
            error: mean_error,
            unblocked,
            bent,
        };
    }
    let end = pilot_rows + (net - m) as usize;
    cast(
        tables,
        n,
        pilot_rows..end,
        origin,
        frame,
        tracer,
        s,
        &mut unblocked,
        &mut bent,
    );
    let norm = 1.0 / f64::from(net);
    for (out, total) in local.iter_mut().zip(&s.totals[..n]) {
        *out = total * norm;
    }
    VertexResult {
        rays: (k as u32 - 1) * m + net,
        error: predicted_error(spread, m, net),
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
    fn the_net_is_the_smallest_round_predicted_to_reach_the_target() {
        let options = BakeOptions {
            target_error: Some(1e-3),
            samples: 4096,
            ..BakeOptions::default()
        };
        let tables = Tables::new(&options, &Basis::new(4));
        // 64-point pilot replicates; the net doubles from 64 to 4096 − 3·64 = 3904.
        assert_eq!(tables.pilot, 64);
        assert_eq!(tables.rounds, [64, 128, 256, 512, 1024, 2048, 3904]);
        // 1/(√(4π)·10⁻³) = 283 rays, 91 of them beyond the other replicates' 192.
        assert_eq!(feature_rays(1e-3), 283);
        assert_eq!(tables.feature_net, 91);
        // s at 64 points = 4E: (64/N)^0.75 ≤ 1/4 at N ≥ 64·4^(4/3) = 406, so 512.
        assert_eq!(tables.net_points(4e-3), 512);
        assert!((predicted_error(4e-3, 64, 512) - 4e-3 / 8f64.powf(0.75)).abs() < 1e-15);
        // A quiet pilot still casts the feature floor's net; a noisy one stops at the cap.
        assert_eq!(tables.net_points(0.0), 128);
        assert_eq!(tables.net_points(1.0), 3904);
        // The pilot shrinks to what the cap allows.
        assert_eq!(pilot_points(256), 64);
        assert_eq!(pilot_points(1 << 20), 64);
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
