//! Texels whose shading normals vary (a normal map, or a surface that bends within a few
//! texels: [`Normals`]) are fitted in the normal too: a first-order fit in (u, v, a, b),
//! where (a, b) is a neighbour's shading normal less the cluster's, in the cluster's tangent
//! frame, and from [`super::FINE_CLUSTERS_FROM`] rays a texel in a², ab and b² as well.
//!
//! Transfer follows the shading normal: unoccluded, its band 1 is linear in the normal and its
//! band 2 quadratic, so across a normal map's bumps it changes from texel to texel as much as
//! across a shadow's edge. A fit over the tangent plane alone averages those changes away (on
//! the production courtyard's normal-mapped wall, 64 rays denoised were 5.9 × further from the
//! reference than 512 raw rays, a third of the whole atlas's error); with the normal as two
//! more regressors the fit follows them, as feature-based regression filters follow their
//! feature buffers (Moon, Carr & Yoon 2014, *Adaptive rendering based on weighted local
//! regression*; Bitterli et al. 2016, *Nonlinearly weighted first-order regression for
//! denoising Monte Carlo renderings*). Where the normals do not vary (no normal map, a flat
//! chart) the cluster keeps the fit over the plane alone, as before, to the bit.
//!
//! The linear fit leaves band 2's curve in the normal as a bias that more rays do not take
//! away; the quadratic terms remove it, for three more regressors' noise, which only a
//! bake of more rays can pay. On the courtyard (2 seeds, sun and sky / low sun / sky): at
//! 1,024 rays 0.316 / 0.515 / 0.172 % -> 0.303 / 0.494 / 0.165 %; at 256 rays 0.551 / 0.881
//! / 0.313 % -> 0.537 / 0.877 / 0.305 % (the wall's part of the sun and sky 0.243 -> 0.210
//! points); at 64 rays the low sun's 1.74 % rose to 1.80 %, so under 256 rays the quadratic
//! fit is blended in by Lepski's rule ([`QUADRATIC_FROM`]) where it departs from the
//! first-order one by more than noise.
//!
//! The bumps also make neighbours' transfer differ by many noise deviations, so a range term
//! that compares each neighbour with the texel's own guide cuts most of them, and leaves the
//! fit few neighbours to follow the bumps with. Over a normal map the range term is robust
//! ([`reweigh`]): each neighbour is weighed again by its distance from the first fit at its
//! place and normal (one step of iteratively reweighted local regression, Cleveland 1979), as
//! the vertices' is. On the courtyard's wall it took the low sun's error from 1.19 to 0.96
//! points (raw 512 rays: 0.88).

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use super::exp4;
use super::texel_fit::{Entry, Scratch};

/// Below this spread of the neighbours' normal offsets (about 0.6°) the fit stays in the
/// plane.
pub(super) const SPREAD: f32 = 0.01;
/// The fit's ridge on each term, relative to the kernel's mass: on the plane's slopes as the
/// plane fit's ([`super::texel_fit::PLANE_RIDGES`]); on the normal's, small beside the
/// offsets' own second moment (about 10⁻² for a normal map's ±6°), so that a neighbourhood
/// whose normals vary along one direction only fits no slope across it; on its squares and
/// product, as small beside theirs (about 10⁻⁴).
const RIDGES: [f64; QUADRATIC] = [0.0, 1e-2, 1e-2, 1e-4, 1e-4, 1e-6, 1e-6, 1e-6];

/// The first `N` of [`RIDGES`].
fn ridges<const N: usize>() -> [f64; N] {
    std::array::from_fn(|t| RIDGES[t])
}

/// The first-order fit's terms: 1, u, v, a, b.
const LINEAR: usize = 5;
/// The quadratic fit's terms: 1, u, v, a, b, a², ab, b².
const QUADRATIC: usize = 8;
/// The most terms in the normal a fit has: a, b, a², ab, b².
pub(super) const NORMAL: usize = QUADRATIC - 3;

