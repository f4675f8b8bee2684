//! Texels within a few texels of another surface are fitted in their distance to it too: a
//! first-order fit in (u, v, c), c = (1 − d / [`REACH`])² for d the distance in texels to the
//! closest texel of another surface, where it changes over the kernel.
//!
//! Where an object stands on a floor, the floor's transfer bends around its foot: a contact
//! shadow's ring around a crate's corner, the line where a bush's two cards cross. A fit over
//! the plane is unbiased where the transfer changes linearly along the surface, not around a
//! ring, and the range term cannot keep a change smaller than the noise of bands 0 to 2. The
//! distance to the other surface is known before a ray is cast, so it is a feature as the
//! normal is over a normal map ([`super::normal_fit`]): a regressor the fit follows, as
//! feature-based regression filters follow their feature buffers (Moon, Carr & Yoon 2014).
//!
//! A regressor costs noise where it removes no bias (the Cornell room's corners, whose plane
//! fit was unbiased already: 2–3 % more error at 64 rays). So the fit in the contact term
//! counts, by Lepski's rule as the curved fit does ([`texel_fit::share_of_second`]), only
//! where it differs from the plane's fit on the guide by more than that difference's noise.
//!
//! Texels with a contact term share a cluster only with texels as far from the same surface
//! ([`Contacts::joinable`]): around a crate's foot the transfer bends with the distance to it
//! faster than over a cluster's 3 texels, and a cluster's members share its kernel and its
//! fits' choices, but along the foot it hardly changes. Each such texel a cluster of its own,
//! with the curved fit ([`texel_fit::blend_curved`]), took the courtyard at 64 rays from
//! 0.957 / 1.601 / 0.560 % to 0.918 / 1.531 / 0.526 %, for 1.6 × the filter's time; joined
//! along the foot and blending the fits within half a step ([`super::blend`]), the error is
//! the same for 0.88 × the instructions ([`JOIN_WITHIN`]; at 256², 1–3 % more). They are
//! most of the terrain's filter time (58 % of its texels, by its folds): there, joined at any
//! distance to a fold, they took 0.64 × the time for 2.26 / 2.64 / 1.82 % against 2.14 /
//! 2.52 / 1.67 % (only those beyond 1.7 spacings, 2.24 %); their kernels 0.75 × as wide,
//! 0.86 × for 2.18 % (the courtyard 0.94 ×, 0.3–0.9 % worse); joined along the fold, 0.90 ×
//! the instructions for 1.3–1.9 % less error.
//!
//! Measured at 64 rays against 16,384, sun and sky / low sun / sky, 2 seeds: the production
//! courtyard 1.057 / 1.737 / 0.612 % -> **1.010 / 1.673 / 0.583 %** (at 256 rays 0.537 /
//! 0.877 / 0.305 -> 0.520 / 0.855 / 0.294 %); the Cornell room within 0.5 %. Without the rule,
//! the courtyard 1.019 / 1.679 / 0.578 % and the room 2–3 % worse; the contact term linear in
//! d, 1.039 %; a reach of 2, 4 or 8 texels, 1.019, 1.011 and 1.033 % (without the rule);
//! (1 − d / 3) and its square as two regressors, no better than one. Finding the terms takes
//! 30 ms of the courtyard's filter on one thread.
//!
//! Another object standing on a texel's surface is a wall between the texels on its two
//! sides: they see it from opposite sides, and under a low sun one side lies in its shadow.
//! A texel in contact with another object's or material's surface reads no neighbour across
//! that surface's plane ([`Contacts::separator`]), as no light may cross a thin wall.
//! Measured against 16,384 rays, sun and sky / low sun / sky: the courtyard at 256 rays
//! 0.464 / 0.763 / 0.269 % -> 0.463 / 0.761 / 0.267 % (seed 2: 0.474 / 0.774 / 0.273 ->
//! 0.473 / 0.771 / 0.270 %), at 64 rays within 0.3 %; the Cornell room at 64 rays 0.926 /
//! 0.725 / 0.610 -> 0.925 / 0.725 / 0.607 %. Not across a crease of one surface: a terrain's
//! folds are no wall (its error rose 2–4 % with them). Nor in the guide's prefilter (the
//! courtyard 0.465 / 0.765 / 0.268 % with it).

