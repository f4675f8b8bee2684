//! Clustered principal component analysis (CPCA) of transfer vectors, after Sloan, Hall, Hart
//! & Snyder 2003, "Clustered Principal Components for Precomputed Radiance Transfer".
//!
//! Each receiver's transfer vector x (all of its channels × n² coefficients concatenated: one
//! RGB vector, so a receiver stores one cluster index and M weights whatever its channel
//! count) is approximated as `x ≈ μ_k + Σ_i w_i · b_ki`: the mean of its cluster k plus M
//! weights on that cluster's first M principal components. The fit is deterministic:
//! k-means++ seeding from a fixed seed, Lloyd iterations, per-cluster PCA (the leading
//! eigenvectors of the scatter matrix, [`crate::math::eigen`]), then Sloan's
//! refinement: each receiver moves to the cluster whose mean and PCs reconstruct it with the
//! least error, and means and PCs are recomputed, which never increases the total error;
//! last, split-and-delete moves (`math::cpca_moves`) take it out of the refinement's
//! local optimum, again never increasing the error. The whole fit runs from [`STARTS`]
//! k-means++ seedings and keeps the one of least total error: with 64 clusters the result
//! depends on the seeding by ±10 % (RMS error), and the relit error follows it.
//! [`crate::formats::cpca_block`] stores the result in a version-2 `.prt` file.

use rayon::prelude::*;

use crate::math::cpca_moves::{self, Fit, Model, mean_of, members, scatter};
use crate::math::eigen;
use crate::support::error::{Error, Result};

/// The seed of the first k-means++ seeding: fixed, so the same input gives the same file.
/// Start s seeds with `SEED ^ s`.
pub const SEED: u64 = 0x5107_2003_c9ca_0001;
/// Fits from different seedings, the best kept. On the demo torus (RGB interreflected,
/// 64 × 4, 12 seedings) the coefficient RMS error ranged 8.2–9.8e-4 and the relit error
/// averaged over suns in the upper hemisphere followed it in rank (0.95–1.12 %); the best of
/// four was 6 % below the first seeding's.
pub const STARTS: usize = 4;
/// Lloyd iterations at most (they stop earlier when no receiver changes cluster).
const LLOYD_ITERATIONS: usize = 30;
/// Sloan 2003's CPCA refinement iterations at most: it stops earlier at a fixed point or once
/// an iteration lowers the total squared error by less than [`CPCA_TOLERANCE`] of it (on the
/// demo scenes 8 iterations were still gaining a few per cent each).
const CPCA_ITERATIONS: usize = 30;
const CPCA_TOLERANCE: f64 = 1e-3;
/// Split-and-delete moves tried at most per cluster ([`cpca_moves`]); they stop earlier,
/// once several in a row fail (the demo torus, RGB, 64 × 4: 26 tried, 20 kept).
const MOVES_PER_CLUSTER: usize = 4;

/// A clustered-PCA approximation of V vectors of `dim` floats.
#[derive(Clone, Debug, PartialEq)]
pub struct Cpca {
    /// D: floats per receiver (channels × n²).
    pub dim: usize,
    /// M: principal components per cluster.
    pub pcs: usize,
    /// K × D cluster means.
    pub means: Vec<f32>,
    /// K × M × D: cluster k's i-th component at `(k·M + i)·D`. Orthonormal where the cluster
    /// has that many directions of spread; zero rows are allowed (they carry no weight).
    pub bases: Vec<f32>,
    /// V cluster indices, each below K.
    pub cluster: Vec<u32>,
    /// V × M weights: receiver v's projections on its cluster's components.
    pub weights: Vec<f32>,
    /// Refinement iterations the fit ran before the moves, plus the moves kept (recorded in
    /// the file, for information).
    pub iterations: u32,
    /// The seed of the k-means++ seeding the kept fit started from (recorded in the file).
    pub seed: u64,
}

impl Cpca {
    pub fn clusters(&self) -> usize {
        self.means.len().checked_div(self.dim).unwrap_or(0)
    }

    pub fn receivers(&self) -> usize {
        self.cluster.len()
    }

