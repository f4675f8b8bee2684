//! Split-and-delete moves for [`crate::math::cpca`]. Sloan's refinement moves a receiver only
//! to a cluster that already reconstructs it better, so it stops in a local optimum, and
//! k-means seeding leaves clusters where the receivers spread far from their mean, not where
//! they spread far from an M-dimensional plane. A move splits one cluster in two along its
//! direction of largest spread and deletes another (its members go to the clusters that
//! reconstruct them best), keeping K, then runs the refinement; it is kept only if the total
//! squared error is then lower than before it, so moves never increase the error. On the
//! demo torus (RGB, 64 × 4) they lower it by a third.
//!
//! The fit keeps every receiver's error in every cluster (V × K values), so the refinement
//! after a move only refits and re-measures the clusters whose members changed: the same
//! result as refitting all of them (an unchanged cluster refits to the same mean and
//! components), at a fraction of the cost; and each cluster's eigenvectors, so the next
//! decomposition of its scatter matrix starts from them (fewer Jacobi sweeps: the demo
//! torus's fit took 11 s instead of 31 s).
//! The model's small pieces (means and components, members, scatter, error) live here too,
//! for [`crate::math::cpca`] to use without the two modules importing each other.

use rayon::prelude::*;

use crate::math::eigen;

/// Consecutive failed moves after which the search stops (on the demo torus, 8 found
/// nothing more than 4).
const FAILURES_IN_A_ROW: usize = 4;
/// The clusters of largest error whose splits are considered.
const SPLIT_CANDIDATES: usize = 16;
/// Two-cluster refinement iterations at most when splitting one cluster.
const SPLIT_ITERATIONS: usize = 8;
/// Refinement iterations at most after a move (a kept move's refinement goes on after the
/// next one; 30 took longer on the demo torus for a similar error, 8.8e-4 against 9.0e-4
/// rms).
const REFINE_ITERATIONS: usize = 8;

/// A partition, its model and every receiver's error in every cluster.
#[derive(Clone)]
pub(crate) struct Fit {
    pub(crate) model: Model,
    pub(crate) assignment: Vec<u32>,
    /// V × K squared reconstruction errors, receiver-major.
    errors: Vec<f64>,
    /// Per cluster, every eigenvector of its last scatter matrix (None before the first
    /// refit): the start of the next decomposition ([`eigen::leading_eigenvectors_from`]).
    frames: Vec<Option<Vec<f64>>>,
    pub(crate) error: f64,
}

impl Fit {
    pub(crate) fn new(data: &[f32], dim: usize, model: Model, assignment: Vec<u32>) -> Fit {
        let k = model.means.len();
        let mut fit = Fit {
            errors: vec![0.0; assignment.len() * k],
            frames: vec![None; k],
            model,
            assignment,
            error: 0.0,
        };
        let all: Vec<usize> = (0..k).collect();
        fit.measure(data, dim, &all);
        fit.error = fit.total();
        fit
    }

    fn set(&mut self, c: usize, (mean, basis, frame): Half) {
        (self.model.means[c], self.model.bases[c], self.frames[c]) = (mean, basis, frame);
    }

    fn clusters(&self) -> usize {
        self.model.means.len()
    }

    /// Re-measures every receiver's error in the clusters `changed`.
    fn measure(&mut self, data: &[f32], dim: usize, changed: &[usize]) {
        let (k, model) = (self.clusters(), &self.model);
        self.errors
            .par_chunks_mut(k)
            .zip(data.par_chunks(dim))
            .for_each_init(
                || vec![0.0f64; dim],
                |centred, (row, x)| {
                    for &c in changed {
                        row[c] =
                            cluster_error(x, &model.means[c], &model.bases[c], centred).max(0.0);
                    }
                },
            );
    }

    fn total(&self) -> f64 {
        let k = self.clusters();
        self.assignment
            .iter()
            .enumerate()
            .map(|(v, &c)| self.errors[v * k + c as usize])
            .sum()
    }

    /// Each receiver's cluster of least error (ties: the lower index).
    fn best(&self, v: usize) -> u32 {
        let k = self.clusters();
        let row = &self.errors[v * k..(v + 1) * k];
        let mut best = (f64::INFINITY, 0u32);
        for (c, &e) in row.iter().enumerate() {
            if e < best.0 {
                best = (e, c as u32);
            }
        }
        best.1
    }