use std::sync::Arc;

use glam::{Vec3, Vec4};

use super::clusters::Clusters;
use super::grid::Grid;
use super::guides::Guides;
use super::texel_fit::{self, CURVED, Entry, PLANE, PLANE_RIDGES, Scratch};

/// How far another surface counts, in the texel's spacings.
pub(super) const REACH: f32 = 3.0;
/// The fit's ridge on the contact term, relative to the kernel's mass, as on the plane's
/// slopes: at 10⁻³ the courtyard gained 1 % more and the Cornell room lost 3 %.
const RIDGES: [f64; PLANE + 1] = [PLANE_RIDGES[0], PLANE_RIDGES[1], PLANE_RIDGES[2], 1e-2];
/// The squared difference of the plane's fit and the fit in the contact term on the guide,
/// over its noise variance, from which the contact term counts and at which its fit is
/// taken whole (measured with a fit half as wide blended into both, since replaced by the
/// curved fit: docs/explanation/denoising-record.md).
const CONTACT_FROM: (f64, f64) = (2.5, 10.0);
/// A texel of the same object and material is another surface where its surface normal turns
/// from the texel's by more than this cosine (a crease of one mesh, about 45°).
const CREASE: f32 = 0.7;
/// Another surface lies at least this many spacings off the texel's plane: a texel of the
/// floor beside it is not in contact.
const OFF_PLANE: f32 = 0.5;
/// A grid cell is flat where every member's surface normal lies within this cosine of its
/// first member's.
const FLAT: f32 = 0.999;

/// Texels whose contact term is above this, within [`REACH`] of another surface, are in
/// contact ([`Contacts::in_contact`]). When each was a cluster of its own, on the courtyard at
/// 64 rays: above 0, 0.918 %; above 0.1 (within 2 texels), 0.931 % for 0.85 × the filter's
/// time; above 0.3, 0.957 %.
const CONTACT_ABOVE: f32 = 0.0;

/// Texels in contact share a cluster only where their contact terms lie within this of each
/// other, beside the same other surface ([`Contacts::joinable`]): a row of texels along a
/// crate's foot, not a ring about its corner. The courtyard at 64 rays, sun and sky / low sun
/// / sky, 4 seeds, and the instructions of the one-shard part's merge, which runs the stage
/// (callgrind): each texel a cluster of its own, 0.867 / 1.435 / 0.500 %, 5.65 G; within
/// 0.01 and their fits blended over half a step ([`super::blend`]), 0.867 / 1.451 / 0.502 %,
/// 5.00 G; seeds 1–2 against within 0.01: equal terms, 1.0–1.4 % less error (low sun 0.6 %)
/// for 1.2 × the instructions; within 0.02, 0.2–0.7 % more for 0.98 ×; within 0.01 but not
/// blended, 1–1.6 % more for 0.94 ×. The Cornell room's error falls by up to 2.4 %, the
/// terrain's by 1.3–1.9 %.
const JOIN_WITHIN: f32 = 0.01;

/// How far off a separating plane, in the texel's spacings, the texel and a neighbour must
/// lie for the plane to part them ([`Contacts::separator`]): a texel on the plane (under a
/// wall standing on a texel centre) has no side, and a neighbour cluster's centroid on it is
/// on neither. 0 and 1 gave the courtyard's 256-ray bake 0.462 / 0.762 / 0.266 % and 0.466
/// / 0.762 / 0.269 %.
const SIDE_MARGIN: f32 = 0.25;

/// Each receiver's contact term ([`terms`]) and, where the closest other surface is another
/// object's or material's, that surface's plane there.
#[derive(Clone, Default)]
pub(super) struct Contacts {
    /// Each receiver's contact term; empty where the filter has none.
    pub terms: Arc<[f32]>,
    /// (receiver, plane) in receiver order: the other surface's unit normal m in xyz and
    /// −m · q in w, q its closest texel, so that plane · (x, 1) is x's distance from it.
    planes: Arc<[(u32, Vec4)]>,
}

