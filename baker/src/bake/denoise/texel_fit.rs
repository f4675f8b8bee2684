//! Texels' weighted fits: first-order over the tangent plane ([`PLANE`] terms), in the
//! shading normal too ([`super::normal_fit`]) or in the contact term
//! ([`super::contact`]), and the curved fit in the plane's squares blended in where the
//! first-order one cannot follow the guide ([`blend_curved`]); and Lepski's rule, which
//! chooses between two fits of one kernel ([`share_of_second`]).
//!
//! A first-order fit over 7 texels is unbiased for a transfer that changes linearly along
//! the surface, not for one that curves over the kernel: the shade of a crate darkening the
//! floor towards its foot, the crease of sky occlusion along a box's corner. There the fit
//! in the squares of the plane's coordinates is blended in by Lepski's rule, as in
//! Katkovnik's intersection of confidence intervals (Katkovnik 1999, *A new method for
//! varying adaptive bandwidth selection*), as the vertices' narrower fits are
//! ([`super::vertices::fit`]): both fits are read on the guide at the cluster's centroid,
//! and where they differ by more than their difference's noise Σ (a_k − b_k)² σ²_k allows,
//! the curved one counts, in part from [`CURVED_FROM`]'s first threshold and wholly from
//! its second. Where the transfer is straight the two agree within their noise and the
//! first-order fit is kept.
//!
//! The curved fit replaced a first-order fit half as wide, blended in the same way: on the
//! production courtyard at 64 rays it left 0.4 % more error beside the curved fit and the
//! clusters of one texel near contact ([`super::contact::Contacts::joinable`]), for a sixth of the
//! filter's time (docs/explanation/denoising-record.md).

use glam::Vec4;

use super::cholesky;

/// A kernel's entry: cluster k's, with [w, u, v], its weight and its place in the tangent
/// plane, which the fits turn into its weights on (1, u, v).
pub(super) type Entry = (u32, [f32; 3]);

/// The plane fit's terms: 1, u, v.
pub(super) const PLANE: usize = 3;

/// The plane fit's ridge on each term, relative to the kernel's mass: a neighbourhood along a
/// line (a one-texel-wide strip) fits no slope across it.
pub(super) const PLANE_RIDGES: [f64; PLANE] = [0.0, 1e-2, 1e-2];

/// The curved fit's terms: 1, u, v, the contact term c ([`super::contact`]), u², uv, v².
pub(super) const CURVED: usize = 7;

/// The curved fit's ridge on each term, relative to the kernel's mass: as the plane's on its
/// slopes and the contact fit's on c; small beside the squares' own second moments (about
/// 10 spacings² over the kernel), where 10⁻⁴ and 1 gave the same error.
const CURVED_RIDGES: [f64; CURVED] = [0.0, 1e-2, 1e-2, 1e-2, 1e-2, 1e-2, 1e-2];

/// The squared difference of the fit so far and the curved fit on the guide, over its noise
/// variance, from which the curved fit is blended in and at which it is taken whole. At 64
/// rays on the production courtyard at 512², sun and sky / low sun / sky, 2 seeds (before
/// the clusters of one near contact): 0.970 / 1.603 / 0.566 % at 2.5 / 10; **0.967 / 1.597
/// / 0.566 %** at 2 / 8; 0.981 / 1.601 / 0.573 % at 1 / 4; 0.986 / 1.633 / 0.572 % at 5 /
/// 20; the curved fit whole, 1.061 / 1.706 / 0.604 %.
const CURVED_FROM: (f64, f64) = (2.0, 8.0);

/// One cluster's kernel as its fit reads it, and the fit's weights.
#[derive(Default)]
pub(super) struct Scratch<const N: usize> {
    /// Each entry's cluster.
    pub key: Vec<u32>,
    /// Each entry's kernel weight.
    pub weight: Vec<f64>,
    /// Each entry's terms x_k: (1, u, v, …) at its place.
    pub terms: Vec<[f64; N]>,
    /// The fit's weights: entry k weighs a member at x by `fitted[k]` · x.
    pub fitted: Vec<[f64; N]>,
    /// Per coefficient of the guide, four to a lane: two fits' difference at the centroid.
    delta: Vec<Vec4>,
}