/// The terms in the normal of an offset (a, b): its squares and product as well where the
/// fit is `quadratic`, else 0 in their place.
pub(super) fn normal_terms([a, b]: [f32; 2], quadratic: bool) -> [f32; NORMAL] {
    match quadratic {
        true => [a, b, a * a, a * b, b * b],
        false => [a, b, 0.0, 0.0, 0.0],
    }
}

/// The squared difference of the first-order and the quadratic fits in the normal on the
/// guide, over its noise variance, from which a bake of fewer than
/// [`super::FINE_CLUSTERS_FROM`] rays blends the quadratic fit in and at which it takes it
/// whole. On the production courtyard at 512², 64 rays, 2 seeds (sun and sky / low sun /
/// sky): the first-order fit alone 0.967 / 1.597 / 0.566 %; at 2.5 / 10, 0.957 / 1.613 /
/// 0.558 %; at 5 / 20, **0.957 / 1.601 / 0.560 %**; at 10 / 40, 0.961 / 1.597 / 0.562 %.
const QUADRATIC_FROM: (f64, f64) = (5.0, 20.0);

/// How a group's (object and material's) texels are fitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Normals {
    /// Over the plane: its shading normals do not vary, or slowly.
    Plane,
    /// In the normal too: a normal map turns some shading normal off its surface's.
    Mapped,
    /// In the normal too: its surface bends within a few texels ([`BENDS`]), as a
    /// terrain's does.
    Bends,
}

/// The median over a group's texels of the largest turn of the surface normal to a
/// neighbour within 1.5 spacings (1 − cos, about 2°), from which the group bends within a
/// few texels. On the terrain of `scripts/bench/large_scene.py` at 512² (its normals turn 6°
/// a texel), 64 rays: fitted over the plane, 3.05 / 3.64 / 2.38 %; in the normal, 2.68 /
/// 3.14 / 2.11 %; with the normal term at the power 1 instead of 32 as well, 2.13 / 2.52 /
/// 1.67 % (raw 512 rays: 1.49 / 1.77 / 1.15 %).
const BENDS: f32 = 6e-4;

/// The normal term's power where the fit is in the normal (over a normal map, or a surface
/// that bends), as the number of squarings that raise it ([`power_of_two`]): 0, the cosine
/// itself. The fit follows the transfer's turn with the normal, so a neighbour's turned
/// normal needs no cut of its own; at 32, the few neighbours the term keeps where the
/// normals turn 6° a texel, or across a brick's joint, leave most of the noise.
pub(super) const FITTED_POWER: u32 = 0;

/// The power of the shading normals' dot product over a plane, 2⁵ = 32, as the number of
/// squarings that raise it: x^32 inline, rather than a call to the runtime's `powi` for an
/// exponent known only at run time (the same product, bit for bit).
pub(super) const NORMAL_SQUARINGS: u32 = 5;

/// x^(2^`squarings`).
pub(super) fn power_of_two(mut x: f32, squarings: u32) -> f32 {
    for _ in 0..squarings {
        x *= x;
    }
    x
}

