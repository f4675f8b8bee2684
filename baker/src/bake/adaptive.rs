//! Adaptive sampling to a stated accuracy (`--target-error E`).
//!
//! Each receiver (vertex or texel) casts a **pilot**, the first K·m points of the fixed bake's
//! Owen-scrambled Sobol sequence, predicts from it how many points N of that sequence it needs
//! for its RMS coefficient error (the root mean square, over its n² coefficients, of the
//! error of its transfer) to be at most E, and sums the answers of points up to N. Two things
//! make that cheaper than the fixed bake of the same accuracy: N differs per receiver, and a
//! point whose neighbours in the net agree (all blocked or all open) is given their answer
//! instead of a ray ([`crate::bake::inference`]), so rays are cast only along the shadows'
//! edges. Where every inference is right, a receiver that stops at N points holds exactly
//! what the fixed N-ray bake holds for it (same sequence, same frame; `tests/adaptive.rs`).
//!
//! # The estimate
//!
//! An Owen-scrambled net is far more accurate than independent samples: its variance falls as
//! N^-1.5 where the integrand has edges (shadows) and faster where it is smooth, so the
//! per-sample variance σ²/N overstates its error. The pilot's K = [`PILOT_BLOCKS`] blocks of
//! m = [`BLOCK_POINTS`] consecutive points are each a scrambled net of m points (a (0,2)-
//! sequence's aligned blocks are nets), so the spread of their K means measures one block's
//! error. The blocks are not independent: together they form a net of K·m points, whose
//! variance the model puts at V·K^-RATE for a block variance V, which makes their covariance
//! C = V·(K^(1−RATE) − 1)/(K − 1) (negative) and the expected spread V − C. So
//!
//! ```text
//!     s² = (1/n²) Σ_j Σ_k (T̂_k,j − T̄_j)² / (K − 1) / (1 + (1 − K^(1−RATE))/(K − 1)),
//!     predicted error at N points = s·(m/N)^(RATE/2),         RATE = 1.5.
//! ```
//!
//! 1. **Pilot**: K·m = 256 points (4 blocks of 64). If the predicted error at 256 is within E
//!    (and the feature floor allows), the receiver stops there.
//! 2. **The rest**: otherwise it extends the sequence to the smallest size of the grid K·m,
//!    then quarter-octave steps (256, 320, 384, 448, 512, 640, …), whose predicted error is
//!    ≤ E. Powers of two alone overshot by 1.4 × on average.
//! 3. **Features**: every receiver sums at least 1/(√(4π)·E) points ([`feature_rays`]): a
//!    feature that no point hits then changes its coefficients by at most E in RMS. Without
//!    this floor, a demo-scene vertex with an unseen sliver of sky stopped at the pilot with an
//!    estimate of 0 and a true error of 2.4e-3. Every point below [`cast_prefix`] (the power
//!    of two nearest that floor, at least the pilot) is cast; beyond it, answers are inferred
//!    where the neighbours agree, so a feature between all of the prefix's points is missed
//!    as the floor allows (within √2·E).
//!
//! The previous designs estimated from independently scrambled replicates: 16 doubling
//! together (1.8 × the rays of the fixed bake they matched), then 4 × 64 replicates and one
//! net extending the first (1.4 ×), which threw away the other replicates' 192 rays and
//! doubled the net. The prediction's rate is a model; the oracle test (`tests/adaptive.rs`)
//! holds it to the truth (true error ≤ 1.5 E at ≥ 95 % of trials, RMS estimate close to the
//! RMS true error), and `examples/adaptive_vs_fixed.rs` measures it against fixed bakes
//! (docs/explanation/performance.md).
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

use crate::bake::inference::Grid;
use crate::bake::options::BakeOptions;
pub use crate::bake::options::{BLOCK_POINTS, PILOT_BLOCKS, RATE};
use crate::math::sampling::{OwenSobol, cosine_hemisphere, hilbert_index, vertex_seed};
use crate::math::sh::Basis;
use crate::trace::Tracer;

/// Rays per tracer call.
const BATCH: usize = 256;

/// Steps of the sizes a receiver may stop at, per octave beyond the pilot.
const STEPS_PER_OCTAVE: u32 = 4;

/// The pilot's points per block: [`BLOCK_POINTS`], or what the cap leaves each block.
pub fn pilot_points(samples: u32) -> u32 {
    BLOCK_POINTS.min(samples / PILOT_BLOCKS as u32)
}

