//! Applying a vertex filter ([`super::vertices`]): each cluster's kernel and quadratic fit
//! formed once, and each member reading its neighbour clusters' means at its own place.
//!
//! A member weighs the means by its fit's weights at its place, one pass over them; forming
//! the fit's six sums of the means first and reading them at each member's place took six
//! passes, which only a cluster of six members or more repays. Most clusters hold one to
//! three vertices, and a transfer matrix is 243 floats a mean: on the glossy torus this
//! stage was 38 % of the filter's instructions.

use glam::Vec4;
use rayon::prelude::*;

use super::Filter;
use super::vertices::{self, TERMS};

impl Filter<'_> {
    /// [`Filter::apply_in_place`] for a second-order fit, with each cluster's mean of
    /// `values` given (`width` floats per cluster): per cluster, its members' values
    /// ([`Filter::cluster_values`]), the values and the scalar after them read in vector
    /// registers' lanes, zero-padded, in the kernel's order; then each member's copied out.
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
        // Each cluster's members' values, in lanes, in the clusters' order of members.
        let mut rows = vec![Vec4::ZERO; self.clusters.members.len() * lanes];
        let mut per_cluster = Vec::with_capacity(clusters);
        let mut rest = &mut rows[..];
        for c in 0..clusters {
            let (mine, after) = rest.split_at_mut(self.clusters.row(c).len() * lanes);
            per_cluster.push(mine);
            rest = after;
        }
        per_cluster.into_par_iter().enumerate().for_each_init(
            || {
                (
                    vertices::Scratch::default(),
                    Vec::new(),
                    Vec::new(),
                    Vec::new(),
                )
            },
            |(scratch, sums, places, weights), (c, out)| {
                let work = (sums, places, weights);
                self.cluster_values(c, (&padded, lanes), scratch, work, out)
            },
        );
        // Each member's place among the rows.
        let mut position = vec![0u32; self.cluster_of.len()];
        for (p, &(m, _)) in self.clusters.members.iter().enumerate() {
            position[m as usize] = p as u32;
        }
        let row = |m: usize| rows[position[m] as usize * lanes..][..lanes].iter();
        values
            .par_chunks_mut(width.max(1))
            .enumerate()
            .for_each(|(m, out)| {
                let floats = row(m).flat_map(|v| v.to_array());
                for (o, f) in out.iter_mut().zip(floats) {
                    *o = f;
                }
            });
        for (m, s) in scalars.iter_mut().enumerate() {
            *s = row(m).flat_map(|v| v.to_array()).nth(width).unwrap_or(0.0);
        }
    }

    /// Cluster c's members' values into `out` (`lanes` per member, in its row's order), from
    /// the clusters' means in `padded`. Each member weighs entry k by e_k · x_m, its fit's
    /// weights at its place: one pass over the means per member. A cluster of [`TERMS`]
    /// members or more sums the means per term once, S_t = Σ_k e_k[t] mean_k, and each member
    /// reads Σ_t x_t S_t: fewer passes than one per member. A cluster of one reads e_k[0]
    /// alone either way (its place is the centroid).
    fn cluster_values(
        &self,
        c: usize,
        (padded, lanes): (&[Vec4], usize),
        scratch: &mut vertices::Scratch,
        (work, places, weights): (&mut Vec<Vec4>, &mut Vec<[f32; TERMS]>, &mut Vec<f32>),
        out: &mut [Vec4],
    ) {
        let members = self.clusters.row(c);
        scratch.centre_only = self.clusters.mass[c] == 1.0;
        self.cluster_kernel(c, scratch);
        places.clear();
        places.extend(members.iter().map(|&(m, _)| {
            let [_, u, v] = self.member_place(c, m as usize);
            vertices::terms(u, v)
        }));
        if members.len() < TERMS {
            // Each member's weight on each entry, then its values up to 8 lanes at a time,
            // their sums in registers; over the entries in the kernel's order.
            let entries = scratch.kernel.len();
            weights.clear();
            for x in places.iter() {
                weights.extend(scratch.weights.iter().map(|e| match scratch.centre_only {
                    true => e[0],
                    false => vertices::dot(e, x),
                }));
            }
            for (out, weights) in out
                .chunks_exact_mut(lanes)
                .zip(weights.chunks_exact(entries.max(1)))
            {
                for (block, out) in out.chunks_mut(8).enumerate() {
                    let entries = (&scratch.kernel[..], weights);
                    let means = (padded, lanes, block * 8);
                    match out.len() {
                        8 => weighted_sum::<8>(out, entries, means),
                        7 => weighted_sum::<7>(out, entries, means),
                        6 => weighted_sum::<6>(out, entries, means),
                        5 => weighted_sum::<5>(out, entries, means),
                        4 => weighted_sum::<4>(out, entries, means),
                        3 => weighted_sum::<3>(out, entries, means),
                        2 => weighted_sum::<2>(out, entries, means),
                        _ => weighted_sum::<1>(out, entries, means),
                    }
                }
            }
            return;
        }
        out.fill(Vec4::ZERO);
        work.clear();
        work.resize(TERMS * lanes, Vec4::ZERO);
        for (&(k, _), e) in scratch.kernel.iter().zip(&scratch.weights) {
            let mean = &padded[k as usize * lanes..][..lanes];
            for (sums, &e) in work.chunks_exact_mut(lanes).zip(e) {
                for (o, v) in sums.iter_mut().zip(mean) {
                    *o += e * *v;
                }
            }
        }
        for (out, x) in out.chunks_exact_mut(lanes).zip(places.iter()) {
            for (sums, &x) in work.chunks_exact(lanes).zip(x) {
                for (o, s) in out.iter_mut().zip(sums) {
                    *o += x * *s;
                }
            }
        }
    }
}

/// Σ_k w_k mean_k over the kernel's entries (k, w_k), in its order, for N lanes of the means
/// from lane `first` on (`lanes` per mean in `padded`), into `out`: the sums in registers.
#[inline(always)]
fn weighted_sum<const N: usize>(
    out: &mut [Vec4],
    (kernel, weights): (&[(u32, [f32; 3])], &[f32]),
    (padded, lanes, first): (&[Vec4], usize, usize),
) {
    let mut local = [Vec4::ZERO; N];
    for (&(k, _), &w) in kernel.iter().zip(weights) {
        let mean = &padded[k as usize * lanes + first..][..N];
        for (o, v) in local.iter_mut().zip(mean) {
            *o += w * *v;
        }
    }
    out.copy_from_slice(&local);
}