impl Contacts {
    /// Whether receiver i lies within [`REACH`] of another surface.
    pub(super) fn in_contact(&self, i: usize) -> bool {
        self.terms.get(i).is_some_and(|&c| c > CONTACT_ABOVE)
    }

    /// Whether receivers a and b may share a cluster by their contact: neither in contact,
    /// or both, at about the same distance ([`JOIN_WITHIN`]) from the same other surface's
    /// plane (or both from a crease of their own surface), a's spacing `spacing`. A
    /// cluster's members share its kernel, its range term and its fits' choices, and the
    /// wide pass reads their mean at their centroid: around another surface's foot the
    /// transfer bends with the distance to it faster than over a cluster's 3 texels, but
    /// hardly along it.
    pub(super) fn joinable(&self, (a, b): (usize, usize), spacing: f32) -> bool {
        match (self.in_contact(a), self.in_contact(b)) {
            (false, false) => return true,
            (true, true) => {}
            _ => return false,
        }
        if (self.terms[a] - self.terms[b]).abs() > JOIN_WITHIN {
            return false;
        }
        match (self.plane(a), self.plane(b)) {
            (None, None) => true,
            (Some(pa), Some(pb)) => {
                let parallel = pa.truncate().dot(pb.truncate()) > FLAT;
                parallel && (pa.w - pb.w).abs() < SIDE_MARGIN * spacing
            }
            _ => false,
        }
    }

    /// The plane of the other object that receiver i stands beside, its unit normal in xyz
    /// and its offset in w; `None` where it has none.
    fn plane(&self, i: usize) -> Option<Vec4> {
        let at = self.planes.binary_search_by_key(&(i as u32), |&(r, _)| r);
        Some(self.planes[at.ok()?].1)
    }

    /// The plane of the other object that receiver i, at `p` with `spacing`, stands beside,
    /// scaled so that `plane · (x, 1)` is a point's distance from it in i's spacings on i's
    /// side (negative across it); `None` where i has none or lies on it.
    pub(super) fn separator(&self, i: usize, p: Vec3, spacing: f32) -> Option<Vec4> {
        let plane = self.plane(i)? / spacing;
        let side = plane.dot(p.extend(1.0));
        (side.abs() > SIDE_MARGIN).then(|| plane * side.signum())
    }

    /// Whether a point whose distance from a [`Contacts::separator`] plane is `side` (of
    /// `plane · (x, 1)`) lies across it.
    pub(super) fn across(side: f32) -> bool {
        side < -SIDE_MARGIN
    }
}

/// The contact term of a distance `d`, in spacings: 1 at contact, 0 from [`REACH`] on, with
/// no kink there.
pub(super) fn term(d: f32) -> f32 {
    let x = (1.0 - d / REACH).max(0.0);
    x * x
}

