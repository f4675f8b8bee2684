//! Adaptive sampling to a stated accuracy *after denoising* (`--target-error E` with
//! `--denoise`): rays go where the filter cannot help.
//!
//! The denoiser ([`crate::bake::denoise`]) is linear, with weights w_ij that every
//! coefficient shares: T̃_i = Σ_j w_ij T_j. Receivers' estimates are independent (each has its
//! own frame about its normal), so the denoised estimate's mean squared coefficient error is
//!
//! ```text
//!     σ̃_i² = Σ_j w_ij² σ_j²(N_j),      σ_j²(N) = s_j² (m/N)^RATE,
//! ```
//!
//! with s_j receiver j's pilot spread and N_j its points ([`crate::bake::adaptive`]'s model).
//! Where the filter has many like neighbours (an open wall) the sum is far below any one σ_j²;
//! where its weights concentrate on few (a shadow edge the range term keeps, a contact
//! shadow, a small object, a chart's corner) it is not, and those receivers need rays.
//!
//! # The loop
//!
//! 1. Every receiver casts the pilot (256 points).
//! 2. The filter is built from the bake so far, its range term reading each receiver's
//!    predicted noise, and each receiver's σ̃_i is formed from its row of weights.
//! 3. Each receiver i with σ̃_i > E asks its neighbours j for more points: the allocation
//!    that meets Σ_j c_j (N_j/N'_j)^RATE = (0.9 E)² with c_j = w_ij² σ_j² at the fewest
//!    points Σ N'_j (a Lagrange multiplier: N'_j/N_j = (L c_j/N_j)^(1/(RATE+1))), so the j
//!    whose variance dominates i's get most. Each j takes the most any i asks, rounded up to
//!    the next stop size of the sequence, at most `--samples`, and extends its sequence.
//! 4. Back to 2, until no receiver above E can grow, or after [`MAX_PASSES`] passes: the
//!    weights change as the noise shrinks (the range term keeps more edges), so the last
//!    pass's filter is the one applied and the one whose σ̃_i the file records.
//!
//! The feature floor of the raw bake (every receiver casting 1/(√(4π)E) points) is not
//! imposed: a feature between one receiver's points is hit by its neighbours', turned about
//! their own normals, and the filter averages them. The oracle is a converged bake
//! (docs/explanation/performance.md).
//!
//! # Inference, audited
//!
//! Beyond the cast prefix a point whose neighbours in the net agree is given their answer
//! instead of a ray ([`crate::bake::adaptive`]). Its mistakes (a sliver of sky or a thin
//! occluder between the neighbours) are not in the pilot's spread, so σ_j² omits them. The
//! filter averages them away where it averages many receivers; where a receiver's output is
//! mostly its own estimate (a shadow edge the range term keeps, an outlier the mistake itself
//! made) they pass through whole: on the torus at E = 10⁻³ they made the p99 tail, 1.19 E.
//! So inference's error is measured where it matters: a receiver whose own estimate is at
//! least [`AUDIT_SHARE`] of its output (α_i w_ii + 1 − α_i) also casts every
//! [`AUDIT_EVERY`]-th point it infers (by sequence index: deterministic) and counts the rays
//! that disagree with the inferred answer. The audited points keep their rays' answers, which
//! also break the agreement that the next octave's inference needs about a missed sliver. A
//! receiver with a mismatch infers no more: it is cast again from the pilot, every point
//! (its unaudited inferred points cannot be told apart; only while its rays stay within
//! `--samples`). Receivers whose inference is right, and those the filter averages, keep
//! their savings (docs/explanation/performance.md).
//!
//! Every pass is a pure function of the previous one (the receivers in parallel, each on its
//! own; the filter bit-identical on any thread; the allocation a maximum), so the bake is
//! bit-identical for any number of threads.

use glam::{Mat3, Vec3};
use rayon::prelude::*;

use crate::bake::adaptive::{
    AUDIT_EVERY, AdaptiveScratch, Inference, ReceiverState, Tables, predicted_error,
};
use crate::bake::denoise::{Filter, Guides, Settings};
use crate::bake::estimator::{Estimator, Visibility};
use crate::bake::options::RATE;
use crate::math::sh::{RotationScratch, ZyzRotator};
use crate::support::progress::Progress;
use crate::trace::Tracer;