/// Each group's [`Normals`], its texels' neighbours found in `fine`: the same on either
/// lattice, as the neighbours are found by distance, not by cell.
pub(super) fn groups(guides: &super::guides::Guides, fine: &super::grid::Grid) -> Vec<Normals> {
    let count = guides.groups.iter().max().map_or(0, |&g| g as usize + 1);
    let mut mapped = vec![false; count];
    let normals = guides.normals.iter().zip(&guides.surfaces);
    for (&group, (n, s)) in guides.groups.iter().zip(normals) {
        if n != s {
            mapped[group as usize] = true;
        }
    }
    // A group of one surface normal (a floor, a wall, a card) turns nowhere: its texels'
    // neighbours need not be sought (on the courtyard, 2 % of the filter's instructions).
    let mut first: Vec<Option<Vec3>> = vec![None; count];
    let mut flat = vec![true; count];
    for (&group, &s) in guides.groups.iter().zip(&guides.surfaces) {
        let g = group as usize;
        flat[g] &= *first[g].get_or_insert(s) == s;
    }
    // Each texel's largest turn to a neighbour of its group, then per group.
    let turn = |i: usize| {
        let (p, n, group) = (guides.points[i], guides.surfaces[i], guides.groups[i]);
        if flat[group as usize] {
            return 0.0;
        }
        let reach = 1.5 * guides.spacing[i];
        let mut turn = 0.0f32;
        fine.visit(p, reach, |j| {
            let j = j as usize;
            if guides.groups[j] == group && p.distance(guides.points[j]) <= reach {
                turn = turn.max(1.0 - n.dot(guides.surfaces[j]));
            }
        });
        turn
    };
    let each: Vec<f32> = (0..guides.points.len()).into_par_iter().map(turn).collect();
    let mut turns = vec![Vec::new(); count];
    for (&group, turn) in guides.groups.iter().zip(each) {
        turns[group as usize].push(turn);
    }
    let bends = |turns: &mut Vec<f32>| {
        let middle = turns.len() / 2;
        !turns.is_empty() && *turns.select_nth_unstable_by(middle, f32::total_cmp).1 > BENDS
    };
    (mapped.into_iter().zip(turns.iter_mut()))
        .map(|(mapped, turns)| match (mapped, bends(turns)) {
            (_, true) => Normals::Bends,
            (true, false) => Normals::Mapped,
            (false, false) => Normals::Plane,
        })
        .collect()
}

/// A normal's offset from `centre` in the frame (t1, t2).
pub(super) fn offset(normal: Vec3, centre: Vec3, (t1, t2): (Vec3, Vec3)) -> [f32; 2] {
    let d = normal - centre;
    [d.dot(t1), d.dot(t2)]
}

/// Whether the offsets spread enough to fit.
pub(super) fn varies(offsets: &[[f32; 2]]) -> bool {
    offsets
        .iter()
        .any(|[a, b]| a.abs() >= SPREAD || b.abs() >= SPREAD)
}

/// What [`fit_kernel`] forms for each cluster.
#[derive(Default)]
pub(super) struct Fits {
    /// Each entry's normal offset ([`offset`]).
    offsets: Vec<[f32; 2]>,
    /// The fits' buffers, first-order and quadratic in the normal.
    first_order: Scratch<LINEAR>,
    second_order: Scratch<QUADRATIC>,
    /// The guide's fit in [`reweigh`]: per four coefficients, each term's coefficients.
    beta: Vec<[Vec4; QUADRATIC]>,
    /// Per coefficient of the guide, four to a lane: the two fits' difference at the
    /// centroid.
    delta: Vec<Vec4>,
}

/// A cluster's kernel entries (k, [w, u, v]), their weights without the range term, and where
/// the fit in the normal writes its normal terms.
pub(super) type Kernel<'a> = (
    &'a mut [(u32, [f32; 3])],
    &'a [(f32, f32)],
    &'a mut Vec<[f32; NORMAL]>,
);