/// Rays that see any feature worth more than E: a feature no ray hits (one whose
/// cosine-weighted measure p is below 1/N for N stratified points) changes the receiver's
/// coefficients by p·y_j(s), whose RMS over j is p/√(4π) (the addition theorem:
/// Σ_j y_j(s)² = n²/4π), so N ≥ 1/(√(4π)·E) keeps it ≤ E.
pub fn feature_rays(target: f32) -> u32 {
    (1.0 / ((4.0 * std::f64::consts::PI).sqrt() * f64::from(target))).ceil() as u32
}

/// The points every receiver casts before any is inferred: the power of two nearest the
/// feature floor in ratio (a feature that falls between all of them is then worth at most
/// √2·E), at least the pilot, at most the cap. Rounding the floor up instead cost 1.4 × the
/// rays at E = 10⁻³ on the demo scene (560 against 402) for a p99 error 4 % lower.
pub fn cast_prefix(pilot: u32, feature_floor: u32, cap: u32) -> u32 {
    let up = feature_floor.max(1).next_power_of_two();
    let nearest = if f64::from(up) > std::f64::consts::SQRT_2 * f64::from(feature_floor) {
        up / 2
    } else {
        up
    };
    nearest.max(pilot).min(cap)
}

/// The bake's points: the fixed bake's Owen-scrambled Sobol sequence, cosine-weighted in the
/// local frame, with y_j at every point. First the pilot (its first K·m points, in K blocks of
/// m), then its extension segment by segment up to each size of `rounds`, each segment
/// sorted along a Hilbert curve (close directions trace faster; sums do not depend on the
/// order).
pub struct Tables {
    pub target: f32,
    /// Points of each pilot block (m).
    pub pilot: u32,
    /// The sizes a receiver may stop at: K·m, then steps of a quarter octave, up to the cap.
    pub rounds: Vec<u32>,
    /// The least number of points: 1/(√(4π)·E).
    pub feature_net: u32,
    dirs: Vec<Vec3>,
    /// y_j(dirs[i]) at `[i·n² + j]`.
    sh: Vec<f32>,
    /// The block each row belongs to (0 beyond the pilot).
    block: Vec<u8>,
    /// The sequence index of each row.
    index: Vec<u32>,
    /// Every point as fixed-point coordinates, by sequence index ([`OwenSobol::bits`]).
    bits: Vec<(u32, u32)>,
    /// Points before this index are always cast; later ones may be inferred
    /// ([`crate::bake::inference`]): a power of two, at least the pilot and the feature floor.
    pub cast_prefix: u32,
}

impl Tables {
    pub fn new(options: &BakeOptions, basis: &Basis) -> Tables {
        let target = options.target_error.expect("an adaptive bake");
        let k = PILOT_BLOCKS as u32;
        let m = pilot_points(options.samples);
        let cap = options.samples;
        let mut rounds = vec![k * m];
        while *rounds.last().unwrap() < cap {
            let last = *rounds.last().unwrap();
            let octave = 1u32 << (31 - last.leading_zeros());
            rounds.push((last + (octave / STEPS_PER_OCTAVE).max(1)).min(cap));
        }
        let set = OwenSobol::new(vertex_seed(options.seed, u64::MAX));
        let bits: Vec<(u32, u32)> = (0..cap).map(|i| set.bits(i)).collect();
        let (mut dirs, mut block_of, mut index) = (Vec::new(), Vec::new(), Vec::new());
        let mut starts = vec![0];
        starts.extend(&rounds);
        for pair in starts.windows(2) {
            let mut block: Vec<(u64, u32, f32, f32)> = (pair[0]..pair[1])
                .map(|i| {
                    let (u1, u2) = set.point(i);
                    (hilbert_index(u1, u2), i, u1, u2)
                })
                .collect();
            block.sort_by_key(|&(h, i, _, _)| (h, i));
            dirs.extend(
                block
                    .iter()
                    .map(|&(_, _, u1, u2)| cosine_hemisphere(u1, u2)),
            );
            let block_of_point = |i: u32| if i < k * m { (i / m) as u8 } else { 0 };
            block_of.extend(block.iter().map(|&(_, i, _, _)| block_of_point(i)));
            index.extend(block.iter().map(|&(_, i, _, _)| i));
        }
        let n = basis.coeff_count();
        let mut sh = vec![0.0; dirs.len() * n];
        for (row, d) in sh.chunks_mut(n).zip(&dirs) {
            basis.eval(*d, row);
        }
        let feature_net = feature_rays(target);
        Tables {
            target,
            pilot: m,
            rounds,
            feature_net,
            dirs,
            sh,
            block: block_of,
            index,
            bits,
            cast_prefix: cast_prefix(k * m, feature_net, cap),
        }
    }