/// Passes of filter and allocation at most (the first after the pilot).
pub const MAX_PASSES: usize = 8;
/// What E bounds is the 99th percentile of the receivers' true RMS errors, not their
/// predicted RMS: a receiver's error is a random variable about its prediction (the RMS of 9
/// Gaussian coefficients exceeds its σ 1.55 × at p99) and the prediction is itself
/// estimated, so each receiver's predicted RMS error is brought within E/TAIL. Measured on
/// the torus and the Cornell room (docs/explanation/performance.md).
pub const TAIL: f64 = 2.2;
/// A receiver whose own estimate is at least this share of its output (α_i w_ii + 1 − α_i)
/// has its inferred points audited (module doc, "Inference"); below it the filter averages
/// inference's mistakes with its neighbours'. Measured on the torus at E = 10⁻³ (p99 / E,
/// rays per vertex, every 4th inferred point audited): 0.5 gave 1.06 (691), 0.3 0.99 (811),
/// 0.2 0.98 (880), every receiver 0.97 (929).
pub const AUDIT_SHARE: f32 = 0.3;
/// The allocation aims this far below E, so a pass's new weights rarely need another pass.
const AIM: f64 = 0.9;

/// The denoised bake of every receiver.
pub struct DenoisedPass {
    /// Denoised, one channel: `coefficients[r · n² + j]`.
    pub coefficients: Vec<f32>,
    /// Per receiver; `error_estimate` is σ̃ (after denoising), `noise` the raw estimate's
    /// band-0 and band-1 variance.
    pub visibility: Vec<Visibility>,
    /// Passes of filter and allocation run.
    pub passes: usize,
}

/// Whether a bake samples to its denoised error: an adaptive bake that is denoised and casts
/// rays.
pub fn applies(options: &crate::bake::options::BakeOptions, tracer: Option<&dyn Tracer>) -> bool {
    options.denoise && options.target_error.is_some() && tracer.is_some()
}

/// Bakes `estimator`'s receivers (an adaptive bake) until each one's denoised estimate is
/// predicted within the target, and denoises them with the final filter.
pub fn bake(
    estimator: &Estimator,
    tracer: &dyn Tracer,
    guides: Guides,
    settings: Settings,
    progress: &dyn Progress,
) -> DenoisedPass {
    let tables = estimator
        .adaptive_tables()
        .expect("an adaptive bake (--target-error)");
    let n = estimator.basis.coeff_count();
    let count = estimator.receiver_count();
    let frames: Vec<(Vec3, Mat3)> = (0..count)
        .map(|v| (estimator.origin(v), estimator.vertex_frame(v)))
        .collect();
    progress.begin(
        "adaptive (denoised)",
        count as u64,
        u64::from(tables.rounds[0]),
    );
    let mut states: Vec<ReceiverState> = frames
        .par_iter()
        .map_init(AdaptiveScratch::default, |s, (origin, frame)| {
            let state = ReceiverState::pilot(tables, n, (*origin, frame), Some(tracer), s);
            progress.advance(1);
            state
        })
        .collect();
    progress.finish();
    let rotator = ZyzRotator::new(estimator.options.order);
    let mut guides = guides;
    let mut transfer = vec![0.0f32; count * n];
    // Receivers whose sums changed since the last pass (all, after the pilot), and those
    // that hold inferred points.
    let mut changed = vec![true; count];
    let mut inferred = vec![false; count];
    // Receivers that cast every point from now on (an audit found inference wrong there).
    let mut cast_all = vec![false; count];
    let cap = *tables.rounds.last().expect("at least the pilot");
    let mut passes = 0;
    loop {
        passes += 1;
        world_transfer(&states, &frames, &rotator, n, &changed, &mut transfer);
        guides.noise = states
            .iter()
            .map(|s| s.variance(tables, true) as f32)
            .collect();
        let filter = Filter::new(&guides, settings, &transfer, 1, n);
        let assessed = Assessed::new(&filter, &states, tables, &transfer, n);
        let mut wanted: Vec<u32> = states.iter().map(|s| s.points).collect();
        for asks in &assessed.asks {
            for &(j, p) in asks {
                wanted[j as usize] = wanted[j as usize].max(p);
            }
        }
        // A receiver whose audits found a mistake infers no more, and is cast again from the
        // pilot (its unaudited inferred points cannot be told apart) as long as its rays stay
        // within `--samples`.
        let mut recast = vec![false; count];
        for j in 0..count {
            cast_all[j] |= states[j].mismatches > 0;
            let want = wanted[j].max(states[j].points);
            recast[j] = cast_all[j] && inferred[j] && states[j].rays + want <= cap;
            changed[j] = wanted[j] > states[j].points || recast[j];
        }
        // Audited: the receivers whose own estimate is a large enough share of their output
        // for inference's mistakes to pass through the filter.
        let inference: Vec<Inference> = (0..count)
            .map(
                |j| match (cast_all[j], assessed.own_share(j) >= AUDIT_SHARE) {
                    (true, _) => Inference::Off,
                    (false, true) => Inference::Audited(AUDIT_EVERY),
                    (false, false) => Inference::On,
                },
            )
            .collect();
        let growing = changed.iter().filter(|c| **c).count();
        if growing == 0 || passes == MAX_PASSES {
            return finish(tables, estimator, &states, &transfer, &assessed, n, passes);
        }
        progress.begin("adaptive (denoised)", growing as u64, 0);
        states
            .par_iter_mut()
            .zip(&frames)
            .zip(wanted.par_iter().zip(&inference))
            .zip(changed.par_iter().zip(&recast).zip(&mut inferred))
            .for_each_init(
                AdaptiveScratch::default,
                |s, (((state, (o, f)), (&want, &inference)), ((&changed, &recast), inferred))| {
                    if !changed {
                        return;
                    }
                    let want = want.max(state.points);
                    if recast {
                        let rays = state.rays;
                        *state = ReceiverState::pilot(tables, n, (*o, f), Some(tracer), s);
                        state.rays += rays;
                        *inferred = false;
                    }
                    if want > state.points {
                        state.extend(tables, n, (*o, f), Some(tracer), s, want, inference);
                        *inferred |= inference != Inference::Off && want > tables.cast_prefix;
                    }
                    progress.advance(1);
                },
            );
        progress.finish();
    }
}