/// Turns a cluster's kernel (entries (k, [w, u, v]), with `geometric` their weights without
/// the range term as (e, s) for s · exp(e)) into the weights of the fit in the plane and the
/// normal, the normal's terms into the kernel's third part ([`NORMAL`] each, 0 past the
/// fit's): a first fit, its entries weighed again by their distance from it ([`reweigh`]),
/// and the fit of those weights. `normal(k)` is cluster k's mean shading normal; `centre` the
/// cluster's own and its tangent frame. The fit is in the normal's squares and product too
/// where `quadratic`; elsewhere that fit is blended into the first-order one by Lepski's
/// rule at [`QUADRATIC_FROM`]. Returns how many terms in the normal the fit has, or `None`
/// (the kernel untouched) where the normals do not vary or a fit is singular.
pub(super) fn fit_kernel<'g>(
    (kernel, geometric, fitted_normal): Kernel,
    scratch: &mut Fits,
    normal: impl Fn(u32) -> Vec3,
    (centre, frame): (Vec3, (Vec3, Vec3)),
    guide: impl Fn(u32) -> (&'g [Vec4], f32) + Copy,
    (noise, sw, kappa, quadratic): (f32, usize, f32, bool),
) -> Option<usize> {
    let Fits {
        offsets,
        first_order,
        second_order,
        beta,
        delta,
    } = scratch;
    offsets.clear();
    offsets.extend(
        kernel
            .iter()
            .map(|&(k, _)| offset(normal(k), centre, frame)),
    );
    if !varies(offsets) {
        return None;
    }
    let settings = (noise, sw, kappa);
    let entries = (&kernel[..], geometric, &offsets[..]);
    let share = match quadratic {
        true => match fit_in(entries, second_order, guide, settings, beta) {
            true => 1.0,
            false => return None,
        },
        false => {
            if !fit_in(entries, first_order, guide, settings, beta) {
                return None;
            }
            match quadratic_on(first_order, entries, second_order) {
                // The quadratic fit's other weights are formed only where it counts.
                Some(l) => {
                    let quadratic = (&second_order.terms[..], &second_order.weight[..]);
                    let centre = super::texel_fit::at_centre(&l, quadratic);
                    let differences =
                        (first_order.fitted.iter().zip(centre)).map(|(a, b)| a[0] - b);
                    let keys = (&first_order.key[..], differences);
                    let share =
                        super::texel_fit::share_of_second(keys, sw, guide, delta, QUADRATIC_FROM);
                    if share > 0.0 {
                        super::texel_fit::fill(&l, second_order);
                    }
                    share
                }
                None => 0.0,
            }
        }
    };
    // Each entry's weights on the fit's terms, the two fits blended by the share: one row
    // at a time, in registers.
    fitted_normal.clear();
    for (n, (_, e)) in kernel.iter_mut().enumerate() {
        let linear = |t: usize| first_order.fitted[n].get(t).copied().unwrap_or(0.0);
        let row: [f64; QUADRATIC] = match share {
            0.0 => std::array::from_fn(linear),
            1.0 => second_order.fitted[n],
            _ => {
                let quadratic = &second_order.fitted[n];
                std::array::from_fn(|t| quadratic[t] * share + linear(t) * (1.0 - share))
            }
        };
        *e = std::array::from_fn(|t| row[t] as f32);
        fitted_normal.push(std::array::from_fn(|t| row[3 + t] as f32));
    }
    Some(match share > 0.0 {
        true => QUADRATIC - 3,
        false => LINEAR - 3,
    })
}

/// The quadratic fit of a cluster's kernel entries with the first-order fit's robust
/// weights, `first`'s: its entries weighed again by their distance from
/// the first-order fit, which band 2's curve over a normal map's bumps leaves within the
/// range term's reach. Its own first fit and reweighing would cost as much again: on the
/// courtyard at 64 rays the filter took 0.85 CPU-s instead of 0.74, for 0.918 / 1.531 /
/// 0.526 % against 0.917 / 1.530 / 0.526 %. Returns the fit's Cholesky factor, its weights
/// not yet formed ([`super::texel_fit::factor_fit`]), or None where it is singular.
fn quadratic_on(
    first: &Scratch<LINEAR>,
    (kernel, _, offsets): Entries,
    fit: &mut Scratch<QUADRATIC>,
) -> Option<[[f64; QUADRATIC]; QUADRATIC]> {
    fit.clear();
    fit.key.extend_from_slice(&first.key);
    fit.weight.extend_from_slice(&first.weight);
    fit.terms.extend(
        (kernel.iter().zip(offsets))
            .map(|(&(_, [_, u, v]), &o)| terms(u, v, normal_terms(o, true))),
    );
    super::texel_fit::factor_fit(fit, &ridges::<QUADRATIC>())
}

/// A cluster's kernel entries, their weights without the range term, and their normal
/// offsets.
type Entries<'a> = (&'a [Entry], &'a [(f32, f32)], &'a [[f32; 2]]);

