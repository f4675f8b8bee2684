//! Texels' weighted first-order fits: over the tangent plane ([`PLANE`] terms), or in the
//! shading normal too ([`super::normal_fit`]), with a fit half as wide blended into the
//! plane's where the wide one cannot follow the guide.
//!
//! A first-order fit over 7 texels is unbiased for a transfer that changes linearly along the
//! surface, not for one that bends within a few texels: the ring of a contact shadow around a
//! crate's foot, a leaf's shadow, the crease of sky occlusion along a box's corner. There a
//! fit half as wide is blended in by Lepski's rule, as in Katkovnik's intersection of
//! confidence intervals (Katkovnik 1999, *A new method for varying adaptive bandwidth
//! selection*), as the vertices' fits are ([`super::vertices::fit`]): both fits are read on
//! the guide at the cluster's centroid, and where they differ by more than their
//! difference's noise Σ (a_k − b_k)² σ²_k allows, the narrower one counts, in part from
//! [`NARROWER`]'s first threshold and wholly from its second. Where the transfer is smooth
//! the two agree within their noise and the wide fit is kept. A fit a quarter as wide, as
//! the vertices have, changed nothing more; in the normal-mapped fit the narrower one raised
//! the courtyard wall's error (docs/explanation/denoising.md).

use glam::Vec4;

use super::cholesky;
use super::exp4::exp4;

/// The squared difference of the wide and the half-width fits of the guide, over its noise
/// variance, from which the narrower fit is blended in and at which it is taken whole.
/// Measured at 64 rays on the production courtyard at 512², sun and sky / low sun / sky, 2
/// seeds: 1.28 / 2.20 / 0.73 % without it; 1.16 / 2.00 / 0.68 % at 2 / 8; 1.17 / 2.02 / 0.68
/// % at 2.5 / 10; 1.18 / 2.04 / 0.68 % at 3 / 12. The Cornell room at 256² moved by under 1
/// % at 2.5 / 10 at 64 and 256 rays, and rose by up to 0.6 % at 2 / 8.
const NARROWER: (f64, f64) = (2.5, 10.0);

/// The plane fit's terms: 1, u, v.
pub(super) const PLANE: usize = 3;

/// The plane fit's ridge on each term, relative to the kernel's mass: a neighbourhood along a
/// line (a one-texel-wide strip) fits no slope across it.
pub(super) const PLANE_RIDGES: [f64; PLANE] = [0.0, 1e-2, 1e-2];

/// One cluster's kernel as its fit reads it, and the fit's weights.
#[derive(Default)]
pub(super) struct Scratch<const N: usize> {
    /// Each entry's cluster.
    pub key: Vec<u32>,
    /// Each entry's kernel weight.
    pub weight: Vec<f64>,
    /// Each entry's terms x_k: (1, u, v, …) at its place.
    pub terms: Vec<[f64; N]>,
    /// Each entry's taper for the narrower fit, exp(−6 r²) on top of the kernel's exp(−2 r²),
    /// r its distance in the plane in kernel radii: a Gaussian half as wide.
    taper: Vec<f64>,
    /// The fit's weights: entry k weighs a member at x by `fitted[k]` · x.
    pub fitted: Vec<[f64; N]>,
    /// Per coefficient of the guide, four to a lane: the two fits' difference at the
    /// centroid.
    delta: Vec<Vec4>,
}

impl<const N: usize> Scratch<N> {
    pub fn clear(&mut self) {
        self.key.clear();
        self.weight.clear();
        self.terms.clear();
        self.taper.clear();
    }

    /// Adds entries (k, w, x): cluster k's, of kernel weight w and terms x (x[1], x[2]: its
    /// place in the tangent plane, in spacings).
    pub fn extend(&mut self, entries: impl Iterator<Item = (u32, f32, [f64; N])> + Clone) {
        self.key.extend(entries.clone().map(|(k, ..)| k));
        self.weight
            .extend(entries.clone().map(|(_, w, _)| f64::from(w)));
        self.terms.extend(entries.map(|(.., x)| x));
    }
}