/// One receiver's α, predicted error and the points it asks of its neighbours.
type Judged = (f32, f64, Vec<(u32, u32)>);

/// One pass's judgement of every receiver: its filtered transfer, the share α_i of it
/// that goes into the output, the predicted error of the output and the points it asks of
/// its neighbours.
struct Assessed {
    /// Each receiver's weights (j, w_ij), in j's order.
    rows: Vec<Vec<(u32, f32)>>,
    /// T̃ = Σ_j w_ij T̂_j, n² floats a receiver.
    filtered: Vec<f32>,
    alpha: Vec<f32>,
    error: Vec<f64>,
    asks: Vec<Vec<(u32, u32)>>,
}

impl Assessed {
    fn new(
        filter: &Filter<'_>,
        states: &[ReceiverState],
        tables: &Tables,
        transfer: &[f32],
        n: usize,
    ) -> Assessed {
        let count = states.len();
        let rows = filter.rows();
        let variance = pooled_variance(states, tables, &rows);
        let filtered: Vec<f32> = rows
            .par_iter()
            .flat_map_iter(|row| {
                let mut out = vec![0.0f64; n];
                for &(j, w) in row {
                    for (o, t) in out.iter_mut().zip(&transfer[j as usize * n..][..n]) {
                        *o += f64::from(w) * f64::from(*t);
                    }
                }
                out.into_iter().map(|o| o as f32)
            })
            .collect();
        // The bias of each receiver's filtered estimate: its squared difference to the raw
        // estimate less what noise alone puts there (σ_i² (1 − 2 w_ii) + Σ_j w_ij² σ_j²).
        let noise = |row: &[(u32, f32)]| -> f64 {
            row.iter()
                .map(|&(j, w)| f64::from(w) * f64::from(w) * variance[j as usize])
                .sum()
        };
        let own = |i: usize, row: &[(u32, f32)]| f64::from(own_weight(i, row));
        let bias: Vec<f64> = (0..count)
            .into_par_iter()
            .map(|i| {
                let (a, b) = (&filtered[i * n..][..n], &transfer[i * n..][..n]);
                let d2: f64 = a
                    .iter()
                    .zip(b)
                    .map(|(x, y)| f64::from(x - y).powi(2))
                    .sum::<f64>()
                    / n as f64;
                let expected = variance[i] * (1.0 - 2.0 * own(i, &rows[i])) + noise(&rows[i]);
                // Not clamped here: the noise of a receiver's value is symmetric about its
                // bias, and clamping each before they are smoothed would bias the mean up.
                d2 - expected
            })
            .collect();
        // E bounds the tail: each receiver's predicted RMS error is brought within E/TAIL.
        let target = f64::from(tables.target) / TAIL;
        let cap = *tables.rounds.last().expect("at least the pilot");
        let points: Vec<u32> = states.iter().map(|s| s.points).collect();
        let judged: Vec<Judged> = (0..count)
            .into_par_iter()
            .map(|i| {
                let row = &rows[i];
                // The bias is coherent over a neighbourhood, its estimate noisy: smoothed
                // with the row's weights.
                let (sum, mass) = row.iter().fold((0.0, 0.0), |(s, m), &(j, w)| {
                    let w = f64::from(w.abs());
                    (s + w * bias[j as usize], m + w)
                });
                let bias = if mass > 0.0 {
                    (sum / mass).max(0.0)
                } else {
                    0.0
                };
                let blend = Blend {
                    filtered: bias + noise(row),
                    raw: variance[i],
                    shared: own(i, row) * variance[i],
                };
                let (alpha, mse) = blend.best();
                let asks = match mse.sqrt() > target {
                    false => Vec::new(),
                    true => asks(
                        i, row, &variance, &points, bias, target, cap, tables, states,
                    ),
                };
                (alpha as f32, mse.sqrt(), asks)
            })
            .collect();
        let mut out = Assessed {
            rows,
            filtered,
            alpha: Vec::with_capacity(count),
            error: Vec::with_capacity(count),
            asks: Vec::with_capacity(count),
        };
        for (alpha, error, asks) in judged {
            out.alpha.push(alpha);
            out.error.push(error);
            out.asks.push(asks);
        }
        out
    }