/// The fit with `N` terms ([`LINEAR`] or [`QUADRATIC`]) of a cluster's kernel entries, their
/// weights without the range term and their normal offsets, into `fit.fitted`: a first fit,
/// its entries weighed again by their distance from it, and the fit of those weights.
/// Returns false where a fit is singular.
fn fit_in<'g, const N: usize>(
    (kernel, geometric, offsets): Entries,
    fit: &mut Scratch<N>,
    guide: impl Fn(u32) -> (&'g [Vec4], f32) + Copy,
    settings: (f32, usize, f32),
    beta: &mut Vec<[Vec4; QUADRATIC]>,
) -> bool {
    let quadratic = N == QUADRATIC;
    let ridges = ridges::<N>();
    fit.clear();
    fit.extend(
        (kernel.iter().zip(offsets.iter()))
            .map(|(&(k, [w, u, v]), &o)| (k, w, terms(u, v, normal_terms(o, quadratic)))),
    );
    if !super::texel_fit::fit(fit, &ridges) {
        return false;
    }
    reweigh(fit, geometric, guide, settings, beta);
    super::texel_fit::fit(fit, &ridges)
}

/// A fit's `N` terms at (u, v) and a normal's terms: 1, u, v, then the normal's.
fn terms<const N: usize>(u: f32, v: f32, normal: [f32; NORMAL]) -> [f64; N] {
    std::array::from_fn(|t| match t {
        0 => 1.0,
        1 => f64::from(u),
        2 => f64::from(v),
        _ => f64::from(normal[t - 3]),
    })
}

/// Weighs each entry again by its guide's distance from the first fit's guide at its place
/// and normal: a neighbour whose guide differs by the bumps the fit follows is kept, one
/// across a shadow's edge is cut (one step of iteratively reweighted local regression, as the
/// vertices' robust range term: [`super::vertices::reweigh`]). `geometric[k]` is entry k's
/// weight without the range term as (e, s) for s · exp(e).
pub(super) fn reweigh<'g, const N: usize>(
    fit: &mut Scratch<N>,
    geometric: &[(f32, f32)],
    guide: impl Fn(u32) -> (&'g [Vec4], f32),
    (noise, sw, kappa): (f32, usize, f32),
    beta: &mut Vec<[Vec4; QUADRATIC]>,
) {
    // The guide's fit: per four coefficients of the guide, its terms' coefficients (the
    // first N of each).
    beta.clear();
    beta.resize(super::range::guide_lanes(sw), [Vec4::ZERO; QUADRATIC]);
    for (&k, e) in fit.key.iter().zip(&fit.fitted) {
        let e = e.map(|e| e as f32);
        for (b, &g) in beta.iter_mut().zip(guide(k).0) {
            for (b, &e) in b.iter_mut().zip(&e) {
                *b += g * e;
            }
        }
    }
    let entries = fit.weight.iter_mut().zip(&fit.terms);
    for (((w, x), &k), &(e, _)) in entries.zip(&fit.key).zip(geometric) {
        let x = x.map(|x| x as f32);
        let (g, their_noise) = guide(k);
        let mut squared = Vec4::ZERO;
        for (b, &g) in beta.iter().zip(g) {
            let predicted = b.iter().zip(&x).fold(Vec4::ZERO, |p, (b, &x)| p + *b * x);
            let r = g - predicted;
            squared += r * r;
        }
        let variance = (noise + their_noise) * sw as f32;
        let range = super::range::range_term(squared.element_sum(), variance, kappa);
        // The exponent, for now: the exponentials are taken four at a time below.
        *w = f64::from(e - range);
    }
    // Each weight s · exp(e − range), in vector registers.
    exp4::scaled(
        &mut fit.weight,
        geometric,
        |&w| w as f32,
        |w, x| *w = f64::from(x),
    );
}

#[cfg(test)]
mod tests {
    use super::super::texel_fit::fit;
    use super::*;