    /// Refits the clusters `changed` to their members (mean and M components) and
    /// re-measures them; an empty cluster keeps its model.
    fn refit(&mut self, data: &[f32], dim: usize, pcs: usize, changed: &[usize]) {
        let groups = members(&self.assignment, self.clusters());
        let fitted: Vec<Option<Half>> = changed
            .par_iter()
            .map(|&c| {
                let g = &groups[c];
                (!g.is_empty()).then(|| half(data, dim, pcs, g, self.frames[c].as_deref()))
            })
            .collect();
        for (&c, f) in changed.iter().zip(fitted) {
            if let Some(h) = f {
                self.set(c, h);
            }
        }
        self.measure(data, dim, changed);
    }

    /// Sloan's refinement: every receiver to its best cluster, the clusters that changed
    /// refitted, until nothing moves, `max` iterations, or an iteration gains less than
    /// `tolerance` of the error. An iteration that would raise the error (rounding only) is
    /// undone. Returns the iterations run.
    pub(crate) fn refine(
        &mut self,
        data: &[f32],
        dim: usize,
        pcs: usize,
        max: usize,
        tolerance: f64,
    ) -> u32 {
        let k = self.clusters();
        let mut iterations = 0;
        for _ in 0..max {
            let next: Vec<u32> = (0..self.assignment.len())
                .into_par_iter()
                .map(|v| self.best(v))
                .collect();
            let mut changed = vec![false; k];
            for (&a, &b) in self.assignment.iter().zip(&next) {
                if a != b {
                    changed[a as usize] = true;
                    changed[b as usize] = true;
                }
            }
            let changed: Vec<usize> = (0..k).filter(|&c| changed[c]).collect();
            if changed.is_empty() {
                break;
            }
            let before = self.clone();
            self.assignment = next;
            self.refit(data, dim, pcs, &changed);
            let error = self.total();
            iterations += 1;
            if error > before.error {
                *self = before;
                break;
            }
            let gain = before.error - error;
            self.error = error;
            if gain <= tolerance * error {
                break;
            }
        }
        iterations
    }
}