    /// The share of receiver i's own estimate in its output: α_i w_ii + (1 − α_i).
    fn own_share(&self, i: usize) -> f32 {
        let alpha = self.alpha[i];
        alpha * own_weight(i, &self.rows[i]) + (1.0 - alpha)
    }

    /// Σ_j w_ij values_j.
    fn filtered_scalar(&self, i: usize, values: &[f32]) -> f32 {
        let sum: f64 = self.rows[i]
            .iter()
            .map(|&(j, w)| f64::from(w) * f64::from(values[j as usize]))
            .sum();
        sum as f32
    }
}

/// w_ii: receiver i's weight on its own estimate in its row.
fn own_weight(i: usize, row: &[(u32, f32)]) -> f32 {
    row.iter().find(|e| e.0 as usize == i).map_or(0.0, |e| e.1)
}

/// Each receiver's variance σ_j²: its own estimate from 4 blocks of its pilot is noisy (a
/// pilot whose blocks agree by chance says 0), so it is taken as at least the mean of its
/// neighbours' estimates at its own points, weighed by |w_jk| (SVGF filters its variance
/// estimate likewise): neighbours alike enough to share the filter see alike noise.
fn pooled_variance(
    states: &[ReceiverState],
    tables: &Tables,
    rows: &[Vec<(u32, f32)>],
) -> Vec<f64> {
    // s² per receiver: the variance of one pilot block of m points.
    let pilot: Vec<f64> = states.iter().map(|s| s.spread * s.spread).collect();
    rows.par_iter()
        .zip(states)
        .enumerate()
        .map(|(i, (row, s))| {
            let (sum, mass) = row.iter().fold((0.0, 0.0), |(sum, mass), &(k, w)| {
                let w = f64::from(w.abs());
                (sum + w * pilot[k as usize], mass + w)
            });
            let pooled = if mass > 0.0 { sum / mass } else { 0.0 };
            predicted_error(pilot[i].max(pooled).sqrt(), tables.pilot, s.points).powi(2)
        })
        .collect()
}

/// The mean squared errors of a receiver's filtered estimate (bias² + Σ_j w_ij² σ_j²), of its
/// raw one (σ_i²), and their covariance (w_ii σ_i²): the output α T̃_i + (1 − α) T̂_i is the
/// blend of least predicted error, a per-receiver weight every coefficient shares (so still
/// linear in the light), as SURE-driven filter selection chooses per pixel (Li, Wu & Chuang
/// 2012, *SURE-based optimization for adaptive sampling and reconstruction*). Where the
/// filter's bias is small α ≈ 1; where it is not (a receiver whose like neighbours are too
/// few), the raw estimate takes over.
struct Blend {
    filtered: f64,
    raw: f64,
    shared: f64,
}

