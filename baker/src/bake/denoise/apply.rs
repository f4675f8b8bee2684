//! Applying a [`Filter`]: each cluster's kernel formed once, its fit's sums read by every
//! member at its own place.

use rayon::prelude::*;

use super::{Filter, clusters, normal_fit, vertices};

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

    /// Member m's shading normal less its cluster c's representative's, in c's frame: where
    /// the cluster's fit is in the normal too, its last two regressors
    /// ([`super::normal_fit`]).
    pub(super) fn member_normal(&self, c: usize, m: usize) -> [f32; 2] {
        let g = self.guides;
        let r = self.clusters.reps[c] as usize;
        normal_fit::offset(g.normals[m], g.normals[r], self.frames[c])
    }

    /// Receiver i's weights on every receiver, normalised, in the receivers' order: its
    /// cluster's kernel at its place times each cluster's weights on its members.
    pub fn row(&self, i: usize, out: &mut Vec<(u32, f32)>) {
        let c = self.cluster_of[i] as usize;
        let mut scratch = vertices::Scratch::default();
        self.cluster_kernel(c, &mut scratch);
        let place = self.member_place(c, i);
        let terms = vertices::terms(place[1], place[2]);
        let [a, b] = self.member_normal(c, i);
        out.clear();
        for (n, &(k, e)) in scratch.kernel.iter().enumerate() {
            let mut w = match self.settings.quadratic {
                true => vertices::dot(&scratch.weights[n], &terms),
                false => e[0] * place[0] + e[1] * place[1] + e[2] * place[2],
            };
            if let Some([na, nb]) = scratch.normal.get(n) {
                w += na * a + nb * b;
            }
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
                        // The fit's terms: (1, u, v), and (a, b) where it is in the normal
                        // too.
                        let terms = match scratch.normal.is_empty() {
                            true => 3,
                            false => normal_fit::TERMS,
                        };
                        sums.clear();
                        sums.resize(terms * (width + 1), 0.0);
                        let (sums, scalar_sums) = sums.split_at_mut(terms * width);
                        for (n, &(k, e)) in scratch.kernel.iter().enumerate() {
                            let k = k as usize;
                            let e = match scratch.normal.get(n) {
                                Some(&[a, b]) => [e[0], e[1], e[2], a, b],
                                None => [e[0], e[1], e[2], 0.0, 0.0],
                            };
                            let mean = &means[k * width..(k + 1) * width];
                            for (t, sums) in sums.chunks_exact_mut(width.max(1)).enumerate() {
                                clusters::add_scaled(sums, e[t], mean);
                            }
                            if let Some(s) = scalar_means.get(k) {
                                for t in 0..terms {
                                    scalar_sums[t] += e[t] * s;
                                }
                            }
                        }
                        // Each member's values, then its scalar.
                        for &(m, _) in self.clusters.row(c) {
                            let [p0, p1, p2] = self.member_place(c, m as usize);
                            let [p3, p4] = match terms {
                                3 => [0.0; 2],
                                _ => self.member_normal(c, m as usize),
                            };
                            let p = [p0, p1, p2, p3, p4];
                            match terms {
                                3 => {
                                    let (s0, rest) = sums.split_at(width);
                                    let (s1, s2) = rest.split_at(width);
                                    let dot = |(a, (b, d)): (&f32, (&f32, &f32))| {
                                        a * p0 + b * p1 + d * p2
                                    };
                                    rows.extend(s0.iter().zip(s1.iter().zip(s2)).map(dot));
                                }
                                _ => rows.extend((0..width).map(|j| {
                                    (0..terms).map(|t| sums[t * width + j] * p[t]).sum::<f32>()
                                })),
                            }
                            let s = &scalar_sums[..terms];
                            rows.push(s.iter().zip(p).map(|(s, p)| s * p).sum());
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