    /// Receiver v's reconstructed vector, into `out` (D floats).
    pub fn reconstruct_into(&self, v: usize, out: &mut [f32]) {
        let (d, m) = (self.dim, self.pcs);
        let k = self.cluster[v] as usize;
        let mut acc: Vec<f64> = self.means[k * d..(k + 1) * d]
            .iter()
            .map(|&x| f64::from(x))
            .collect();
        for i in 0..m {
            let w = f64::from(self.weights[v * m + i]);
            if w == 0.0 {
                continue; // so a mean of −0 stays −0: K = V is bit-exact
            }
            let b = &self.bases[(k * m + i) * d..(k * m + i + 1) * d];
            for (a, &x) in acc.iter_mut().zip(b) {
                *a += w * f64::from(x);
            }
        }
        for (o, a) in out.iter_mut().zip(acc) {
            *o = a as f32;
        }
    }

    /// All receivers' reconstructed vectors, V × D.
    pub fn reconstruct(&self) -> Vec<f32> {
        let d = self.dim;
        let mut out = vec![0.0f32; self.receivers() * d];
        out.par_chunks_mut(d.max(1))
            .enumerate()
            .for_each(|(v, chunk)| {
                if d > 0 {
                    self.reconstruct_into(v, chunk)
                }
            });
        out
    }

    /// Floats stored per receiver, the cluster data shared out: M weights and the index (one
    /// 4-byte value) each, plus K·(M + 1)·D for the means and bases over V receivers.
    pub fn floats_per_vertex(&self) -> f64 {
        let v = self.receivers().max(1) as f64;
        let shared = (self.clusters() * (self.pcs + 1) * self.dim) as f64;
        (self.pcs + 1) as f64 + shared / v
    }
}

/// RMS difference of two equally long arrays (0 for empty ones).
pub fn rms_error(a: &[f32], b: &[f32]) -> f64 {
    if a.is_empty() {
        return 0.0;
    }
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
        .sum();
    (sum / a.len() as f64).sqrt()
}

/// Clustered PCA of `data` (V × `dim` floats, receiver-major) with at most `clusters`
/// clusters and `pcs` components each. With K ≥ V every receiver is its own cluster's mean:
/// exact. Clusters that end up empty are dropped, so the result may hold fewer than K.
pub fn compress(data: &[f32], dim: usize, clusters: usize, pcs: usize) -> Result<Cpca> {
    compress_from(data, dim, clusters, pcs, STARTS)
}

/// [`compress`] from `starts` seedings (at least one) instead of [`STARTS`]: the time is
/// linear in them.
pub fn compress_from(
    data: &[f32],
    dim: usize,
    clusters: usize,
    pcs: usize,
    starts: usize,
) -> Result<Cpca> {
    compress_with(
        data,
        dim,
        clusters,
        pcs,
        MOVES_PER_CLUSTER * clusters,
        starts,
    )
}

/// [`compress`] trying at most `max_moves` split-and-delete moves (0: Sloan's refinement
/// alone, as the tests compare) from each of `starts` seedings.
fn compress_with(
    data: &[f32],
    dim: usize,
    clusters: usize,
    pcs: usize,
    max_moves: usize,
    starts: usize,
) -> Result<Cpca> {
    if clusters == 0 {
        return Err(Error::InvalidOption("--clusters must be at least 1".into()));
    }
    if dim == 0 || data.len() % dim != 0 {
        return Err(Error::InvalidOption(format!(
            "{} floats are not whole vectors of {dim}",
            data.len()
        )));
    }
    if pcs > dim {
        return Err(Error::InvalidOption(format!(
            "--pcs {pcs} is more than the {dim} floats of a receiver's transfer"
        )));
    }
    let v = data.len() / dim;
    if v == 0 {
        return Err(Error::InvalidOption("no receivers to compress".into()));
    }
    if clusters >= v {
        // Every receiver its own cluster: the means are the data, exactly.
        return Ok(Cpca {
            dim,
            pcs,
            means: data.to_vec(),
            bases: vec![0.0; v * pcs * dim],
            cluster: (0..v as u32).collect(),
            weights: vec![0.0; v * pcs],
            iterations: 0,
            seed: SEED,
        });
    }
    // Each start's fit; the first of least error is kept (so one start is the old fit). Only
    // its model and partition are kept, not its V × K errors: one start's memory at a time.
    let mut best: Option<(f64, Model, Vec<u32>, u32, u64)> = None;
    for start in 0..starts.max(1) {
        let seed = SEED ^ start as u64;
        let (fit, iterations) = fit_from(data, dim, clusters, pcs, max_moves, seed);
        if best.as_ref().is_none_or(|b| fit.error < b.0) {
            best = Some((fit.error, fit.model, fit.assignment, iterations, seed));
        }
    }
    let (_, model, assignment, iterations, seed) = best.expect("at least one start");
    Ok(finish(data, dim, pcs, model, &assignment, iterations, seed))
}