/// The Cholesky factor of A = Σ w_k s_k x_k x_kᵀ, its ridge (`ridge[t]` × the mass on term
/// t) added, with s_k the entries' tapers for the narrower fit (1 for the wide one).
fn factor<const N: usize>(
    weight: &[f64],
    terms: &[[f64; N]],
    taper: Option<&[f64]>,
    ridge: &[f64; N],
) -> Option<[[f64; N]; N]> {
    let mut a = [[0.0f64; N]; N];
    for (k, (&w, x)) in weight.iter().zip(terms).enumerate() {
        let w = w * taper.map_or(1.0, |t| t[k]);
        for p in 0..N {
            for q in 0..=p {
                a[p][q] += w * x[p] * x[q];
            }
        }
    }
    let mass = a[0][0];
    for (p, row) in a.iter_mut().enumerate() {
        row[p] += ridge[p] * mass;
    }
    cholesky::factor(&a, 0.0)
}

/// A⁻¹ from its Cholesky factor `l`, column by column (A is symmetric, so are they rows).
fn inverse<const N: usize>(l: &[[f64; N]; N]) -> [[f64; N]; N] {
    std::array::from_fn(|column| {
        let mut y = [0.0; N];
        y[column] = 1.0;
        cholesky::solve(l, &mut y);
        y
    })
}

/// A⁻¹ x w: an entry's weights in the fit of inverse `b`.
fn weights<const N: usize>(b: &[[f64; N]; N], x: &[f64; N], w: f64) -> [f64; N] {
    b.map(|row| row.iter().zip(x).map(|(b, x)| b * x).sum::<f64>() * w)
}

/// Turns the kernel pushed into `scratch` into the weights of its first-order fit,
/// e_k = w_k A⁻¹ x_k with A = Σ w_k x_k x_kᵀ, into `scratch.fitted`: they sum to 1 at every
/// place. With `narrower`, the kernel's radius in spacings, the half-width fit is blended in
/// by [`NARROWER`]; `guide(k)` gives cluster k's guide (`sw` floats in
/// [`super::range::guide_lanes`] lanes) and its variance. Returns false (nothing fitted)
/// where the wide fit is singular.
pub(super) fn fit<'g, const N: usize>(
    scratch: &mut Scratch<N>,
    ridge: &[f64; N],
    narrower: Option<f64>,
    sw: usize,
    guide: impl Fn(u32) -> (&'g [Vec4], f32),
) -> bool {
    let Scratch {
        key,
        weight,
        terms,
        taper,
        fitted,
        delta,
    } = scratch;
    let Some(wide) = factor(weight, terms, None, ridge).map(|l| inverse(&l)) else {
        return false;
    };
    fitted.clear();
    fitted.extend(
        weight
            .iter()
            .zip(terms.iter())
            .map(|(&w, x)| weights(&wide, x, w)),
    );
    let Some(radius) = narrower else {
        return true;
    };
    // The tapers, four at a time.
    let falloff = Vec4::splat((-6.0 / (radius * radius)) as f32);
    taper.clear();
    for four in terms.chunks(4) {
        let r2 = Vec4::from_array(std::array::from_fn(|l| {
            four.get(l)
                .map_or(0.0, |x| (x[1] * x[1] + x[2] * x[2]) as f32)
        }));
        let t = exp4(r2 * falloff).to_array();
        taper.extend(t[..four.len()].iter().map(|&t| f64::from(t)));
    }
    let Some(narrow) = factor(weight, terms, Some(taper), ridge).map(|l| inverse(&l)) else {
        return true;
    };
    // The narrower fit's weight at the centroid: its inverse's first row, dotted.
    let narrow_at_centre = |(k, x): (usize, &[f64; N])| {
        narrow[0].iter().zip(x).map(|(f, x)| f * x).sum::<f64>() * weight[k] * taper[k]
    };
    let differences = (fitted.iter().zip(terms.iter().enumerate()))
        .map(|(e, entry)| e[0] - narrow_at_centre(entry));
    let share = share_of_second((key, differences), sw, guide, delta);
    if share > 0.0 {
        for (k, (x, e)) in terms.iter().zip(fitted.iter_mut()).enumerate() {
            let n = weights(&narrow, x, weight[k] * taper[k]);
            for (e, n) in e.iter_mut().zip(n) {
                *e = *e * (1.0 - share) + n * share;
            }
        }
    }
    true
}

