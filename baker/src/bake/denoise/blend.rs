//! Each texel's answer blended from the fits of the clusters about it: its own cluster's fit
//! and its neighbours', each read at the texel's place, weighed by a tent in the distance
//! from each centroid and by how closely the neighbour's fit of the signal agrees with its
//! own there.
//!
//! A member at its cluster's edge reads a fit made about a centroid a texel or two away, and
//! its neighbour across the cluster's seam reads another cluster's: where the transfer bends,
//! the lattice of clusters shows as a grid of lines that every seed repeats. Blending the fits
//! of every cluster within a step makes the answer continuous across the seams, as the
//! guided filter averages the linear models of every window that holds a pixel (He, Sun &
//! Tang 2013) and moving least squares blends local fits; the neighbours' kernels, centred
//! elsewhere, average more noise away too. A neighbour whose fit of the signal departs from
//! the cluster's own at the member by more than their noise (across a shadow's edge) counts
//! less, as the range term weighs a kernel's entries. It replaced cycle spinning over a
//! second lattice of clusters half a cluster across (Coifman & Donoho 1995), the mean of two
//! filters, which cost twice the kernels for the same error (docs/explanation/denoising-record.md).
//!
//! The shares depend on the geometry and the signal alone, never on the values filtered, so
//! the filter stays linear: every coefficient and channel shares them.

use super::contact::Contacts;
use super::{Filter, normal_fit};

/// A neighbour cluster's fit counts for a member within this many cluster steps of its
/// centroid, by a tent falling to 0 there. On the production courtyard at 64 rays (4 seeds,
/// sun and sky / low sun / sky): 1 step, 0.867 / 1.435 / 0.500 %; 0.5, 0.888 / 1.460 /
/// 0.514 %; two lattices, 0.864 / 1.422 / 0.502 %.
const REACH: f32 = 1.0;

/// The tent's reach, in cluster steps, about a cluster of texels in contact with another
/// surface ([`super::contact`]): the transfer bends faster there, and a neighbour's fit
/// read a step away departs from it. Measured with texels in contact joined where their
/// contact terms are equal within 0.01, on the courtyard at 64 rays, seeds 1–2: 0.5 step,
/// 0.869 / 1.428 / 0.502 % (seed 2: 0.853 / 1.466 / 0.495 %); a third of a step, within
/// 0.6 % of it; not blended, 0.883 / 1.445 / 0.506 %. A whole step, as every other cluster
/// (measured without the joins), left 0.4–0.8 % more error than half a step, for 1.13 × its
/// instructions.
const CONTACT_REACH: f32 = 0.5;

/// κ of the agreement between a neighbour's fit of the signal and the cluster's own at the
/// member: 1 to 4 give the courtyard the same error within 0.2 %, and from 2 a contact
/// shadow's bend without noise (tests.rs) is followed worse than on one lattice.
const AGREEMENT_KAPPA: f32 = 1.5;

/// The most terms a fit has: (1, u, v) and those past them.
pub(super) const TERMS: usize = 3 + normal_fit::NORMAL;

