//! Applying a vertex filter ([`super::vertices`]): each cluster's kernel and quadratic fit
//! formed once, the fit's six sums of its neighbour clusters' means formed once, and each
//! member reading them at its own place.

use glam::Vec4;
use rayon::prelude::*;

use super::Filter;
use super::vertices::{self, TERMS};

impl Filter<'_> {
    /// [`Filter::apply_in_place`] for a second-order fit, with each cluster's mean of
    /// `values` given (`width` floats per cluster): per cluster c, the fit's sums
    /// S_t = Σ_k e_k[t] mean_k for each term t of (1, u, v, u², uv, v²), the values and the
    /// scalar after them read in vector registers' lanes, zero-padded, in the kernel's order;
    /// a member's value is Σ_t x_t(u_m, v_m) S_t.
    pub(super) fn apply_quadratic(
        &self,
        values: &mut [f32],
        means: &[f32],
        width: usize,
        scalars: &mut [f32],
    ) {
        let clusters = self.clusters.reps.len();
        let scalar_means = match scalars.is_empty() {
            true => Vec::new(),
            false => self.clusters.means(scalars, 1),
        };
        let lanes = (width + 1).div_ceil(4);
        let mut padded = vec![Vec4::ZERO; clusters * lanes];
        for (c, at) in padded.chunks_exact_mut(lanes).enumerate() {
            let mean = &means[c * width..][..width];
            let float = |j: usize| match j.cmp(&width) {
                std::cmp::Ordering::Less => mean[j],
                std::cmp::Ordering::Equal => scalar_means.get(c).copied().unwrap_or(0.0),
                std::cmp::Ordering::Greater => 0.0,
            };
            for (l, lane) in at.iter_mut().enumerate() {
                *lane = Vec4::from_array(std::array::from_fn(|i| float(4 * l + i)));
            }
        }
        let stride = TERMS * lanes;
        let mut sums = vec![Vec4::ZERO; clusters * stride];
        sums.par_chunks_mut(stride).enumerate().for_each_init(
            vertices::Scratch::default,
            |scratch, (c, sums)| {
                // A cluster of one vertex reads its fit at its centroid, the vertex: the
                // first term alone.
                scratch.centre_only = self.clusters.mass[c] == 1.0;
                let used = if scratch.centre_only { 1 } else { TERMS };
                self.cluster_kernel(c, scratch);
                for (&(k, _), e) in scratch.kernel.iter().zip(&scratch.weights) {
                    let mean = &padded[k as usize * lanes..][..lanes];
                    for (sums, &e) in sums.chunks_exact_mut(lanes).zip(e).take(used) {
                        for (o, v) in sums.iter_mut().zip(mean) {
                            *o += e * *v;
                        }
                    }
                }
            },
        );
        // Member m's value in lanes `range` of its cluster's sums, at its place.
        let value = |m: usize, range: std::ops::Range<usize>, out: &mut [Vec4]| {
            let c = self.cluster_of[m] as usize;
            let [_, u, v] = self.member_place(c, m);
            let x = vertices::terms(u, v);
            let sums = &sums[c * stride..][..stride];
            out.fill(Vec4::ZERO);
            for (sums, &x) in sums.chunks_exact(lanes).zip(&x) {
                for (o, s) in out.iter_mut().zip(&sums[range.clone()]) {
                    *o += x * *s;
                }
            }
        };
        values
            .par_chunks_mut(width.max(1))
            .enumerate()
            .for_each_init(
                || vec![Vec4::ZERO; lanes],
                |lanes, (m, out)| {
                    value(m, 0..lanes.len(), lanes);
                    let floats = lanes.iter().flat_map(|v| v.to_array());
                    for (o, f) in out.iter_mut().zip(floats) {
                        *o = f;
                    }
                },
            );
        let mut lane = [Vec4::ZERO];
        for (m, s) in scalars.iter_mut().enumerate() {
            value(m, width / 4..width / 4 + 1, &mut lane);
            *s = lane[0].to_array()[width % 4];
        }
    }
}
