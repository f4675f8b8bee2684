//! The wide pass's guides: each cluster's or receiver's signal prefiltered over a few
//! spacings with the geometric terms and the raw signal's own range term, and the variance
//! of each receiver's signal where the rays gave none.

use rayon::prelude::*;

use super::range::range_exponent;
use super::{Filter, GUIDE_KAPPA};

impl Filter<'_> {
    /// The variance of each receiver's signal where the rays gave none: half the median
    /// squared difference to its closest neighbours (noise alone puts two receivers 2σ²
    /// apart; the median ignores the few across an edge).
    pub(super) fn noise_from_signal(&self, signal: &[f32]) -> Vec<f32> {
        let sw = self.signal_width;
        (0..self.guides.points.len())
            .into_par_iter()
            .map_init(
                || (Vec::new(), Vec::new()),
                |(near, squares): &mut (Vec<(u32, f32)>, Vec<f32>), i| {
                    self.neighbours(i, self.settings.guide_radius, near, |_| 0.0);
                    squares.clear();
                    squares.extend(near.iter().filter(|&&(j, _)| j as usize != i).map(
                        |&(j, _)| {
                            let (a, b) =
                                (&signal[i * sw..][..sw], &signal[j as usize * sw..][..sw]);
                            a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f32>() / sw as f32
                        },
                    ));
                    if squares.is_empty() {
                        return 0.0;
                    }
                    let mid = squares.len() / 2;
                    *squares.select_nth_unstable_by(mid, f32::total_cmp).1 * 0.5
                },
            )
            .collect()
    }

    /// The guides of `receivers` into `guide`, `signal_width` floats each in their order: the
    /// signal filtered with the geometric terms over `guide_radius`; and its variance
    /// Σ_j w_ij² σ²_j into `guide_noise`.
    pub(super) fn prefilter(
        &self,
        signal: &[f32],
        noise: &[f32],
        receivers: &[u32],
        (guide, guide_noise): (&mut [f32], &mut [f32]),
    ) {
        let sw = self.signal_width;
        guide
            .par_chunks_mut(sw.max(1))
            .zip(guide_noise.par_iter_mut())
            .zip(receivers.par_iter())
            .for_each_init(Vec::new, |near, ((out, var), &i)| {
                let i = i as usize;
                // The raw signal's own range term: a receiver's guide does not take in
                // neighbours far brighter or darker than its noise allows (a thin wall's
                // other side, a shadow's edge).
                let si = &signal[i * sw..(i + 1) * sw];
                self.neighbours(i, self.settings.guide_radius, near, |j| {
                    let sj = &signal[j * sw..(j + 1) * sw];
                    range_exponent(si, sj, (noise[i] + noise[j]) * sw as f32, GUIDE_KAPPA)
                });
                let total: f32 = near.iter().map(|&(_, w)| w).sum();
                for &(j, w) in near.iter() {
                    let w = w / total;
                    let j = j as usize;
                    for (o, s) in out.iter_mut().zip(&signal[j * sw..(j + 1) * sw]) {
                        *o += w * s;
                    }
                    *var += w * w * noise[j];
                }
            });
    }
}
