//! The filter's coarse level: receivers joined into small clusters of like neighbours on one
//! surface, each standing for its members in the wide pass ([`super::Filter`]), as an
//! à-trous pass reads a coarser level (Dammertz et al. 2010; Schied et al. 2017). The wide
//! pass then forms one kernel per cluster over a few dozen clusters instead of one per
//! receiver over a hundred receivers, and every receiver still counts, once, through its
//! cluster's mean.

use super::grid::Grid;
use super::guides::Guides;

/// Clusters of receivers: singletons in receiver order, or built clusters cell by cell, the
/// cells in the order of their first receiver ([`Grid::cells_by_first`]).
pub struct Clusters {
    /// Each cluster's representative, the member nearest the members' centroid: its point,
    /// normals and plane stand for the cluster.
    pub reps: Vec<u32>,
    /// Cluster k's members and their normalised weights: `members[starts[k]..starts[k + 1]]`.
    pub starts: Vec<u32>,
    pub members: Vec<(u32, f32)>,
    /// How many receivers each cluster stands for: the sum of its members' weights before
    /// normalising.
    pub mass: Vec<f32>,
    /// The variance of each cluster's mean, Σ w² σ² over its members.
    pub noise: Vec<f32>,
    /// Each cluster's weighted centroid: where its mean lies.
    pub points: Vec<glam::Vec3>,
}

/// Whether receiver m may join seed's cluster by the geometry alone: within `reach` of it,
/// the same group (object and material), normals within 25°, and on its plane.
pub(super) fn on_one_surface(g: &Guides, seed: usize, m: usize, reach: f32) -> bool {
    let d = g.points[m] - g.points[seed];
    g.groups[seed] == g.groups[m]
        && g.normals[seed].dot(g.normals[m]) > 0.9
        && g.surfaces[seed].dot(g.surfaces[m]) > 0.9
        && g.surfaces[seed].dot(d).abs() < 0.5 * g.spacing[seed]
        && d.length_squared() <= reach * reach
}

impl Clusters {
    /// No clusters yet, room for `receivers` members.
    pub(super) fn empty(receivers: usize) -> Clusters {
        Clusters {
            reps: Vec::new(),
            starts: vec![0],
            members: Vec::with_capacity(receivers),
            mass: Vec::new(),
            noise: Vec::new(),
            points: Vec::new(),
        }
    }

    /// Every receiver its own cluster: the wide pass reads the raw values.
    pub fn singletons(noise: &[f32]) -> Clusters {
        let count = noise.len() as u32;
        Clusters {
            reps: (0..count).collect(),
            starts: (0..=count).collect(),
            members: (0..count).map(|i| (i, 1.0)).collect(),
            mass: vec![1.0; noise.len()],
            noise: noise.to_vec(),
            points: Vec::new(),
        }
    }

    /// Clusters of at most `step` spacings across, within the cells of `grid` (cells about
    /// `step` typical spacings wide): in each cell, receivers in index order join the first
    /// cluster whose first member they may share a kernel with (the same group, normals
    /// within 25°, on its plane, within `step` of its spacings, and `similar`: raw signals
    /// apart by about their noise), or start one. Members weigh the same. A function of the
    /// guides and the signal alone, in a fixed order (cells by their first receiver): the
    /// same on any thread.
    ///
    /// Returns the clusters and their means of `signal` (`width` floats per receiver), the
    /// very sums of [`Clusters::means`], formed while the cell's signal is still in cache:
    /// a second pass would gather it again from all over the receivers.
    pub fn build(
        guides: &Guides,
        grid: &Grid,
        step: f32,
        noise: &[f32],
        (signal, width): (&[f32], usize),
        similar: impl Fn(usize, usize) -> bool,
    ) -> (Clusters, Vec<f32>) {
        let g = guides;
        let joins = |seed: usize, m: usize| {
            on_one_surface(g, seed, m, step * g.spacing[seed]) && similar(seed, m)
        };
        let mut clusters = Clusters::empty(g.points.len());
        // At most one cluster per receiver: room reserved, not touched, so never moved.
        let mut means = Vec::with_capacity(g.points.len() * width);
        let (mut seeds, mut label) = (Vec::<usize>::new(), Vec::<usize>::new());
        for cell in grid.cells_by_first() {
            seeds.clear();
            label.clear();
            for &m in cell {
                let m = m as usize;
                let k = match seeds.iter().position(|&s| joins(s, m)) {
                    Some(k) => k,
                    None => {
                        seeds.push(m);
                        seeds.len() - 1
                    }
                };
                label.push(k);
            }
            // Each seed's cluster, written straight into the flat arrays: no allocation
            // per cluster.
            for k in 0..seeds.len() {
                let mine = || cell.iter().zip(&label).filter(move |(_, l)| **l == k);
                let (sum, n) = mine().fold((glam::Vec3::ZERO, 0.0f32), |(s, n), (&m, _)| {
                    (s + g.points[m as usize], n + 1.0)
                });
                let centre = sum / n;
                let mut rep = u32::MAX;
                let mut best = f32::INFINITY;
                let mut var = 0.0f32;
                let mut at = glam::Vec3::ZERO;
                let w = 1.0 / n;
                let mean = means.len();
                means.resize(mean + width, 0.0);
                for (&m, _) in mine() {
                    add_scaled(
                        &mut means[mean..],
                        w,
                        &signal[m as usize * width..][..width],
                    );
                    let p = g.points[m as usize];
                    let d = p.distance_squared(centre);
                    if d < best {
                        (best, rep) = (d, m);
                    }
                    var += w * w * noise[m as usize];
                    at += w * p;
                    clusters.members.push((m, w));
                }
                clusters.points.push(at);
                clusters.reps.push(rep);
                clusters.starts.push(clusters.members.len() as u32);
                clusters.mass.push(n);
                clusters.noise.push(var);
            }
        }
        (clusters, means)
    }

    /// Cluster k's members and their weights.
    pub fn row(&self, k: usize) -> &[(u32, f32)] {
        &self.members[self.starts[k] as usize..self.starts[k + 1] as usize]
    }

    /// Each cluster's weighted mean of `values` (`width` floats per receiver).
    pub fn means(&self, values: &[f32], width: usize) -> Vec<f32> {
        let mut out = vec![0.0f32; self.reps.len() * width];
        for (k, out) in out.chunks_mut(width.max(1)).enumerate() {
            for &(j, w) in self.row(k) {
                add_scaled(out, w, &values[j as usize * width..][..width]);
            }
        }
        out
    }
}

/// o += s x, elementwise, four at a time in a vector register (glam's `Vec4`): a loop
/// of unknown length, a receiver's 27 floats, is otherwise left mostly to scalar
/// arithmetic. The same products and sums as one at a time, bit for bit.
pub fn add_scaled(o: &mut [f32], s: f32, x: &[f32]) {
    debug_assert_eq!(o.len(), x.len());
    let (mut o4, x4) = (o.chunks_exact_mut(4), x.chunks_exact(4));
    for (o, x) in o4.by_ref().zip(x4.clone()) {
        (glam::Vec4::from_slice(o) + s * glam::Vec4::from_slice(x)).write_to_slice(o);
    }
    for (o, x) in o4.into_remainder().iter_mut().zip(x4.remainder()) {
        *o += s * x;
    }
}
