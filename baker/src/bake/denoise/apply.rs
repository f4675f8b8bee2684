//! Applying a [`Filter`]: each cluster's kernel formed once, its fit's sums read by every
//! member at its own place.

use rayon::prelude::*;

use super::{Filter, clusters, vertices};

impl Filter<'_> {
    /// Member m's place about cluster c's centroid, in c's representative's tangent plane, in
    /// its spacings: (1, u, v).
    pub(super) fn member_place(&self, c: usize, m: usize) -> [f32; 3] {
        let g = self.guides;
        let r = self.clusters.reps[c] as usize;
        let (t1, t2) = self.frames[c];
        let d = (g.points[m] - self.clusters.points[c]) / g.spacing[r];
        [1.0, d.dot(t1), d.dot(t2)]
    }

    /// Receiver i's weights on every receiver, normalised, in the receivers' order: its
    /// cluster's kernel at its place times each cluster's weights on its members.
    pub fn row(&self, i: usize, out: &mut Vec<(u32, f32)>) {
        let c = self.cluster_of[i] as usize;
        let mut scratch = vertices::Scratch::default();
        self.cluster_kernel(c, &mut scratch);
        let place = self.member_place(c, i);
        let terms = vertices::terms(place[1], place[2]);
        out.clear();
        for (n, &(k, e)) in scratch.kernel.iter().enumerate() {
            let w = match self.settings.quadratic {
                true => vertices::dot(&scratch.weights[n], &terms),
                false => e[0] * place[0] + e[1] * place[1] + e[2] * place[2],
            };
            out.extend(
                self.clusters
                    .row(k as usize)
                    .iter()
                    .map(|&(j, m)| (j, w * m)),
            );
        }
        out.sort_unstable_by_key(|&(j, _)| j);
    }

    /// The filtered values: `values` holds `width` floats per receiver, and so does the
    /// result.
    pub fn apply(&self, values: &[f32], width: usize) -> Vec<f32> {
        let mut out = values.to_vec();
        self.apply_in_place(&mut out, width, &mut []);
        out
    }

    /// [`Filter::apply`] of `values` and of `scalars` (one float per receiver, or none)
    /// with the same kernels, in place: each cluster's kernel is formed once, and no
    /// receiver-sized buffer is allocated for the result.
    pub fn apply_in_place(&self, values: &mut [f32], width: usize, scalars: &mut [f32]) {
        let means = self.clusters.means(values, width);
        self.apply_with_means(values, &means, width, scalars);
    }

    /// [`Filter::apply_in_place`] of the very transfer the filter was formed for (`width`
    /// floats per receiver, unchanged since): where that transfer was the filter's signal,
    /// its clusters' means are already at hand, the same floats.
    pub fn apply_to_transfer(&self, transfer: &mut [f32], width: usize, scalars: &mut [f32]) {
        match self.transfer_means.len() == self.clusters.reps.len() * width {
            true => self.apply_with_means(transfer, &self.transfer_means, width, scalars),
            false => self.apply_in_place(transfer, width, scalars),
        }
    }

    /// [`Filter::apply_in_place`] with each cluster's mean of `values` given.
    fn apply_with_means(
        &self,
        values: &mut [f32],
        means: &[f32],
        width: usize,
        scalars: &mut [f32],
    ) {
        if self.settings.quadratic {
            return self.apply_quadratic(values, means, width, scalars);
        }
        let scalar_means = match scalars.is_empty() {
            true => Vec::new(),
            false => self.clusters.means(scalars, 1),
        };
        // Per cluster, the fit's three sums Σ e_k · mean_k for each of (1, u, v), of the
        // values and then of the scalars: a member's value is their dot with its place, so
        // the clusters' means are read once per cluster, not once per member.
        let stride = 3 * (width + 1);
        let mut sums = vec![0.0f32; self.clusters.reps.len() * stride];
        sums.par_chunks_mut(stride).enumerate().for_each_init(
            vertices::Scratch::default,
            |scratch, (c, sums)| {
                self.cluster_kernel(c, scratch);
                let (sums, scalar_sums) = sums.split_at_mut(3 * width);
                for &(k, e) in &scratch.kernel {
                    let k = k as usize;
                    let mean = &means[k * width..(k + 1) * width];
                    for (t, sums) in sums.chunks_exact_mut(width.max(1)).enumerate() {
                        clusters::add_scaled(sums, e[t], mean);
                    }
                    if let Some(s) = scalar_means.get(k) {
                        for t in 0..3 {
                            scalar_sums[t] += e[t] * s;
                        }
                    }
                }
            },
        );
        values
            .par_chunks_mut(width.max(1))
            .enumerate()
            .for_each(|(m, out)| {
                let c = self.cluster_of[m] as usize;
                let [p0, p1, p2] = self.member_place(c, m);
                let sums = &sums[c * stride..][..3 * width];
                let (s0, rest) = sums.split_at(width);
                let (s1, s2) = rest.split_at(width);
                for (o, ((a, b), d)) in out.iter_mut().zip(s0.iter().zip(s1).zip(s2)) {
                    *o = a * p0 + b * p1 + d * p2;
                }
            });
        for (m, out) in scalars.iter_mut().enumerate() {
            let c = self.cluster_of[m] as usize;
            let [p0, p1, p2] = self.member_place(c, m);
            let s = &sums[c * stride + 3 * width..][..3];
            *out = s[0] * p0 + s[1] * p1 + s[2] * p2;
        }
    }
}