    /// A value linear in place and normal offset is reproduced exactly at every member's
    /// (u, v, a, b), and the weights sum to 1.
    #[test]
    fn a_transfer_linear_in_the_normal_is_kept() {
        let mut kernel = Vec::new();
        let mut offsets = Vec::new();
        for i in 0..40u32 {
            let (u, v) = ((i % 7) as f32 - 3.0, (i / 7) as f32 - 3.0);
            let (a, b) = (
                ((i * 37) % 11) as f32 * 0.03 - 0.15,
                ((i * 17) % 5) as f32 * 0.04,
            );
            kernel.push((i, [1.0 + 0.1 * (i % 3) as f32, u, v]));
            offsets.push([a, b]);
        }
        let value = |u: f32, v: f32, a: f32, b: f32| 0.5 + 0.1 * u - 0.05 * v + 2.0 * a - 1.5 * b;
        let values: Vec<f32> = kernel
            .iter()
            .zip(&offsets)
            .map(|(&(_, [_, u, v]), &[a, b])| value(u, v, a, b))
            .collect();
        assert!(varies(&offsets));
        let mut scratch = Scratch::<LINEAR>::default();
        scratch.extend(
            kernel
                .iter()
                .zip(&offsets)
                .map(|(&(k, [w, u, v]), &[a, b])| (k, w, [1.0, u, v, a, b].map(f64::from))),
        );
        let ridges = ridges::<LINEAR>();
        assert!(fit(&mut scratch, &ridges));
        for (u, v, a, b) in [(0.0, 0.0, 0.0, 0.0), (1.0, -0.5, 0.1, 0.05)] {
            let place = [1.0, u, v, a, b];
            let weight = |n: usize| {
                let e = scratch.fitted[n];
                (0..LINEAR).map(|t| e[t] * f64::from(place[t])).sum::<f64>() as f32
            };
            let total: f32 = (0..kernel.len()).map(weight).sum();
            let fitted: f32 = (0..kernel.len()).map(|n| weight(n) * values[n]).sum();
            assert!((total - 1.0).abs() < 1e-4, "weights sum to {total}");
            // The ridges shrink the slopes a little.
            let want = value(u, v, a, b);
            assert!((fitted - want).abs() < 0.02, "{fitted} against {want}");
        }
    }

    /// A transfer that curves in the normal, as band 2 does: read at a member tilted to the
    /// corner of its neighbours' normals, the quadratic fit follows it and the first-order
    /// one misses by many times as much. Where the settings have the first-order fit, the
    /// quadratic one is blended in where their difference is far beyond the noise, and kept
    /// out where it is within.
    #[test]
    fn the_quadratic_fit_follows_a_transfer_that_curves_in_the_normal() {
        let (mut normals, mut entries) = (Vec::new(), Vec::new());
        for i in 0..49u32 {
            let (u, v) = ((i % 7) as f32 - 3.0, (i / 7) as f32 - 3.0);
            let a = ((i * 37) % 11) as f32 * 0.03 - 0.15;
            let b = ((i * 17) % 7) as f32 * 0.05 - 0.15;
            // In the frame (x, y) about z, this normal's offset is (a, b) exactly.
            normals.push(Vec3::new(a, b, 1.0));
            entries.push((i, [1.0f32, u, v]));
        }
        let value =
            |[a, b]: [f32; 2]| 0.5 + 2.0 * a - 1.5 * b + 8.0 * a * a - 5.0 * a * b + 6.0 * b * b;
        let guides: Vec<[Vec4; 1]> = (normals.iter())
            .map(|n| [Vec4::new(value([n.x, n.y]), 0.0, 0.0, 0.0)])
            .collect();
        let geometric = vec![(0.0f32, 1.0f32); entries.len()];
        let error = |quadratic: bool, noise: f32| {
            let (mut kernel, mut terms, mut fits) = (entries.clone(), Vec::new(), Fits::default());
            let count = fit_kernel(
                (&mut kernel, &geometric, &mut terms),
                &mut fits,
                |k| normals[k as usize],
                (Vec3::Z, (Vec3::X, Vec3::Y)),
                |k| (&guides[k as usize][..], noise),
                (noise, 1, 4.0, quadratic),
            )
            .expect("the normals vary");
            // At the centre's place, tilted to (0.15, 0.15).
            let tilt = normal_terms([0.15, 0.15], true);
            let weight = |(&(_, [e, ..]), n): (&(u32, [f32; 3]), &[f32; NORMAL])| {
                e + n.iter().zip(&tilt).map(|(n, t)| n * t).sum::<f32>()
            };
            let total: f32 = kernel.iter().zip(&terms).map(weight).sum();
            assert!((total - 1.0).abs() < 1e-3, "weights sum to {total}");
            let read: f32 = (kernel.iter().zip(&terms))
                .map(|entry| weight(entry) * guides[entry.0.0 as usize][0].x)
                .sum();
            ((read - value([0.15, 0.15])).abs(), count)
        };
        let (quadratic, count) = error(true, 1e-4);
        assert!(quadratic < 0.01, "the quadratic fit misses by {quadratic}");
        assert_eq!(count, QUADRATIC - 3);
        let (blended, count) = error(false, 1e-4);
        assert_eq!(count, QUADRATIC - 3, "not blended in");
        assert!(blended < 0.01, "the blended fit misses by {blended}");
        let (linear, count) = error(false, 1e3);
        assert_eq!(count, LINEAR - 3, "blended in at a high noise");
        assert!(
            linear > 5.0 * quadratic,
            "first-order {linear}, quadratic {quadratic}"
        );
    }