    /// The number of points (an entry of `rounds`) predicted to reach the target from the
    /// pilot's per-block RMS error `spread` at m points: the smallest of at least
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

/// The RMS error of `points` points of the sequence predicted from the RMS error `spread` of
/// one block of `pilot` points: spread·(pilot/points)^(RATE/2).
pub fn predicted_error(spread: f64, pilot: u32, points: u32) -> f64 {
    spread * (f64::from(pilot) / f64::from(points)).powf(0.5 * RATE)
}

/// What one vertex's adaptive estimate gives besides its coefficients.
pub struct VertexResult {
    /// Rays cast.
    pub rays: u32,
    /// Points of the sequence the estimate sums: the rays cast and the answers inferred.
    pub points: u32,
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
    /// Per-block f64 sums, `[k·n² + j]`.
    totals: Vec<f64>,
    /// Every point's answer so far, by sequence index: 1 unblocked, 0 blocked.
    seen: Vec<u8>,
    /// The grid the current octave is inferred from (its memory reused across receivers).
    grid: Grid,
    /// Whether `grid` belongs to the current receiver.
    grid_current: bool,
    /// Rows of the current segment that must be cast.
    to_cast: Vec<usize>,
    /// How this extension answers points past the cast prefix ([`ReceiverState::extend`]).
    inference: Inference,
    /// The audited rows of the current segment, with the answer inference gave them.
    audits: Vec<(usize, u8)>,
    /// Audited points so far, and those whose ray disagreed with the inferred answer.
    audited: u32,
    mismatches: u32,
}

/// An audited extension casts the inferred points whose sequence index is a multiple of this
/// too, to count inference's mistakes ([`crate::bake::adaptive_denoised`], "Inference").
pub const AUDIT_EVERY: usize = 4;

/// How an extension ([`ReceiverState::extend`]) answers the points beyond the cast prefix.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Inference {
    /// Every point is cast.
    Off,
    /// A point whose neighbours agree is inferred ([`crate::bake::inference`]).
    #[default]
    On,
    /// As `On`, and every n-th inferred point is cast as well, its ray's answer kept and a
    /// disagreement counted.
    Audited(usize),
}

/// Answers rows `rows` of the tables (a segment: points of one octave at most) from `origin`
/// along `frame`: beyond the cast prefix, a point whose neighbours in the octave's grid agree
/// is inferred ([`crate::bake::inference`]), the others are cast. Then each unblocked row's
/// y_j goes to its block's totals (the pilot's first block beyond the pilot). Returns the
/// rays cast.
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
) -> u32 {
    s.seen.resize(s.seen.len().max(rows.end), 0);
    s.to_cast.clear();
    let infer = rows.start >= tables.cast_prefix as usize
        && tracer.is_some()
        && s.inference != Inference::Off;
    if infer {
        let level = usize::BITS - 1 - rows.start.leading_zeros();
        if !s.grid_current || s.grid.level() != level {
            s.grid.rebuild(level, &tables.bits, &s.seen);
            s.grid_current = true;
        }
    }
    let grid = Some(&s.grid).filter(|_| infer);
    let audit = match s.inference {
        Inference::Audited(every) => every,
        Inference::Off | Inference::On => 0,
    };
    s.audits.clear();
    for row in rows.clone() {
        let i = tables.index[row] as usize;
        match grid.and_then(|g| g.infer(tables.bits[i])) {
            Some(answer) if audit > 0 && i % audit == 0 => {
                s.audits.push((row, answer));
                s.to_cast.push(row);
            }
            Some(answer) => s.seen[i] = answer,
            None => s.to_cast.push(row),
        }
    }
    for batch in s.to_cast.chunks(BATCH) {
        s.dirs.clear();
        s.dirs
            .extend(batch.iter().map(|&row| *frame * tables.dirs[row]));
        let occluded = &mut s.occluded[..batch.len()];
        match tracer {
            Some(tracer) => tracer.occluded_from(origin, &s.dirs, occluded),
            None => occluded.fill(false),
        }
        for (&row, &blocked) in batch.iter().zip(occluded.iter()) {
            s.seen[tables.index[row] as usize] = u8::from(!blocked);
        }
    }
    // The audited points keep their rays' answers; their inferred ones are only counted.
    s.audited += s.audits.len() as u32;
    for &(row, inferred) in &s.audits {
        s.mismatches += u32::from(s.seen[tables.index[row] as usize] != inferred);
    }
    for batch in rows.clone().step_by(BATCH) {
        let batch = batch..(batch + BATCH).min(rows.end);
        s.batch.fill(0.0);
        let sh = tables.sh[batch.start * n..batch.end * n].chunks_exact(n);
        for ((y, row), &b) in sh.zip(batch.clone()).zip(&tables.block[batch.clone()]) {
            if s.seen[tables.index[row] as usize] == 1 {
                let sums = &mut s.batch[usize::from(b) * n..][..n];
                for (acc, y) in sums.iter_mut().zip(y) {
                    *acc += y;
                }
                *unblocked += 1;
                *bent += *frame * tables.dirs[row];
            }
        }
        for (total, b) in s.totals.iter_mut().zip(&s.batch) {
            *total += f64::from(*b);
        }
    }
    s.to_cast.len() as u32
}