impl<const N: usize> Scratch<N> {
    pub fn clear(&mut self) {
        self.key.clear();
        self.weight.clear();
        self.terms.clear();
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

/// The Cholesky factor of A = Σ w_k x_k x_kᵀ, its ridge (`ridge[t]` × the mass on term t)
/// added.
fn factor<const N: usize>(
    weight: &[f64],
    terms: &[[f64; N]],
    ridge: &[f64; N],
) -> Option<[[f64; N]; N]> {
    // Row by row, each row's sums kept in registers over the entries rather than the whole
    // matrix in memory: the same sums, in the same order.
    let mut a = [[0.0f64; N]; N];
    for (p, row) in a.iter_mut().enumerate() {
        let mut sums = [0.0f64; N];
        for (&w, x) in weight.iter().zip(terms) {
            let wx = w * x[p];
            for (s, &xq) in sums[..=p].iter_mut().zip(x) {
                *s += wx * xq;
            }
        }
        row[..=p].copy_from_slice(&sums[..=p]);
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

/// A⁻¹ x w: an entry's weights in the fit of inverse `b`, given as its columns: the sum
/// over x's terms in their order, each a column scaled, runs down the rows in vector
/// registers.
#[inline(always)]
fn weights<const N: usize>(columns: &[[f64; N]; N], x: &[f64; N], w: f64) -> [f64; N] {
    let mut out = [-0.0; N];
    for (column, &x) in columns.iter().zip(x) {
        for (out, b) in out.iter_mut().zip(column) {
            *out += b * x;
        }
    }
    out.map(|sum| sum * w)
}

/// The columns of `b`.
fn columns<const N: usize>(b: &[[f64; N]; N]) -> [[f64; N]; N] {
    std::array::from_fn(|q| std::array::from_fn(|p| b[p][q]))
}

/// Turns the kernel pushed into `scratch` into the weights of its first-order fit,
/// e_k = w_k A⁻¹ x_k with A = Σ w_k x_k x_kᵀ, into `scratch.fitted`: they sum to 1 at every
/// place. Returns false (nothing fitted) where the fit is singular.
pub(super) fn fit<const N: usize>(scratch: &mut Scratch<N>, ridge: &[f64; N]) -> bool {
    match factor_fit(scratch, ridge) {
        Some(l) => {
            fill(&l, scratch);
            true
        }
        None => false,
    }
}

/// The Cholesky factor of the fit of the kernel pushed into `scratch`, for a fit that
/// Lepski's rule tests first: the rule reads its weights at the centroid alone
/// ([`at_centre`]), one solve, and its every weight ([`fill`]) is formed only where it
/// counts. None where the fit is singular.
pub(super) fn factor_fit<const N: usize>(
    scratch: &Scratch<N>,
    ridge: &[f64; N],
) -> Option<[[f64; N]; N]> {
    factor(&scratch.weight, &scratch.terms, ridge)
}

/// Each entry's weight at the centroid in the fit of Cholesky factor `l`: A⁻¹'s first row
/// dotted with its terms, the same floats as [`fill`]'s `fitted[k][0]`.
pub(super) fn at_centre<'a, const N: usize>(
    l: &[[f64; N]; N],
    (terms, weight): (&'a [[f64; N]], &'a [f64]),
) -> impl Iterator<Item = f64> + 'a {
    let mut first = [0.0; N];
    first[0] = 1.0;
    cholesky::solve(l, &mut first);
    (terms.iter().zip(weight))
        .map(move |(x, w)| first.iter().zip(x).map(|(f, x)| f * x).sum::<f64>() * w)
}

/// The fit's weights from its Cholesky factor `l` into `scratch.fitted`, as [`fit`] forms
/// them.
pub(super) fn fill<const N: usize>(l: &[[f64; N]; N], scratch: &mut Scratch<N>) {
    let Scratch {
        weight,
        terms,
        fitted,
        ..
    } = scratch;
    let inverse = columns(&inverse(l));
    fitted.clear();
    fitted.extend(
        weight
            .iter()
            .zip(terms.iter())
            .map(|(&w, x)| weights(&inverse, x, w)),
    );
}

/// Lepski's rule between two fits of one kernel: the share of the second to blend into the
/// first. `differences` holds each entry's weight at the centroid in the first fit less in
/// the second, entry k reading cluster `keys[k]`'s guide (`sw` floats in lanes, and its
/// variance, from `guide`). The two fits of the guide at the centroid differ by d² of their
/// difference's noise, Σ (a_k − b_k)² σ²_k: the share is 0 up to the first of `thresholds`
/// and 1 from the second, and 0 where there is no noise (d² NaN). `delta` is the
/// difference's buffer, per four coefficients of the guide.
pub(super) fn share_of_second<'g>(
    (keys, differences): (&[u32], impl Iterator<Item = f64>),
    sw: usize,
    guide: impl Fn(u32) -> (&'g [Vec4], f32),
    delta: &mut Vec<Vec4>,
    (start, full): (f64, f64),
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
    let d2 = squared / (sw.max(1) as f64 * variance);
    let share = ((d2 - start) / (full - start)).clamp(0.0, 1.0);
    // NaN (no variance) keeps the first fit.
    if share > 0.0 { share } else { 0.0 }
}

/// Blends the curved fit ([`CURVED`] terms) of the kernel in `curved` (its entries pushed)
/// into the fit so far, `current`: each entry's weights on the same terms, 0 on those the
/// fit so far has not. Lepski's rule at [`CURVED_FROM`] compares the two at the centroid;
/// the test needs only the curved fit's weights there (one solve), and its other weights
/// are formed only where it counts. Returns whether it counts.
///
/// A first-order fit over 7 texels misses where the transfer curves over the kernel: the
/// shade of a crate darkens the floor faster towards its foot, over 10–20 texels, and the
/// plane's fit reads the floor too bright near the crate and too dark further out. The squares of
/// the plane's coordinates follow that curve; where the transfer is straight they cost noise
/// and the rule keeps the fit so far.
pub(super) fn blend_curved<'g>(
    curved: &mut Scratch<CURVED>,
    current: &mut [[f64; CURVED]],
    sw: usize,
    guide: impl Fn(u32) -> (&'g [Vec4], f32),
) -> bool {
    let Scratch {
        key,
        weight,
        terms,
        delta,
        ..
    } = curved;
    let Some(l) = factor(weight, terms, &CURVED_RIDGES) else {
        return false;
    };
    let centre = at_centre(&l, (terms, weight));
    let differences = current.iter().zip(centre).map(|(e, c)| e[0] - c);
    let share = share_of_second((key, differences), sw, guide, delta, CURVED_FROM);
    if share <= 0.0 {
        return false;
    }
    let inverse = columns(&inverse(&l));
    for (k, (x, e)) in terms.iter().zip(current.iter_mut()).enumerate() {
        let c = weights(&inverse, x, weight[k]);
        for (e, c) in e.iter_mut().zip(c) {
            *e = *e * (1.0 - share) + c * share;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lepski's rule reads a fit's weights at the centroid from its factor alone
    /// ([`at_centre`]) and forms the rest only where the fit counts ([`fill`]): the two must
    /// be the same floats, or a fit that counts would be blended with other weights than the
    /// rule tested.
    #[test]
    fn the_weights_at_the_centroid_are_the_fits_to_the_bit() {
        let mut fit = Scratch::<CURVED>::default();
        fit.extend((0..40u32).map(|k| {
            let (u, v) = ((k % 7) as f64 - 3.1, (k / 7) as f64 - 2.7);
            let c = 0.9 / (1.0 + f64::from(k));
            (
                k,
                0.2 + (k % 5) as f32 * 0.3,
                [1.0, u, v, c, u * u, u * v, v * v],
            )
        }));
        let l = factor_fit(&fit, &CURVED_RIDGES).expect("a fit of 40 entries");
        let centre: Vec<f64> = at_centre(&l, (&fit.terms, &fit.weight)).collect();
        fill(&l, &mut fit);
        for (k, (c, f)) in centre.iter().zip(&fit.fitted).enumerate() {
            assert_eq!(
                c.to_bits(),
                f[0].to_bits(),
                "entry {k}: {c} against {}",
                f[0]
            );
        }
        // They sum to 1: the fit keeps a constant.
        assert!((centre.iter().sum::<f64>() - 1.0).abs() < 1e-9);
    }

    /// A texel on a 15 × 15 grid of neighbours (one spacing apart, radius 7) whose guide
    /// curves over the kernel, as a crate's shade does towards its foot: with a noise far
    /// below the fits' difference the curved fit is blended in and reads the texel's value
    /// where the plane's misses; with a noise far above it the plane's fit is kept, to the
    /// bit.
    #[test]
    fn the_curved_fit_is_blended_in_where_the_guide_curves_beyond_its_noise() {
        let radius = 7.0f64;
        let places: Vec<(f64, f64)> = (-7..=7)
            .flat_map(|x| (-7..=7).map(move |y| (f64::from(x), f64::from(y))))
            .filter(|(x, y)| x * x + y * y <= radius * radius)
            .collect();
        let value = |x: f64, y: f64| 0.5 + 0.05 * x + 0.01 * x * x - 0.005 * x * y;
        let guides: Vec<[Vec4; 1]> = (places.iter())
            .map(|&(x, y)| [Vec4::new(value(x, y) as f32, 0.0, 0.0, 0.0)])
            .collect();
        let weight = |x: f64, y: f64| (-2.0 * (x * x + y * y) / (radius * radius)).exp() as f32;
        let mut plane = Scratch::<PLANE>::default();
        plane.extend(
            (places.iter().enumerate()).map(|(k, &(x, y))| (k as u32, weight(x, y), [1.0, x, y])),
        );
        assert!(fit(&mut plane, &PLANE_RIDGES));
        let first_order: Vec<[f64; CURVED]> = (plane.fitted.iter())
            .map(|f| std::array::from_fn(|t| f.get(t).copied().unwrap_or(0.0)))
            .collect();
        let read = |noise: f32| {
            let mut curved = Scratch::<CURVED>::default();
            curved.extend(places.iter().enumerate().map(|(k, &(x, y))| {
                (
                    k as u32,
                    weight(x, y),
                    [1.0, x, y, 0.0, x * x, x * y, y * y],
                )
            }));
            let mut weights = first_order.clone();
            let guide = |k: u32| (&guides[k as usize][..], noise);
            let blended = blend_curved(&mut curved, &mut weights, 1, guide);
            let at_centre: f64 = (weights.iter().zip(&guides))
                .map(|(e, g)| e[0] * f64::from(g[0].x))
                .sum();
            (blended, weights, (at_centre - 0.5).abs())
        };
        let (blended, _, curved) = read(1e-8);
        assert!(blended, "not blended in at a low noise");
        let (blended, kept, _) = read(1e9);
        assert!(!blended, "blended in at a high noise");
        assert_eq!(kept, first_order);
        let (_, _, missed) = read(1e9);
        assert!(curved < 0.01 * missed, "curved {curved}, plane {missed}");
    }
}