/// One fit from the k-means++ seeding of `seed`: the fit and its refinement iterations plus
/// the moves kept.
fn fit_from(
    data: &[f32],
    dim: usize,
    clusters: usize,
    pcs: usize,
    max_moves: usize,
    seed: u64,
) -> (Fit, u32) {
    let v = data.len() / dim;
    let x = |i: usize| &data[i * dim..(i + 1) * dim];

    // k-means++ seeding.
    let mut rng = SplitMix64(seed);
    let mut centres: Vec<Vec<f64>> = vec![to_f64(x((rng.next() % v as u64) as usize))];
    let mut d2: Vec<f64> = (0..v)
        .into_par_iter()
        .map(|i| dist2(x(i), &centres[0]))
        .collect();
    while centres.len() < clusters {
        let total: f64 = d2.iter().sum();
        if total <= 0.0 {
            break; // fewer distinct vectors than clusters
        }
        let target = rng.unit() * total;
        let mut acc = 0.0;
        let mut pick = None;
        for (i, &d) in d2.iter().enumerate() {
            acc += d;
            if d > 0.0 {
                pick = Some(i);
                if acc > target {
                    break;
                }
            }
        }
        let Some(pick) = pick else { break };
        let centre = to_f64(x(pick));
        d2.par_iter_mut().enumerate().for_each(|(i, d)| {
            *d = d.min(dist2(x(i), &centre));
        });
        centres.push(centre);
    }

    // Lloyd iterations.
    let mut assignment = nearest(data, dim, &centres);
    for _ in 0..LLOYD_ITERATIONS {
        centres = cluster_means(data, dim, &assignment, &centres);
        let next = nearest(data, dim, &centres);
        let changed = next != assignment;
        assignment = next;
        if !changed {
            break;
        }
    }

    // PCA per cluster, then Sloan's refinement: reassign by reconstruction error, refit;
    // then split-and-delete moves out of its local optimum.
    let model = fit(data, dim, pcs, &assignment, &centres);
    let mut state = Fit::new(data, dim, model, assignment);
    let iterations = state.refine(data, dim, pcs, CPCA_ITERATIONS, CPCA_TOLERANCE);
    let (_, moves) = cpca_moves::improve(data, dim, pcs, &mut state, max_moves);
    (state, iterations + moves as u32)
}

fn to_f64(x: &[f32]) -> Vec<f64> {
    x.iter().map(|&a| f64::from(a)).collect()
}

fn dist2(a: &[f32], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| (f64::from(x) - y).powi(2))
        .sum()
}

/// Each receiver's nearest centre (ties: the lower index).
fn nearest(data: &[f32], dim: usize, centres: &[Vec<f64>]) -> Vec<u32> {
    data.par_chunks(dim)
        .map(|x| {
            let mut best = (f64::INFINITY, 0u32);
            for (k, c) in centres.iter().enumerate() {
                let d = dist2(x, c);
                if d < best.0 {
                    best = (d, k as u32);
                }
            }
            best.1
        })
        .collect()
}

/// The mean of each cluster's members; an empty cluster keeps `previous`.
fn cluster_means(
    data: &[f32],
    dim: usize,
    assignment: &[u32],
    previous: &[Vec<f64>],
) -> Vec<Vec<f64>> {
    members(assignment, previous.len())
        .iter()
        .zip(previous)
        .map(|(group, old)| match group.is_empty() {
            true => old.clone(),
            false => mean_of(data, dim, group),
        })
        .collect()
}

/// Each cluster's first M principal components about `means`.
fn fit(data: &[f32], dim: usize, pcs: usize, assignment: &[u32], means: &[Vec<f64>]) -> Model {
    let members = members(assignment, means.len());
    let bases = members
        .par_iter()
        .zip(means)
        .map(|(members, mean)| principal_components(data, dim, pcs, members, mean))
        .collect();
    Model {
        means: means.to_vec(),
        bases,
    }
}