impl Blend {
    /// α in [0, 1] and the mean squared error of its blend.
    fn best(&self) -> (f64, f64) {
        let (a, c, k) = (self.filtered, self.raw, self.shared);
        let denominator = a + c - 2.0 * k;
        let alpha = match denominator > 0.0 {
            true => ((c - k) / denominator).clamp(0.0, 1.0),
            false => 1.0,
        };
        let mse = alpha * alpha * a + (1.0 - alpha).powi(2) * c + 2.0 * alpha * (1.0 - alpha) * k;
        (alpha, mse.max(0.0))
    }
}

/// The points receiver i (above the target) asks of its neighbours (module doc, step 3):
/// with a small bias, the allocation that brings Σ_j w_ij² σ_j² within (0.9 E)² − bias²;
/// where the bias takes half of that or more, rays cannot filter it away, and i asks its own
/// raw estimate within 0.9 E.
#[allow(clippy::too_many_arguments)]
fn asks(
    i: usize,
    row: &[(u32, f32)],
    variance: &[f64],
    points: &[u32],
    bias: f64,
    target: f64,
    cap: u32,
    tables: &Tables,
    states: &[ReceiverState],
) -> Vec<(u32, u32)> {
    let aim = (AIM * target).powi(2);
    if bias >= 0.5 * aim {
        if points[i] >= cap {
            return Vec::new();
        }
        // σ_i(N) = s (m/N)^(RATE/2) ≤ 0.9 E.
        let spread = states[i].spread;
        let want = f64::from(tables.pilot) * (spread / (AIM * target)).powf(2.0 / RATE);
        return vec![(
            i as u32,
            stop_at_least(tables, want.max(f64::from(points[i]) + 1.0)),
        )];
    }
    allocate(row, variance, points, aim - bias, cap, tables)
}

/// The fewest points that bring Σ_j c_j (N_j/N'_j)^RATE within `budget`, c_j = w_j² σ_j²
/// (module doc, step 3), as stop sizes of the tables at most `cap`.
fn allocate(
    row: &[(u32, f32)],
    variance: &[f64],
    points: &[u32],
    budget: f64,
    cap: u32,
    tables: &Tables,
) -> Vec<(u32, u32)> {
    let share = |&(j, w): &(u32, f32)| f64::from(w) * f64::from(w) * variance[j as usize];
    let (up, down) = (1.0 / (RATE + 1.0), RATE / (RATE + 1.0));
    let sum: f64 = row
        .iter()
        .map(|e| share(e).powf(up) * f64::from(points[e.0 as usize]).powf(down))
        .sum();
    let multiplier = (sum / budget).powf(1.0 / down);
    let mut asks = Vec::new();
    for e in row {
        let (c, have) = (share(e), f64::from(points[e.0 as usize]));
        if c <= 0.0 || have >= f64::from(cap) {
            continue;
        }
        let want = have * (multiplier * c / have).powf(up);
        if want > have {
            asks.push((e.0, stop_at_least(tables, want)));
        }
    }
    asks
}

/// The smallest stop size of the tables at least `points`, or the cap.
fn stop_at_least(tables: &Tables, points: f64) -> u32 {
    let last = *tables.rounds.last().expect("at least the pilot");
    tables
        .rounds
        .iter()
        .copied()
        .find(|&r| f64::from(r) >= points)
        .unwrap_or(last)
}

/// Every receiver's world-frame transfer so far, n² floats a receiver, into `out`: only
/// those `changed` since the last pass are rotated again.
fn world_transfer(
    states: &[ReceiverState],
    frames: &[(Vec3, Mat3)],
    rotator: &ZyzRotator,
    n: usize,
    changed: &[bool],
    out: &mut [f32],
) {
    out.par_chunks_mut(n)
        .zip(states.par_iter().zip(frames).zip(changed))
        .filter(|(_, (_, changed))| **changed)
        .for_each_init(
            || (vec![0.0; n], vec![0.0; n], RotationScratch::default()),
            |(local, world, scratch), (out, ((state, (_, frame)), _))| {
                state.local_transfer(n, local);
                rotator.rotate(frame.as_dmat3(), local, world, scratch);
                for (o, w) in out.iter_mut().zip(world.iter()) {
                    *o = *w as f32;
                }
            },
        );
}

