//! Applying a [`Filter`]: each cluster's kernel formed once, its fit's sums read by every
//! member at its own place.

use rayon::prelude::*;

use super::{Filter, clusters, vertices};

/// Clusters per block of [`Filter::apply_with_means`]: one lock per block's values, which
/// stay in a core's cache (about 400 texels' at 64).
const APPLY_BLOCK: usize = 64;

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
        match self.transfer_means && self.signal_width == width {
            true => {
                let means = &self.tap_guide[..self.clusters.reps.len() * width];
                self.apply_with_means(transfer, means, width, scalars)
            }
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
        // the clusters' means are read once per cluster, not once per member. The sums are
        // a thread's own, used up before its next cluster: no buffer of every cluster's
        // (12 MB of fresh pages on the courtyard, which cost more than forming the sums). A
        // block's members' values are formed outside the lock and copied in under it;
        // every receiver is one cluster's member, so the result is the same in any order of
        // blocks.
        let stride = 3 * (width + 1);
        let count = self.clusters.reps.len();
        let out = std::sync::Mutex::new((values, scalars));
        (0..count.div_ceil(APPLY_BLOCK))
            .into_par_iter()
            .for_each_init(
                || (vertices::Scratch::default(), Vec::new(), Vec::new()),
                |(scratch, sums, rows): &mut (_, Vec<f32>, Vec<f32>), b| {
                    let block = b * APPLY_BLOCK..((b + 1) * APPLY_BLOCK).min(count);
                    rows.clear();
                    for c in block.clone() {
                        self.cluster_kernel(c, scratch);
                        sums.clear();
                        sums.resize(stride, 0.0);
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
                        // Each member's values, then its scalar.
                        let (s0, rest) = sums.split_at(width);
                        let (s1, s2) = rest.split_at(width);
                        for &(m, _) in self.clusters.row(c) {
                            let [p0, p1, p2] = self.member_place(c, m as usize);
                            let dot = |(a, (b, d)): (&f32, (&f32, &f32))| a * p0 + b * p1 + d * p2;
                            rows.extend(s0.iter().zip(s1.iter().zip(s2)).map(dot));
                            let s = &scalar_sums[..3];
                            rows.push(s[0] * p0 + s[1] * p1 + s[2] * p2);
                        }
                    }
                    let mut out = out.lock().expect("no block panicked");
                    let (values, scalars) = &mut *out;
                    let members = block.flat_map(|c| self.clusters.row(c));
                    for (&(m, _), row) in members.zip(rows.chunks_exact(width + 1)) {
                        let m = m as usize;
                        values[m * width..][..width].copy_from_slice(&row[..width]);
                        if let Some(s) = scalars.get_mut(m) {
                            *s = row[width];
                        }
                    }
                },
            );
    }
}