    /// Neighbours whose guide differs from the centre's by the normal map's bumps, several
    /// noise deviations apart but on the fit, get their geometric weight back from the range
    /// term that compared them with the centre; those across a step, off the fit, stay cut.
    #[test]
    fn the_reweighing_keeps_the_bumps_and_cuts_a_step() {
        let (noise, kappa) = (1e-4f32, 4.0f32);
        let mut scratch = Scratch::<LINEAR>::default();
        let (mut guides, mut geometric) = (Vec::new(), Vec::new());
        let offsets = |i: u32| {
            let a = ((i * 37) % 11) as f32 * 0.02 - 0.1;
            (a, ((i * 17) % 5) as f32 * 0.02 - 0.04)
        };
        let centre = 24;
        for i in 0..49u32 {
            let (u, v) = ((i % 7) as f32 - 3.0, (i / 7) as f32 - 3.0);
            let (a, b) = offsets(i);
            // The last column a step down.
            let step = if u >= 3.0 { -0.5 } else { 0.0 };
            guides.push([Vec4::new(0.5 + a - b + step, 0.0, 0.0, 0.0)]);
            geometric.push((-0.1 * (u * u + v * v), 1.0f32));
        }
        for i in 0..49u32 {
            let (u, v) = ((i % 7) as f32 - 3.0, (i / 7) as f32 - 3.0);
            let (a, b) = offsets(i);
            let d = guides[i as usize][0].x - guides[centre][0].x;
            let range = crate::bake::denoise::range::range_term(d * d, 2.0 * noise, kappa);
            let w = (geometric[i as usize].0 - range).exp();
            scratch.extend(std::iter::once((i, w, [1.0, u, v, a, b].map(f64::from))));
        }
        let before = scratch.weight.clone();
        let guide = |k: u32| (&guides[k as usize][..], noise);
        assert!(fit(&mut scratch, &ridges::<LINEAR>()));
        reweigh(
            &mut scratch,
            &geometric,
            guide,
            (noise, 1, kappa),
            &mut Vec::new(),
        );
        let (mut bumps_before, mut bumps_after) = (0.0, 0.0);
        for (k, &w) in scratch.weight.iter().enumerate() {
            let full = f64::from(geometric[k].0.exp());
            if k % 7 == 6 {
                assert!(
                    w < 1e-3 * full,
                    "entry {k} across the step keeps {w} of {full}"
                );
            } else {
                bumps_before += before[k] / full;
                bumps_after += w / full;
            }
        }
        assert!(
            bumps_after > 0.9 * 42.0,
            "the bumps keep {bumps_after} of 42"
        );
        assert!(
            bumps_before < 0.7 * 42.0,
            "the range term kept {bumps_before} of 42"
        );
    }
}