/// The M eigenvectors of largest eigenvalue of the members' scatter matrix about `mean`.
/// A cluster with fewer than M + 1 members spreads in fewer than M directions: the rest are
/// eigenvectors of eigenvalue 0, harmless (its members' weights on them are 0).
fn principal_components(
    data: &[f32],
    dim: usize,
    pcs: usize,
    members: &[usize],
    mean: &[f64],
) -> Vec<Vec<f64>> {
    if pcs == 0 || members.is_empty() {
        return vec![vec![0.0; dim]; pcs];
    }
    eigen::leading_eigenvectors(&scatter(data, dim, members, mean), dim, pcs)
}

/// The stored form: empty clusters dropped, f32 values, weights projected in f64.
fn finish(
    data: &[f32],
    dim: usize,
    pcs: usize,
    model: Model,
    assignment: &[u32],
    iterations: u32,
    seed: u64,
) -> Cpca {
    let members = members(assignment, model.means.len());
    let mut renumber = vec![u32::MAX; model.means.len()];
    let mut means = Vec::new();
    let mut bases = Vec::new();
    for (k, m) in members.iter().enumerate() {
        if m.is_empty() {
            continue;
        }
        renumber[k] = (means.len() / dim) as u32;
        means.extend(model.means[k].iter().map(|&x| x as f32));
        for b in &model.bases[k] {
            bases.extend(b.iter().map(|&x| x as f32));
        }
    }
    let weights: Vec<f32> = data
        .par_chunks(dim)
        .zip(assignment)
        .flat_map_iter(|(x, &k)| {
            let k = k as usize;
            let centred: Vec<f64> = x
                .iter()
                .zip(&model.means[k])
                .map(|(&a, &m)| f64::from(a) - m)
                .collect();
            model.bases[k]
                .iter()
                .map(move |b| b.iter().zip(&centred).map(|(b, c)| b * c).sum::<f64>() as f32)
                .collect::<Vec<_>>()
        })
        .collect();
    Cpca {
        dim,
        pcs,
        means,
        bases,
        cluster: assignment.iter().map(|&k| renumber[k as usize]).collect(),
        weights,
        iterations,
        seed,
    }
}