/// Estimates vertex `v`'s local-frame transfer into `local` (n² values): the pilot, then, if
/// its predicted error is not yet within the target, the sequence's further points up to the
/// predicted size. With no tracer nothing is blocked.
pub fn receiver_transfer(
    tables: &Tables,
    n: usize,
    origin: Vec3,
    frame: &Mat3,
    tracer: Option<&dyn Tracer>,
    s: &mut AdaptiveScratch,
    local: &mut [f64],
) -> VertexResult {
    let m = tables.pilot;
    let (mut rays, mut unblocked, mut bent) = pilot(tables, n, origin, frame, tracer, s);
    let spread = block_spread(&s.totals, n, m);
    let net = tables.net_points(spread);
    rays += extend(
        tables,
        n,
        (origin, frame),
        tracer,
        s,
        tables.rounds[0]..net,
        (&mut unblocked, &mut bent),
    );
    sequence_mean(&s.totals, n, net, local);
    VertexResult {
        rays,
        points: net,
        error: predicted_error(spread, m, net),
        unblocked,
        bent,
    }
}

/// Casts the pilot (the first K·m points) into fresh totals: returns the rays cast, the
/// unblocked count and the sum of the unblocked world directions.
fn pilot(
    tables: &Tables,
    n: usize,
    origin: Vec3,
    frame: &Mat3,
    tracer: Option<&dyn Tracer>,
    s: &mut AdaptiveScratch,
) -> (u32, u32, Vec3) {
    let k = PILOT_BLOCKS;
    s.totals.clear();
    s.totals.resize(k * n, 0.0);
    s.batch.resize(k * n, 0.0);
    s.occluded.resize(BATCH, false);
    s.seen.clear();
    s.grid_current = false;
    let (mut unblocked, mut bent) = (0u32, Vec3::ZERO);
    let pilot_rows = k * tables.pilot as usize;
    let rays = cast(
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
    (rays, unblocked, bent)
}

/// Extends the points summed in `s` over `points` (from one stop size of the tables to a
/// later one), segment by segment, so no segment spans two octaves. Returns the rays cast.
fn extend(
    tables: &Tables,
    n: usize,
    (origin, frame): (Vec3, &Mat3),
    tracer: Option<&dyn Tracer>,
    s: &mut AdaptiveScratch,
    points: std::ops::Range<u32>,
    (unblocked, bent): (&mut u32, &mut Vec3),
) -> u32 {
    let mut rays = 0;
    for pair in tables.rounds.windows(2) {
        let rows = pair[0] as usize..pair[1] as usize;
        if rows.start >= points.end as usize {
            break;
        }
        if rows.start < points.start as usize {
            continue;
        }
        rays += cast(tables, n, rows, origin, frame, tracer, s, unblocked, bent);
    }
    rays
}

/// The estimate of the first `points` points from their block totals `totals[k·n + j]`.
fn sequence_mean(totals: &[f64], n: usize, points: u32, local: &mut [f64]) {
    let norm = 1.0 / f64::from(points);
    for (j, out) in local.iter_mut().enumerate() {
        *out = (0..PILOT_BLOCKS).map(|r| totals[r * n + j]).sum::<f64>() * norm;
    }
}

/// One receiver of a bake sampled in passes ([`crate::bake::adaptive_denoised`]): what it
/// has summed so far, kept between passes so a later pass extends its sequence instead of
/// casting it again. Extending to N points in several passes sums exactly what one pass to
/// N sums: every inference grid is built from the points before an octave only.
#[derive(Clone, Debug, Default)]
pub struct ReceiverState {
    /// Block totals `[k·n² + j]` (the points beyond the pilot in block 0).
    totals: Vec<f64>,
    /// The answers of the points summed, one bit a point, by sequence index.
    seen: Vec<u64>,
    /// Rays cast, and points summed (a stop size of the tables).
    pub rays: u32,
    pub points: u32,
    pub unblocked: u32,
    /// The sum of the unblocked world directions.
    pub bent: Vec3,
    /// Inferred points audited by a ray, and those whose ray disagreed ([`AUDIT_EVERY`]).
    pub audited: u32,
    pub mismatches: u32,
    /// The pilot's per-block RMS error over every coefficient ([`block_spread`]).
    pub spread: f64,
    /// The same over bands 0 and 1 only: the noise the denoiser's range term reads
    /// ([`crate::bake::noise`] sums the same coefficients).
    pub low_spread: f64,
}

impl ReceiverState {
    /// The pilot of one receiver.
    pub fn pilot(
        tables: &Tables,
        n: usize,
        (origin, frame): (Vec3, &Mat3),
        tracer: Option<&dyn Tracer>,
        s: &mut AdaptiveScratch,
    ) -> ReceiverState {
        let (rays, unblocked, bent) = pilot(tables, n, origin, frame, tracer, s);
        let mut state = ReceiverState {
            rays,
            points: tables.rounds[0],
            unblocked,
            bent,
            spread: block_spread(&s.totals, n, tables.pilot),
            low_spread: block_spread_of(&s.totals, n, n.min(4), tables.pilot),
            ..ReceiverState::default()
        };
        state.save(s);
        state
    }

    /// Extends the receiver's sequence to `points` (a stop size of the tables, more than it
    /// holds), inferring points as `inference` says.
    #[allow(clippy::too_many_arguments)]
    pub fn extend(
        &mut self,
        tables: &Tables,
        n: usize,
        (origin, frame): (Vec3, &Mat3),
        tracer: Option<&dyn Tracer>,
        s: &mut AdaptiveScratch,
        points: u32,
        inference: Inference,
    ) {
        s.inference = inference;
        (s.audited, s.mismatches) = (0, 0);
        s.totals.clone_from(&self.totals);
        s.batch.resize(PILOT_BLOCKS * n, 0.0);
        s.occluded.resize(BATCH, false);
        s.seen.clear();
        s.seen
            .extend((0..self.points as usize).map(|i| ((self.seen[i / 64] >> (i % 64)) & 1) as u8));
        s.grid_current = false;
        self.rays += extend(
            tables,
            n,
            (origin, frame),
            tracer,
            s,
            self.points..points,
            (&mut self.unblocked, &mut self.bent),
        );
        s.inference = Inference::default();
        self.audited += s.audited;
        self.mismatches += s.mismatches;
        self.points = points;
        self.save(s);
    }

    fn save(&mut self, s: &AdaptiveScratch) {
        self.totals.clone_from(&s.totals);
        self.seen.clear();
        self.seen.resize((self.points as usize).div_ceil(64), 0);
        for (i, &answer) in s.seen[..self.points as usize].iter().enumerate() {
            self.seen[i / 64] |= u64::from(answer & 1) << (i % 64);
        }
    }

    /// The local-frame transfer of the points summed.
    pub fn local_transfer(&self, n: usize, local: &mut [f64]) {
        sequence_mean(&self.totals, n, self.points, local);
    }

    /// The predicted mean squared coefficient error of the transfer, over every coefficient
    /// (`low`: bands 0 and 1 only).
    pub fn variance(&self, tables: &Tables, low: bool) -> f64 {
        let spread = if low { self.low_spread } else { self.spread };
        predicted_error(spread, tables.pilot, self.points).powi(2)
    }
}

/// One pilot block's RMS coefficient error s, from the K blocks whose sums over `points`
/// points each are `totals[k·n + j]`: the blocks' sample variance, corrected for their
/// covariance under the rate model (module doc).
pub fn block_spread(totals: &[f64], n: usize, points: u32) -> f64 {
    block_spread_of(totals, n, n, points)
}

/// [`block_spread`] over the first `used` of the n coefficients.
fn block_spread_of(totals: &[f64], n: usize, used: usize, points: u32) -> f64 {
    let k = totals.len() / n;
    let scale = 1.0 / f64::from(points);
    let mut sum_of_variances = 0.0;
    for j in 0..used {
        let estimate = |r: usize| totals[r * n + j] * scale;
        let mean = (0..k).map(estimate).sum::<f64>() / k as f64;
        let squares: f64 = (0..k).map(|r| (estimate(r) - mean).powi(2)).sum();
        sum_of_variances += squares / (k - 1) as f64;
    }
    let blocks = k as f64;
    let inflation = 1.0 + (1.0 - blocks.powf(1.0 - RATE)) / (blocks - 1.0);
    (sum_of_variances / used as f64 / inflation).sqrt()
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

    #[test]
    fn the_stop_is_the_smallest_size_predicted_to_reach_the_target() {
        let options = BakeOptions {
            target_error: Some(1e-3),
            samples: 4096,
            ..BakeOptions::default()
        };
        let tables = Tables::new(&options, &Basis::new(4));
        // Four pilot blocks of 64, then quarter octaves up to the cap.
        assert_eq!(tables.pilot, 64);
        assert_eq!(
            tables.rounds,
            [
                256, 320, 384, 448, 512, 640, 768, 896, 1024, 1280, 1536, 1792, 2048, 2560, 3072,
                3584, 4096
            ]
        );
        // 1/(√(4π)·10⁻³) = 283 rays.
        assert_eq!(feature_rays(1e-3), 283);
        assert_eq!(tables.feature_net, 283);
        // s at 64 points = 4E: (64/N)^0.75 ≤ 1/4 at N ≥ 64·4^(4/3) = 406, so 448.
        assert_eq!(tables.net_points(4e-3), 448);
        assert!((predicted_error(4e-3, 64, 512) - 4e-3 / 8f64.powf(0.75)).abs() < 1e-15);
        // A quiet pilot still casts the feature floor; a noisy one stops at the cap.
        assert_eq!(tables.net_points(0.0), 320);
        assert_eq!(tables.net_points(1.0), 4096);
        // The pilot shrinks to what the cap allows, and the grid ends at the cap.
        assert_eq!(pilot_points(256), 64);
        assert_eq!(pilot_points(1 << 20), 64);
        let capped = Tables::new(
            &BakeOptions {
                samples: 300,
                ..options.clone()
            },
            &Basis::new(4),
        );
        assert_eq!(capped.rounds, [256, 300]);
    }

    #[test]
    fn the_cast_prefix_is_the_power_of_two_nearest_the_feature_floor() {
        // E = 10⁻³: 283 rays → 256; 5·10⁻⁴: 565 → 512; 2.5·10⁻⁴: 1,129 → 1,024; 363 → 512.
        assert_eq!(cast_prefix(256, 283, 1 << 16), 256);
        assert_eq!(cast_prefix(256, 565, 1 << 16), 512);
        assert_eq!(cast_prefix(256, 1129, 1 << 16), 1024);
        assert_eq!(cast_prefix(256, 363, 1 << 16), 512);
        // Never below the pilot nor above the cap.
        assert_eq!(cast_prefix(256, 71, 1 << 16), 256);
        assert_eq!(cast_prefix(256, 5000, 3000), 3000);
    }

    #[test]
    fn the_block_spread_is_corrected_for_the_blocks_covariance() {
        // Two coefficients, four blocks of 2 points: estimates 1, 2, 3, 4 (sample variance
        // 5/3) and all 5 (zero); with RATE 1.5 the blocks' spread overstates V by 7/6.
        let totals = [2.0, 10.0, 4.0, 10.0, 6.0, 10.0, 8.0, 10.0];
        let expected = ((5.0 / 3.0 + 0.0) / 2.0 / (7.0 / 6.0f64)).sqrt();
        assert!((block_spread(&totals, 2, 2) - expected).abs() < 1e-15);
    }

    #[test]
    fn distributions_use_nearest_ranks() {
        let d = Distribution::of((1..=100).map(f64::from)).unwrap();
        assert_eq!((d.min, d.median, d.p95, d.max), (1.0, 50.0, 95.0, 100.0));
        assert_eq!(d.mean, 50.5);
        assert!(Distribution::of(std::iter::empty()).is_none());
    }
}