/// Split-and-delete moves, each followed by the refinement and kept only if it lowers the
/// total squared error, until [`FAILURES_IN_A_ROW`] fail in a row or `max_tries` were tried.
/// Returns the moves tried and kept.
pub(crate) fn improve(
    data: &[f32],
    dim: usize,
    pcs: usize,
    fit: &mut Fit,
    max_tries: usize,
) -> (usize, usize) {
    let k = fit.clusters();
    if k < 2 || pcs >= dim {
        return (0, 0);
    }
    let mut failed: Vec<(usize, usize)> = Vec::new();
    let mut splits: Vec<Option<Split>> = Vec::new();
    let mut stale = vec![true; k];
    let (mut tries, mut in_a_row, mut kept) = (0, 0, 0);
    while tries < max_tries && in_a_row < FAILURES_IN_A_ROW {
        let groups = members(&fit.assignment, k);
        // Each cluster's error, and the cost of deleting it: its members' errors in their
        // best other cluster, less their errors in it.
        let mut own = vec![0.0f64; k];
        let mut delete_cost = vec![0.0f64; k];
        for (v, &c) in fit.assignment.iter().enumerate() {
            let row = &fit.errors[v * k..(v + 1) * k];
            let c = c as usize;
            let other = row
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != c)
                .map(|(_, &e)| e)
                .fold(f64::INFINITY, f64::min);
            own[c] += row[c];
            delete_cost[c] += other - row[c];
        }
        // Splits of the clusters of largest error (a split's gain is at most the cluster's
        // error), computed again only when their members have changed.
        let mut worst: Vec<usize> = (0..k).collect();
        worst.sort_by(|&a, &b| own[b].total_cmp(&own[a]).then(a.cmp(&b)));
        worst.truncate(SPLIT_CANDIDATES);
        let fresh: Vec<(usize, Option<Split>)> = worst
            .par_iter()
            .filter(|&&c| stale[c])
            .map(|&c| {
                (
                    c,
                    split(data, dim, pcs, &groups[c], fit.frames[c].as_deref()),
                )
            })
            .collect();
        splits.resize_with(k, || None);
        for (c, s) in fresh {
            splits[c] = s;
            stale[c] = false;
        }
        // The most promising untried move: a split's gain less the cheapest deletion's cost.
        let mut cheapest: Vec<usize> = (0..k).collect();
        cheapest.sort_by(|&a, &b| delete_cost[a].total_cmp(&delete_cost[b]).then(a.cmp(&b)));
        let best = worst
            .iter()
            .filter_map(|&s| {
                let sp = splits[s].as_ref()?;
                let d = *cheapest
                    .iter()
                    .find(|&&d| d != s && !failed.contains(&(s, d)))?;
                Some((own[s] - sp.error - delete_cost[d], s, d))
            })
            .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
        let Some((_, s, d)) = best else { break };
        let sp = splits[s].as_ref().expect("a split was chosen");
        let mut next = fit.clone();
        next.set(s, sp.halves[0].clone());
        next.set(d, sp.halves[1].clone());
        for (&v, &second) in groups[s].iter().zip(&sp.second) {
            next.assignment[v] = if second { d as u32 } else { s as u32 };
        }
        next.measure(data, dim, &[s, d]);
        for &v in &groups[d] {
            next.assignment[v] = next.best(v);
        }
        next.error = next.total();
        next.refine(data, dim, pcs, REFINE_ITERATIONS, 0.0);
        tries += 1;
        if next.error < fit.error {
            for (&a, &b) in fit.assignment.iter().zip(&next.assignment) {
                if a != b {
                    stale[a as usize] = true;
                    stale[b as usize] = true;
                }
            }
            stale[s] = true;
            stale[d] = true;
            *fit = next;
            failed.clear();
            in_a_row = 0;
            kept += 1;
        } else {
            failed.push((s, d));
            in_a_row += 1;
        }
    }
    (tries, kept)
}

/// One cluster split in two: each half's mean and components, which half each member went to
/// (in member order, `true` for the second), and the halves' total squared error.
struct Split {
    halves: [Half; 2],
    second: Vec<bool>,
    error: f64,
}

/// Splits the members of one cluster in two: by the side of the mean they lie on along the
/// cluster's first principal component (its direction of largest spread; splitting across
/// the (M+1)-th, the direction of most remaining error, lowered the torus's error half as
/// much), then two-cluster refinement. None for fewer than two members or when one half
/// would be empty.
fn split(
    data: &[f32],
    dim: usize,
    pcs: usize,
    group: &[usize],
    frame: Option<&[f64]>,
) -> Option<Split> {
    if group.len() < 2 {
        return None;
    }
    let (mean, mut axis, frame) = half(data, dim, 1, group, frame);
    split_along(data, dim, pcs, group, &mean, &axis.pop()?, frame.as_deref())
}

/// A cluster's mean, M components and every eigenvector of its scatter matrix (None where
/// the transfer is too long for Jacobi), the decomposition started from `start`.
type Half = (Vec<f64>, Vec<Vec<f64>>, Option<Vec<f64>>);

/// The mean and `pcs` principal components of `group` (not empty).
fn half(data: &[f32], dim: usize, pcs: usize, group: &[usize], start: Option<&[f64]>) -> Half {
    let mean = mean_of(data, dim, group);
    if pcs == 0 {
        return (mean, Vec::new(), None);
    }
    let scatter = scatter(data, dim, group, &mean);
    match eigen::leading_eigenvectors_from(&scatter, dim, pcs, start) {
        Some((basis, frame)) => (mean, basis, Some(frame)),
        None => (mean, eigen::leading_eigenvectors(&scatter, dim, pcs), None),
    }
}