/// A deterministic 64-bit generator (Steele, Lea & Flood's SplitMix64): enough for seeding,
/// and no dependency.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// V pseudo-random vectors of `dim` floats with a few dominant directions, as transfer
    /// vectors have.
    fn data(v: usize, dim: usize) -> Vec<f32> {
        let mut rng = SplitMix64(7);
        let dirs: Vec<Vec<f64>> = (0..6)
            .map(|_| (0..dim).map(|_| rng.unit() - 0.5).collect())
            .collect();
        (0..v)
            .flat_map(|_| {
                let w: Vec<f64> = (0..6)
                    .map(|j| (rng.unit() - 0.5) / (1 + j) as f64)
                    .collect();
                let noise: Vec<f64> = (0..dim).map(|_| 0.01 * (rng.unit() - 0.5)).collect();
                (0..dim)
                    .map(|i| (noise[i] + (0..6).map(|j| w[j] * dirs[j][i]).sum::<f64>()) as f32)
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    #[test]
    fn as_many_clusters_as_receivers_is_exact() {
        let x = data(50, 16);
        for k in [50, 80] {
            let c = compress(&x, 16, k, 2).unwrap();
            assert_eq!(c.clusters(), 50);
            assert_eq!(c.reconstruct(), x);
        }
    }

    #[test]
    fn clusters_smaller_than_the_components_are_exact() {
        // Four far-apart groups of three: each spans a plane about its mean, so two components
        // (or five, more than the group has directions) reconstruct it exactly.
        let mut x = Vec::new();
        for g in 0..4 {
            for i in 0..3 {
                x.extend((0..8).map(|j| (100 * g) as f32 + ((i * 7 + j * 3) % 5) as f32));
            }
        }
        for m in [2, 5] {
            let c = compress(&x, 8, 4, m).unwrap();
            assert_eq!(c.clusters(), 4);
            assert!(rms_error(&x, &c.reconstruct()) < 1e-4, "M = {m}");
        }
    }

    #[test]
    fn error_falls_with_clusters_and_components() {
        let x = data(2000, 16);
        let error = |k, m| rms_error(&x, &compress(&x, 16, k, m).unwrap().reconstruct());
        let by_k: Vec<f64> = [1, 4, 16, 64].map(|k| error(k, 2)).to_vec();
        let by_m: Vec<f64> = [0, 1, 2, 4].map(|m| error(8, m)).to_vec();
        for w in by_k.windows(2).chain(by_m.windows(2)) {
            assert!(w[1] < w[0], "{by_k:?} {by_m:?}");
        }
        // Six directions and 1 % noise: six components leave only the noise.
        assert!(error(1, 6) < 0.01, "{}", error(1, 6));
    }

    #[test]
    fn deterministic_and_refinement_does_not_hurt() {
        let x = data(1500, 16);
        let a = compress(&x, 16, 32, 3).unwrap();
        assert_eq!(a, compress(&x, 16, 32, 3).unwrap());
        assert!(a.cluster.iter().all(|&k| (k as usize) < a.clusters()));
        assert_eq!(a.weights.len(), 1500 * 3);
    }

    /// A straight segment, which k-means cuts into several clusters though any one of their
    /// lines reconstructs all of it, beside a circle, which needs many lines.
    fn segment_and_circle() -> Vec<f32> {
        let mut x = Vec::new();
        for i in 0..400 {
            x.extend([i as f32 / 10.0 - 20.0, 0.0, 0.0]);
        }
        for i in 0..400 {
            let a = i as f32 / 400.0 * std::f32::consts::TAU;
            x.extend([0.0, 10.0 + a.cos(), a.sin()]);
        }
        x
    }

    #[test]
    fn moves_beat_the_refinement_alone() {
        // The refinement keeps the segment's spare clusters (they reconstruct it exactly); the
        // moves split the circle's clusters and delete the spares.
        let x = segment_and_circle();
        let error = |moves| {
            rms_error(
                &x,
                &compress_with(&x, 3, 6, 1, moves, 1).unwrap().reconstruct(),
            )
        };
        let (plain, moved) = (error(0), error(100));
        assert!(
            moved < 0.5 * plain,
            "refinement alone {plain}, with moves {moved}"
        );
    }

    #[test]
    fn moves_never_increase_the_error() {
        // The same moves are tried in the same order whatever the budget, so each budget's
        // result is the previous one's after one more move, kept or not.
        for (x, dim, k, m) in [
            (data(1500, 16), 16, 16, 2),
            (data(800, 16), 16, 8, 1),
            (segment_and_circle(), 3, 6, 1),
        ] {
            let mut previous = f64::INFINITY;
            for moves in 0..10 {
                let e = rms_error(
                    &x,
                    &compress_with(&x, dim, k, m, moves, 1)
                        .unwrap()
                        .reconstruct(),
                );
                assert!(
                    e <= previous * (1.0 + 1e-5),
                    "{moves} moves: {e} > {previous}"
                );
                previous = e;
            }
        }
    }

    #[test]
    fn the_best_of_several_starts_is_kept() {
        // Each start is the fit of one seeding; the kept one has the least error of all,
        // and the file records its seed.
        let x = data(1500, 16);
        let error = |fit: &Cpca| rms_error(&x, &fit.reconstruct());
        let single: Vec<f64> = (0..4)
            .map(|s| {
                let fit = fit_from(&x, 16, 16, 2, 0, SEED ^ s);
                let cpca = finish(&x, 16, 2, fit.0.model, &fit.0.assignment, 0, 0);
                error(&cpca)
            })
            .collect();
        let best = compress_with(&x, 16, 16, 2, 0, 4).unwrap();
        let least = single.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(
            (error(&best) - least).abs() <= 1e-9 * least,
            "kept {}, starts {single:?}",
            error(&best)
        );
        assert!(error(&best) < single[0], "starts {single:?}");
        let winner = single.iter().position(|&e| e == least).unwrap() as u64;
        assert_eq!(best.seed, SEED ^ winner);
    }

    #[test]
    fn identical_receivers_drop_empty_clusters() {
        let x = vec![0.5f32; 16 * 30];
        let c = compress(&x, 16, 8, 2).unwrap();
        assert_eq!(c.clusters(), 1);
        assert_eq!(c.reconstruct(), x);
    }
}