/// Each receiver's contact term, from the closest receiver of another surface within
/// [`REACH`] of its spacings: of another group (object and material), or of its own across a
/// crease, and off its plane. `grid` holds every receiver. A function of the guides alone, the
/// same for every lattice, thread and shard.
pub(super) fn terms(guides: &Guides, grid: &Grid) -> Contacts {
    use rayon::prelude::*;
    // Most cells hold a few flat surfaces (a floor and its back face), and most of a cell's
    // neighbours hold the same: none of them another surface to the cell's texels (of their
    // group and turned by well under a crease, or parallel and within half a spacing of
    // their plane). Each flat surface of a cell finds, once for all its texels, the
    // neighbour cells that may hold another surface; a texel reads only those cells' texels.
    let cells: Vec<&[u32]> = grid.cell_members().collect();
    let kinds: Vec<Option<Vec<Kind>>> = cells.iter().map(|m| kinds(guides, m)).collect();
    let boxes: Vec<(Vec3, Vec3)> = (cells.iter())
        .map(|m| {
            let points = m.iter().map(|&j| guides.points[j as usize]);
            points.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p), hi.max(p))
            })
        })
        .collect();
    let searched = (&cells[..], &kinds[..], &boxes[..]);
    let per_cell: Vec<Vec<(u32, Closest)>> = (0..cells.len())
        .into_par_iter()
        .map_init(Vec::new, |near: &mut Vec<usize>, c| {
            let mut out = Vec::with_capacity(cells[c].len());
            let Some(own) = &kinds[c] else {
                for &i in cells[c] {
                    let (p, reach) = (
                        guides.points[i as usize],
                        REACH * guides.spacing[i as usize],
                    );
                    near.clear();
                    grid.visit_cells(p, reach, |n, _| near.push(n));
                    let far = 3f32.sqrt() * (reach + grid.cell());
                    out.push((i, closest(guides, searched, (i as usize, far), near)));
                }
                return out;
            };
            for kind in own {
                let members = || {
                    cells[c]
                        .iter()
                        .filter(|&&i| guides.groups[i as usize] == kind.group)
                };
                let (mut low, mut high) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
                let (mut widest, mut finest) = (0.0f32, f32::INFINITY);
                for &i in members() {
                    let (p, spacing) = (guides.points[i as usize], guides.spacing[i as usize]);
                    (low, high) = (low.min(p), high.max(p));
                    (widest, finest) = (widest.max(spacing), finest.min(spacing));
                }
                let centre = 0.5 * (low + high);
                let radius = 0.5 * (high - low).max_element() + REACH * widest;
                // How far a member of a cell the cube about centre overlaps can lie from it.
                let far = 3f32.sqrt() * (radius + grid.cell());
                let bounds = (centre, far, finest);
                near.clear();
                grid.visit_cells(centre, radius, |n, _| {
                    if !kinds[n]
                        .as_ref()
                        .is_some_and(|k| k.iter().all(|k| apart(kind, k, bounds)))
                    {
                        near.push(n);
                    }
                });
                for &i in members() {
                    let term = match near.is_empty() {
                        true => Closest::default(),
                        false => closest(guides, searched, (i as usize, 2.0 * far), near),
                    };
                    out.push((i, term));
                }
            }
            out
        })
        .collect();
    let mut terms = vec![0.0; guides.points.len()];
    let mut planes = Vec::new();
    for (i, closest) in per_cell.into_iter().flatten() {
        terms[i as usize] = closest.term;
        planes.extend(closest.plane.map(|plane| (i, plane)));
    }
    planes.sort_unstable_by_key(|&(i, _)| i);
    Contacts {
        terms: terms.into(),
        planes: planes.into(),
    }
}

/// A receiver's contact term and, where its closest other surface is of another group, that
/// surface's plane ([`Contacts`]).
#[derive(Default)]
struct Closest {
    term: f32,
    plane: Option<Vec4>,
}