fn split_along(
    data: &[f32],
    dim: usize,
    pcs: usize,
    group: &[usize],
    mean: &[f64],
    axis: &[f64],
    frame: Option<&[f64]>,
) -> Option<Split> {
    let x = |v: usize| &data[v * dim..(v + 1) * dim];
    let mut second: Vec<bool> = group
        .iter()
        .map(|&v| {
            x(v).iter()
                .zip(mean)
                .zip(axis)
                .map(|((&a, m), b)| (f64::from(a) - m) * b)
                .sum::<f64>()
                > 0.0
        })
        .collect();
    let mut result = None;
    let mut centred = vec![0.0f64; dim];
    for _ in 0..SPLIT_ITERATIONS {
        let side_of = |side: bool| -> Vec<usize> {
            group
                .iter()
                .zip(&second)
                .filter(|&(_, &s)| s == side)
                .map(|(&v, _)| v)
                .collect()
        };
        let (first, other) = (side_of(false), side_of(true));
        if first.is_empty() || other.is_empty() {
            break;
        }
        let halves = [&first, &other].map(|h| half(data, dim, pcs, h, frame));
        let mut error = 0.0;
        let next: Vec<bool> = group
            .iter()
            .map(|&v| {
                let [e0, e1] = [&halves[0], &halves[1]]
                    .map(|(m, b, _)| cluster_error(x(v), m, b, &mut centred).max(0.0));
                error += e0.min(e1);
                e1 < e0
            })
            .collect();
        let changed = next != second;
        second = next.clone();
        result = Some(Split {
            halves,
            second: next,
            error,
        });
        if !changed {
            break;
        }
    }
    result
}

pub(crate) fn mean_of(data: &[f32], dim: usize, group: &[usize]) -> Vec<f64> {
    let mut sum = vec![0.0f64; dim];
    for &v in group {
        for (s, &a) in sum.iter_mut().zip(&data[v * dim..(v + 1) * dim]) {
            *s += f64::from(a);
        }
    }
    let n = group.len().max(1) as f64;
    sum.into_iter().map(|s| s / n).collect()
}

/// Means and components of every cluster, f64 while fitting.
#[derive(Clone)]
pub(crate) struct Model {
    pub(crate) means: Vec<Vec<f64>>,
    /// Per cluster, M components of D floats.
    pub(crate) bases: Vec<Vec<Vec<f64>>>,
}

/// Members of each of `clusters` clusters, in receiver order.
pub(crate) fn members(assignment: &[u32], clusters: usize) -> Vec<Vec<usize>> {
    let mut members = vec![Vec::new(); clusters];
    for (v, &k) in assignment.iter().enumerate() {
        members[k as usize].push(v);
    }
    members
}

/// The members' scatter matrix about `mean`, D × D row-major.
pub(crate) fn scatter(data: &[f32], dim: usize, members: &[usize], mean: &[f64]) -> Vec<f64> {
    let mut scatter = vec![0.0f64; dim * dim];
    let mut centred = vec![0.0f64; dim];
    for &v in members {
        for (c, (&x, &m)) in centred
            .iter_mut()
            .zip(data[v * dim..(v + 1) * dim].iter().zip(mean))
        {
            *c = f64::from(x) - m;
        }
        for p in 0..dim {
            let cp = centred[p];
            if cp == 0.0 {
                continue;
            }
            let row = &mut scatter[p * dim..(p + 1) * dim];
            for q in p..dim {
                row[q] += cp * centred[q];
            }
        }
    }
    for p in 0..dim {
        for q in 0..p {
            scatter[p * dim + q] = scatter[q * dim + p];
        }
    }
    scatter
}

/// Squared reconstruction error of `x` by cluster k's mean and components.
pub(crate) fn cluster_error(
    x: &[f32],
    mean: &[f64],
    basis: &[Vec<f64>],
    centred: &mut [f64],
) -> f64 {
    for (c, (&a, &m)) in centred.iter_mut().zip(x.iter().zip(mean)) {
        *c = f64::from(a) - m;
    }
    let mut e = dot(centred, centred);
    for b in basis {
        let w = dot(b, centred);
        e -= w * w;
    }
    e
}

/// a·b summed in four interleaved lanes, which the compiler vectorises (a single running sum
/// cannot be reordered, and this is most of the fit's time); deterministic all the same.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut lanes = [0.0f64; 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let mut sum: f64 = a4
        .remainder()
        .iter()
        .zip(b4.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in a4.zip(b4) {
        for l in 0..4 {
            lanes[l] += x[l] * y[l];
        }
    }
    sum += (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    sum
}