/// Lepski's rule between two fits of one kernel: the share of the second to blend into the
/// first. `differences` holds each entry's weight at the centroid in the first fit less in
/// the second, entry k reading cluster `keys[k]`'s guide (`sw` floats in lanes, and its
/// variance, from `guide`). The two fits of the guide at the centroid differ by d² of their
/// difference's noise, Σ (a_k − b_k)² σ²_k: the share is 0 up to [`NARROWER`]'s first
/// threshold and 1 from its second, and 0 where there is no noise (d² NaN). `delta` is the
/// difference's buffer, per four coefficients of the guide.
pub(super) fn share_of_second<'g>(
    (keys, differences): (&[u32], impl Iterator<Item = f64>),
    sw: usize,
    guide: impl Fn(u32) -> (&'g [Vec4], f32),
    delta: &mut Vec<Vec4>,
) -> f64 {
    delta.clear();
    delta.resize(super::range::guide_lanes(sw), Vec4::ZERO);
    let mut variance = 0.0f64;
    for (&k, difference) in keys.iter().zip(differences) {
        let (row, noise) = guide(k);
        variance += difference * difference * f64::from(noise);
        let difference = Vec4::splat(difference as f32);
        for (d, &g) in delta.iter_mut().zip(row) {
            *d += difference * g;
        }
    }
    let squared: f64 = delta.iter().map(|d| f64::from(d.length_squared())).sum();
    let (start, full) = NARROWER;
    let d2 = squared / (sw.max(1) as f64 * variance);
    let share = ((d2 - start) / (full - start)).clamp(0.0, 1.0);
    // NaN (no variance) keeps the first fit.
    if share > 0.0 { share } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A texel on a 15 × 15 grid of neighbours (one spacing apart, radius 7) whose guide bends
    /// faster than a line (a contact shadow's exp): with a noise far below the fits'
    /// difference the narrower fit is blended in and reads the texel's value closer; with a
    /// noise far above it the wide fit is kept, to the bit.
    #[test]
    fn the_narrower_fit_is_blended_in_where_the_guide_bends_beyond_its_noise() {
        let radius = 7.0f64;
        let places: Vec<(f64, f64)> = (-7..=7)
            .flat_map(|x| (-7..=7).map(move |y| (f64::from(x), f64::from(y))))
            .filter(|(x, y)| x * x + y * y <= radius * radius)
            .collect();
        let guides: Vec<[Vec4; 1]> = places
            .iter()
            .map(|&(x, _)| [Vec4::new((x * 0.6).exp() as f32, 0.0, 0.0, 0.0)])
            .collect();
        let read = |narrower: Option<f64>, noise: f32| {
            let mut scratch = Scratch::<PLANE>::default();
            scratch.extend(places.iter().enumerate().map(|(k, &(x, y))| {
                let w = (-2.0 * (x * x + y * y) / (radius * radius)).exp() as f32;
                (k as u32, w, [1.0, x, y])
            }));
            assert!(fit(&mut scratch, &PLANE_RIDGES, narrower, 1, |k| {
                (&guides[k as usize][..], noise)
            }));
            let at_centre: f64 = (scratch.fitted.iter().zip(&guides))
                .map(|(e, g)| e[0] * f64::from(g[0].x))
                .sum();
            (scratch.fitted, at_centre)
        };
        let (wide, wide_value) = read(None, 1e-6);
        let (quiet, quiet_value) = read(Some(radius), 1e-6);
        let (noisy, _) = read(Some(radius), 1e9);
        assert!(
            (quiet_value - 1.0).abs() < 0.5 * (wide_value - 1.0).abs(),
            "{quiet_value} {wide_value}"
        );
        assert_eq!(noisy, wide);
        assert_ne!(quiet, wide);
    }
}