impl Filter<'_> {
    /// Cluster c's representative's [`Contacts::separator`] at c's centroid: the plane of
    /// another object standing beside it, which no fit or kernel entry of c's reads across.
    ///
    /// [`Contacts::separator`]: super::contact::Contacts::separator
    pub(super) fn cluster_separator(&self, c: usize) -> Option<glam::Vec4> {
        self.separators.get(c).copied().flatten()
    }

    /// Every cluster's [`Filter::cluster_separator`], formed once: each blend reads those of
    /// all its candidate neighbours, and each a search among the planes.
    pub(super) fn cluster_separators(&self) -> Vec<Option<glam::Vec4>> {
        let separator = |c: usize| {
            let r = self.clusters.reps[c] as usize;
            (self.contact).separator(r, self.clusters.points[c], self.guides.spacing[r])
        };
        (0..self.clusters.reps.len()).map(separator).collect()
    }

    /// The clusters whose fits cluster c's members blend, into `out`: c first, then, with
    /// [`Settings::blend`], every other cluster of its surface (the same group, normals
    /// within 25°, about on its plane, neither across the other's separating plane:
    /// [`Filter::cluster_separator`]) that one of its members lies within reach of.
    ///
    /// [`Settings::blend`]: super::Settings::blend
    pub(super) fn blend_neighbours(&self, c: usize, out: &mut Vec<u32>) {
        out.clear();
        out.push(c as u32);
        if !self.settings.blend {
            return;
        }
        let g = self.guides;
        let r = self.clusters.reps[c] as usize;
        let spacing = g.spacing[r];
        let pi = self.clusters.points[c];
        let farthest = (self.clusters.row(c).iter())
            .map(|&(m, _)| g.points[m as usize].distance(pi))
            .fold(0.0f32, f32::max);
        let reach = self.blend_width(c) + farthest;
        // Whether a separating plane parts point p from the cluster it is of.
        let parts = |plane: Option<glam::Vec4>, p: glam::Vec3| {
            plane.is_some_and(|plane| Contacts::across(plane.dot(p.extend(1.0))))
        };
        let own = self.cluster_separator(c);
        self.wide.visit(g.groups[r], pi, reach, |k| {
            let k = k as usize;
            let rk = self.clusters.reps[k] as usize;
            let d = self.taps[k].at - pi;
            let keep = k != c
                && d.length_squared() <= reach * reach
                && g.normals[r].dot(g.normals[rk]) > 0.9
                && g.surfaces[r].dot(g.surfaces[rk]) > 0.9
                && g.surfaces[r].dot(d).abs() < spacing
                && !parts(own, self.taps[k].at)
                && !parts(self.cluster_separator(k), pi);
            if keep {
                out.push(k as u32);
            }
        });
    }

    /// The tent's radius about cluster c's centroid: [`REACH`] steps of its spacing, or
    /// [`CONTACT_REACH`] in contact with another surface.
    fn blend_width(&self, c: usize) -> f32 {
        let r = self.clusters.reps[c] as usize;
        let steps = match self.contact.in_contact(r) {
            true => CONTACT_REACH,
            false => REACH,
        };
        steps * self.settings.step.unwrap_or(1.0) * self.guides.spacing[r]
    }

    /// Member m's tent over each fit of `near` (its cluster c's [`Filter::blend_neighbours`],
    /// c first), into `tents`: 1 at a centroid, 0 a [`REACH`] of steps from it (never 0 for
    /// c's own).
    pub(super) fn blend_tents(&self, (c, m): (usize, usize), near: &[u32], tents: &mut Vec<f32>) {
        let width = self.blend_width(c);
        let at = self.guides.points[m];
        tents.clear();
        tents.extend(near.iter().map(|&k| {
            let d = at.distance(self.clusters.points[k as usize]);
            (1.0 - d / width).max(0.0)
        }));
        // A member far from its own centroid still reads its own cluster's fit.
        tents[0] = tents[0].max(1e-3);
    }

    /// How much neighbour k's fit counts beside cluster c's at a member, from their fits of
    /// the signal there: the range term of their difference against their guides' noise.
    pub(super) fn agreement(&self, (c, k): (usize, usize), own: &[f32], theirs: &[f32]) -> f32 {
        let sw = self.signal_width;
        let squared: f32 = own.iter().zip(theirs).map(|(a, b)| (a - b) * (a - b)).sum();
        let variance = (self.taps[c].noise + self.taps[k].noise) * sw as f32;
        (-super::range_term(squared, variance, AGREEMENT_KAPPA)).exp()
    }

    /// Member m's terms in cluster k's fit, `terms` of them: its place about k's centroid,
    /// and those past it ([`Filter::member_extra`]); 0 past `terms`.
    pub(super) fn member_terms(&self, k: usize, m: usize, terms: usize) -> [f32; TERMS] {
        let place = self.member_place(k, m);
        let extra = match terms {
            3 => [0.0; normal_fit::NORMAL],
            _ => self.member_extra(k, m),
        };
        std::array::from_fn(|t| match t {
            0..3 => place[t],
            _ => extra[t - 3],
        })
    }
}

/// A fit read at a place of terms `p`, into `out`: `width` floats, then the scalar where
/// `out` has room for it. `sums` holds each of the fit's `terms` sums of the values, `width`
/// floats each, then (where the scalar is read) each term's sum of the scalars
/// ([`Filter::fit_sums`]).
pub(super) fn read_fit(
    sums: &[f32],
    (terms, width): (usize, usize),
    p: &[f32; TERMS],
    out: &mut [f32],
) {
    // Term by term, four floats at a time: the same products, summed in the same order, as
    // coefficient by coefficient.
    let (values, scalar) = out.split_at_mut(width);
    super::lanes::read_sums(sums, (terms, width), p, values);
    if let Some(scalar) = scalar.first_mut() {
        *scalar = (0..terms).map(|t| sums[terms * width + t] * p[t]).sum();
    }
}