/// The last pass: each receiver's blend α_i T̃_i + (1 − α_i) T̂_i of its filtered and raw
/// transfer (and accessibility, with the same weights), and its record.
fn finish(
    tables: &Tables,
    estimator: &Estimator,
    states: &[ReceiverState],
    transfer: &[f32],
    assessed: &Assessed,
    n: usize,
    passes: usize,
) -> DenoisedPass {
    let blend = |alpha: f32, filtered: f32, raw: f32| alpha * filtered + (1.0 - alpha) * raw;
    let coefficients: Vec<f32> = (0..states.len())
        .flat_map(|i| {
            let alpha = assessed.alpha[i];
            let (f, r) = (&assessed.filtered[i * n..][..n], &transfer[i * n..][..n]);
            f.iter().zip(r).map(move |(f, r)| blend(alpha, *f, *r))
        })
        .collect();
    let ao: Vec<f32> = states
        .iter()
        .map(|s| (f64::from(s.unblocked) / f64::from(s.points)) as f32)
        .collect();
    let visibility = states
        .iter()
        .enumerate()
        .map(|(v, s)| {
            let row_ao = assessed.filtered_scalar(v, &ao);
            Visibility {
                accessibility: blend(assessed.alpha[v], row_ao, ao[v]).clamp(0.0, 1.0),
                bent_normal: s.bent.try_normalize().unwrap_or(estimator.normals[v]),
                rays: s.rays,
                points: s.points,
                error_estimate: assessed.error[v] as f32,
                noise: s.variance(tables, true) as f32,
            }
        })
        .collect();
    DenoisedPass {
        coefficients,
        visibility,
        passes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::options::BakeOptions;
    use crate::math::sh::Basis;

    #[test]
    fn the_loudest_neighbour_is_asked_for_the_most_points_and_the_budget_is_met() {
        let options = BakeOptions {
            target_error: Some(1e-3),
            samples: 4096,
            ..BakeOptions::default()
        };
        let tables = Tables::new(&options, &Basis::new(2));
        let points = [256, 256, 256];
        // Receiver 0 averages three; neighbour 2 is 16 × louder than the others.
        let row = [(0, 1.0 / 3.0), (1, 1.0 / 3.0), (2, 1.0 / 3.0)];
        let loud = [4e-6, 4e-6, 64e-6];
        let budget = 0.81e-6;
        let asks = allocate(&row, &loud, &points, budget, 4096, &tables);
        let most = asks.iter().max_by_key(|a| a.1).unwrap();
        assert_eq!(most.0, 2);
        let after: f64 = row
            .iter()
            .map(|&(j, w)| {
                let p = asks.iter().find(|a| a.0 == j).map_or(256, |a| a.1);
                f64::from(w * w) * loud[j as usize] * (256.0 / f64::from(p)).powf(RATE)
            })
            .sum();
        assert!(after <= budget, "{after:e}");
        // At the cap nothing more is asked of a receiver.
        assert!(allocate(&row, &loud, &[4096; 3], budget, 4096, &tables).is_empty());
    }

    #[test]
    fn the_blend_keeps_the_filtered_estimate_unless_its_bias_is_large() {
        // A filter that averages 9 like receivers, w_ii = 1/9, no bias: α = 1, error σ²/9.
        let quiet = Blend {
            filtered: 1.0 / 9.0,
            raw: 1.0,
            shared: 1.0 / 9.0,
        };
        let (alpha, mse) = quiet.best();
        assert!((alpha - 1.0).abs() < 1e-12);
        assert!((mse - 1.0 / 9.0).abs() < 1e-12);
        // A bias 4 × the raw variance: the raw estimate takes most of the weight, and the
        // blend beats both.
        let biased = Blend {
            filtered: 4.0 + 1.0 / 9.0,
            raw: 1.0,
            shared: 1.0 / 9.0,
        };
        let (alpha, mse) = biased.best();
        assert!(alpha < 0.25 && mse < 1.0, "{alpha} {mse}");
    }
}