/// What [`closest`] reads of the grid's cells: each one's members, [`Kind`]s (`None` where
/// they are not flat) and members' bounding box.
type Searched<'a> = (&'a [&'a [u32]], &'a [Option<Vec<Kind>>], &'a [(Vec3, Vec3)]);

/// Receiver i's contact term from the receivers of cells `near` (a superset of the cells
/// within its reach, whose members lie within `far` of it), each cell skipped where each of
/// its [`Kind`]s is no other surface to i, or where its members' bounding box lies no closer
/// than the closest other surface found so far.
fn closest(
    guides: &Guides,
    (cells, kinds, boxes): Searched,
    (i, far): (usize, f32),
    near: &[usize],
) -> Closest {
    let (p, s, spacing, group) = (
        guides.points[i],
        guides.surfaces[i],
        guides.spacing[i],
        guides.groups[i],
    );
    // The texel as a surface of its own, to test each cell's surfaces against.
    let at = s.dot(p);
    let texel = Kind {
        group,
        axis: s,
        tilt: 0.0,
        low: at,
        high: at,
    };
    let ignored = |kind: &Kind| apart(&texel, kind, (p, far, spacing));
    let (mut closest, mut nearest) = (f32::INFINITY, None);
    for &cell in near {
        if kinds[cell].as_ref().is_some_and(|k| k.iter().all(ignored)) {
            continue;
        }
        // No member lies closer than the box: each of its offsets from p is at least as
        // long, axis by axis, and a length is monotonic in them, in floats too, so the
        // members passed over would not have been taken (the same result, bit for bit).
        let (low, high) = boxes[cell];
        if (p.clamp(low, high) - p).length() >= closest {
            continue;
        }
        for &j in cells[cell] {
            let j = j as usize;
            let other = guides.groups[j] != group || guides.surfaces[j].dot(s) <= CREASE;
            let d = guides.points[j] - p;
            if other && s.dot(d).abs() >= OFF_PLANE * spacing && d.length() < closest {
                closest = d.length();
                nearest = Some(j);
            }
        }
    }
    let term = term(closest / spacing);
    // Another group's surface parts the texels on its sides; a crease of the texel's own
    // surface does not.
    let plane = nearest
        .filter(|&j| term > 0.0 && guides.groups[j] != group)
        .map(|j| guides.surfaces[j].extend(-guides.surfaces[j].dot(guides.points[j])));
    Closest { term, plane }
}
/// Whether no member of the flat surface `other` is another surface to any member of `own`,
/// all of whose members lie within `far` of `centre`, as do `other`'s, the closest `spacing`
/// apart: of `own`'s group and turned by well under a crease from it, or parallel to it and
/// within half a spacing of its members' planes.
fn apart(own: &Kind, other: &Kind, (centre, far, spacing): (Vec3, f32, f32)) -> bool {
    let facing = own.axis.dot(other.axis);
    // Each member's normal lies within acos(FLAT) of its surface's axis.
    if other.group == own.group && facing >= (CREASE.acos() - 2.0 * FLAT.acos()).cos() {
        return true;
    }
    // Along own's axis, other's members lie where their own axis puts them, give or take its
    // turn from own's, over their distance from the centre.
    let turn = (2.0 - 2.0 * facing.abs()).max(0.0).sqrt();
    let at = other.axis.dot(centre);
    let (low, high) = match facing >= 0.0 {
        true => (other.low - at, other.high - at),
        false => (at - other.high, at - other.low),
    };
    let centre = own.axis.dot(centre);
    let (low, high) = (centre + low - turn * far, centre + high + turn * far);
    // A member's distance from another's plane, its normal within `tilt` of own's axis.
    let off = (high - own.low).max(own.high - low);
    off + own.tilt * 2.0 * far < (OFF_PLANE - MARGIN) * spacing
}

/// Slack on [`OFF_PLANE`] for a cell's members read from its [`Kind`]s, against rounding.
const MARGIN: f32 = 1e-2;
/// The most surfaces a cell is summed up by.
const KINDS: usize = 4;

/// A flat surface of one group within a grid cell: its axis (its first member's surface
/// normal, every member's within [`FLAT`]) and the range of its members' distances along it.
struct Kind {
    group: u32,
    axis: Vec3,
    /// The farthest member's normal from the axis, |n − axis|.
    tilt: f32,
    low: f32,
    high: f32,
}

/// A cell's `members` as up to [`KINDS`] flat surfaces, one per group; `None` where they are
/// not.
fn kinds(guides: &Guides, members: &[u32]) -> Option<Vec<Kind>> {
    let mut kinds: Vec<Kind> = Vec::new();
    for &j in members {
        let j = j as usize;
        let (group, normal) = (guides.groups[j], guides.surfaces[j]);
        let at = match kinds.iter().position(|k| k.group == group) {
            Some(at) => at,
            None if kinds.len() < KINDS => {
                let along = normal.dot(guides.points[j]);
                kinds.push(Kind {
                    group,
                    axis: normal,
                    tilt: 0.0,
                    low: along,
                    high: along,
                });
                kinds.len() - 1
            }
            None => return None,
        };
        let kind = &mut kinds[at];
        let facing = normal.dot(kind.axis);
        if facing < FLAT {
            return None;
        }
        kind.tilt = kind.tilt.max((2.0 - 2.0 * facing).max(0.0).sqrt());
        let along = kind.axis.dot(guides.points[j]);
        (kind.low, kind.high) = (kind.low.min(along), kind.high.max(along));
    }
    Some(kinds)
}

/// Each cluster's contact term: its members' weighted mean.
pub(super) fn cluster_terms(clusters: &Clusters, terms: &[f32]) -> Vec<f32> {
    (0..clusters.reps.len())
        .map(|c| {
            let row = clusters.row(c);
            let (sum, mass) = row.iter().fold((0.0, 0.0), |(s, t), &(m, w)| {
                (s + terms[m as usize] * w, t + w)
            });
            sum / mass
        })
        .collect()
}

/// A cluster's fit in the contact term.
#[derive(Default)]
pub(super) struct Fits {
    contact: Scratch<{ PLANE + 1 }>,
    /// Per coefficient of the guide, four to a lane: the two fits' difference at the
    /// centroid.
    delta: Vec<Vec4>,
}

/// Blends the fit in (u, v, c) of a cluster's kernel entries (k, [w, u, v]) into the fit
/// over the plane, `current` (each entry's weights on the terms of [`CURVED`], the plane's
/// fit on the first three), where its neighbours' contact terms differ from its own:
/// `offset(k)`, neighbour k's term less the cluster's. The fit in the contact term counts by
/// how far it departs from the plane's on the guide. Returns whether it counts (else
/// `current` is as it was).
pub(super) fn blend<'g>(
    (entries, current): (&[Entry], &mut [[f64; CURVED]]),
    fits: &mut Fits,
    offset: impl Fn(u32) -> f32,
    sw: usize,
    guide: impl Fn(u32) -> (&'g [Vec4], f32) + Copy,
) -> bool {
    if entries.iter().all(|&(k, _)| offset(k) == 0.0) {
        return false;
    }
    let Fits { contact, delta } = fits;
    contact.clear();
    contact.extend(entries.iter().map(|&(k, [w, u, v])| {
        let x = [1.0, f64::from(u), f64::from(v), f64::from(offset(k))];
        (k, w, x)
    }));
    let Some(l) = texel_fit::factor_fit(contact, &RIDGES) else {
        return false;
    };
    // Lepski's rule, as for the curved fit: the contact term counts where the two fits of
    // the guide at the centroid differ by more than their difference's noise. The fit's
    // other weights are formed only where it counts.
    let centre = texel_fit::at_centre(&l, (&contact.terms, &contact.weight));
    let differences = current.iter().zip(centre).map(|(b, a)| b[0] - a);
    let keys = (&contact.key[..], differences);
    let share = texel_fit::share_of_second(keys, sw, guide, delta, CONTACT_FROM);
    if share <= 0.0 {
        return false;
    }
    texel_fit::fill(&l, contact);
    for (e, a) in current.iter_mut().zip(&contact.fitted) {
        for t in 0..PLANE {
            e[t] = a[t] * share + e[t] * (1.0 - share);
        }
        e[PLANE] = a[PLANE] * share;
    }
    true
}

#[cfg(test)]
mod tests {

    use super::*;

    /// A floor of 0.1-unit texels with its back face in place (another group, facing down)
    /// and a wall standing on it at x = 0: a floor texel's term is (1 − d/3)² of its distance
    /// in texels to the wall's closest texel, the back face is no other surface, and the terms
    /// are the same for any grid.
    #[test]
    fn a_texel_s_term_is_its_distance_to_another_surface() {
        let mut guides = Guides::default();
        let mut add = |at: Vec3, surface: Vec3, group: u32| {
            guides.points.push(at);
            guides.normals.push(surface);
            guides.surfaces.push(surface);
            guides.groups.push(group);
            guides.spacing.push(0.1);
        };
        for x in 1..=20 {
            for y in -5..=5 {
                let at = Vec3::new(x as f32 * 0.1, y as f32 * 0.1, 0.0);
                add(at, Vec3::Z, 0);
                add(at, -Vec3::Z, 1);
            }
        }
        for z in 1..=10 {
            for y in -5..=5 {
                add(Vec3::new(0.0, y as f32 * 0.1, z as f32 * 0.1), Vec3::X, 2);
            }
        }
        for cell in [0.3, 0.07, 1.0] {
            let contacts = terms(&guides, &Grid::new(&guides.points, cell));
            for (i, &t) in contacts.terms.iter().enumerate() {
                let p = guides.points[i];
                let expected = match guides.groups[i] {
                    // The wall's closest texel to a floor texel is at z = 0.1.
                    0 | 1 => term((p.x * p.x + 0.01).sqrt() / 0.1),
                    // The floor's texels from x = 0.1 on, off the wall's plane by 1 texel.
                    _ => term((p.z * p.z + 0.01).sqrt() / 0.1),
                };
                assert!(
                    (t - expected).abs() < 1e-5,
                    "{p} of group {}: {t}",
                    guides.groups[i]
                );
            }
        }
    }

    /// Entries on a 15 × 15 grid whose guide bends with the contact term (c³, the term
    /// falling towards a wall along u): with a noise far below the fits' difference the fit in
    /// the contact term is blended in and reads the centre closer where the plane's misses;
    /// with a noise far above it the plane's fit is kept, to the bit.
    #[test]
    fn the_fit_follows_a_transfer_that_bends_with_the_contact_term() {
        let radius = 7.0f32;
        let mut entries = Vec::new();
        let mut contact = Vec::new();
        // The wall at u = −3: no entries beyond it.
        for x in -2..=7 {
            for y in -7..=7 {
                let (u, v) = (x as f32, y as f32);
                if u * u + v * v <= radius * radius {
                    let w = (-2.0 * (u * u + v * v) / (radius * radius)).exp();
                    entries.push((entries.len() as u32, [w, u, v]));
                    contact.push(term(u + 3.0));
                }
            }
        }
        let centre = term(3.0);
        let value = |c: f32| 0.3 + 2.0 * c * c * c;
        let guides: Vec<[Vec4; 1]> = (contact.iter())
            .map(|&c| [Vec4::new(value(c), 0.0, 0.0, 0.0)])
            .collect();
        let read_at_centre = |weights: &[[f64; CURVED]]| -> f32 {
            (entries.iter().zip(weights))
                .map(|(&(k, _), e)| e[0] as f32 * guides[k as usize][0].x)
                .sum()
        };
        let read = |noise: f32| {
            let guide = |k: u32| (&guides[k as usize][..], noise);
            let mut plane = Scratch::<PLANE>::default();
            plane
                .extend((entries.iter()).map(|&(k, [w, u, v])| (k, w, [1.0, u, v].map(f64::from))));
            assert!(texel_fit::fit(&mut plane, &PLANE_RIDGES));
            let plane: Vec<[f64; CURVED]> = (plane.fitted.iter())
                .map(|f| std::array::from_fn(|t| f.get(t).copied().unwrap_or(0.0)))
                .collect();
            let mut current = plane.clone();
            let offset = |k: u32| contact[k as usize] - centre;
            let blended = blend(
                (&entries, &mut current),
                &mut Fits::default(),
                offset,
                1,
                guide,
            );
            (blended, plane, current)
        };
        let (blended, plane, quiet) = read(1e-8);
        assert!(blended, "no contact term at a low noise");
        let (blended, kept, noisy) = read(1e3);
        assert!(!blended, "a contact term at a high noise");
        assert_eq!(kept, noisy);
        let quiet = read_at_centre(&quiet) - value(centre);
        let missed = read_at_centre(&plane) - value(centre);
        // 0.011 against 0.040.
        assert!(
            quiet.abs() < 0.35 * missed.abs(),
            "in the contact term {quiet}, in the plane {missed}"
        );
    }
}
