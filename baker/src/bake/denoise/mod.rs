//! Denoised transfer: a linear filter over the baked receivers whose weights every
//! coefficient of every channel shares, so it commutes with relighting. T̃_i = Σ_j w_ij T_j
//! gives T̃_i · L = Σ_j w_ij (T_j · L) for every light L: the filter is run once, at bake
//! time, and every light, rig and rotation at run time sees a denoised picture for free. A
//! denoiser of lit images (OIDN, OptiX, Godot's JNLM) has to run again for each light.
//!
//! # The method
//!
//! A cross-bilateral filter in world space with a variance-normalised range term, the
//! family of joint non-local means (Buades et al. 2005; Rousselle, Knaus & Zwicker 2012,
//! *Adaptive rendering with non-local means filtering*; Rousselle, Manzi & Zwicker 2013,
//! *Robust denoising using feature and color information*) with SVGF's idea of a prefiltered
//! guide and its filtered variance (Schied et al. 2017). Receiver i's weight on receiver j
//! multiplies:
//!
//! * a Gaussian of their **world distance**, within `radius` receiver spacings (texels, or
//!   the mesh's local vertex spacing) found in a grid over the receivers' points, not in
//!   the atlas: charts that meet at a seam share neighbours, charts that merely sit side by
//!   side in the atlas never mix;
//! * the **shading normals'** agreement, (n_i · n_j)^32 (normal-mapped texels use their mapped
//!   normal; where the fit is in the normal, the wide pass takes n_i · n_j itself), and 0 for
//!   normals facing apart;
//! * the **plane distance** of j from i's surface, |s_i · (p_j − p_i)|, in spacings: a thin
//!   wall's other side, a step or a slab lying on a floor are off i's plane;
//! * the same **object and material**;
//! * the **range term**: how far apart their transfer is against how far apart noise alone
//!   would put it. The guide is the transfer's bands 0 to 2 prefiltered over 1.5 spacings
//!   with the terms above, its variance Σ w² σ²_j from each receiver's own estimate
//!   ([`crate::bake::noise`]: the spread of its rays' runs). With d² the squared guide
//!   difference over that variance, the weight is exp(−max(0, d² − 1)/κ²): noise is
//!   smoothed, a real shadow edge or contact shadow, many σ deep, is kept. Transfer
//!   matrices estimate it for their first row's bands 0 to 2, their signal. Where the rays
//!   give no estimate (the vertices whose subsurface walks replaced their transfer), the
//!   variance is half the median of the squared differences to the closest neighbours
//!   ([`Filter::new`]).
//!
//! The wide pass (7 texel spacings, about 150 texels) does not weigh every texel: it weighs
//! **clusters** of up to 3 × 3 like texels ([`clusters`]), each at its members' centroid,
//! with its representative's normals, group and guide, and its members' mean, as an à-trous
//! pass reads a coarser level (Dammertz et al. 2010, *Edge-avoiding À-Trous wavelet
//! transform*; SVGF), and forms one kernel per cluster, which each member evaluates at its
//! own place. The clusters within reach are found in one grid per group
//! ([`grid::GroupedGrid`]), of cells sized to that group's own texels. Every texel counts
//! once; the wide pass costs a sixth. A cluster of 3 or more
//! is its own guide, its members' mean (of variance Σ w² σ²), as SVGF's coarser levels read
//! the level below: they are alike by construction, so their mean is about as steady as the
//! prefilter over 1.5 spacings, and costs nothing more; only the representatives of smaller
//! clusters (a shadow's edge, a chart's corner) are prefiltered.
//!
//! A member at its cluster's edge reads a fit made about a centroid a texel or two away, and
//! its neighbour across the seam another cluster's: where the transfer bends (a contact
//! shadow's ring, the line where two cards cross) the lattice of clusters shows in the
//! result, as a bias every seed repeats. So each texel **blends the fits about it**
//! ([`blend`]): its own cluster's and its like neighbours', each read at its place and
//! weighed by a tent in its distance from their centroids, as the guided filter averages
//! the models of every window that holds a pixel. The answer is continuous across the
//! seams, and the neighbours' kernels average more noise away: on the courtyard at 64 rays
//! it gives the error of two lattices of clusters half a cluster apart (cycle spinning,
//! which it replaced) in four fifths of their time (docs/explanation/denoising-record.md).
//!
//! Vertices (vertex bakes, transfer
//! matrices, subsurface vertices) gather into clusters of like neighbours around seeds, each
//! within its own spacings ([`vertex_clusters`]), with a second-order fit over 9 spacings
//! ([`vertices`]): a mesh's curves are too close for a first-order fit. Their range term is
//! robust: a neighbour's guide is compared with a first fit of the neighbourhood at its
//! place, not with the vertex's own guide, which on a curved mesh differs by the curve.
//!
//! The kernel weights then become those of a weighted first-order fit over i's tangent plane
//! (local regression: Moon, Carr & Yoon 2014), evaluated at i ([`Filter::row`]): a constant
//! kernel biases every gradient (towards a contact shadow, over a chart's last texels, where
//! the neighbours lie on one side), the fit does not. Its weights may go negative and cost a
//! little noise; on the Cornell room at 128² it takes a 64-ray bake's error from 3.5 % to
//! 1.9 % (docs/explanation/denoising-record.md). Where the transfer curves over the kernel, a
//! fit in the plane's squares is blended in by Lepski's rule ([`texel_fit`]); over a normal
//! map or a surface that bends within texels the fit is in the normal too ([`normal_fit`]),
//! and its normal term is the cosine itself, not its 32nd power; over a
//! normal map the unoccluded lobe is taken out before and put back after ([`demodulate`]); near
//! another surface, in the distance to it, in clusters of texels as far from it, which read
//! nothing across another object standing beside it ([`contact`]).
//!
//! The weights sum to 1, so a constant transfer is kept exactly. They are a pure function of
//! the guides and the bake's transfer, formed receiver by receiver over neighbours in a fixed
//! order: the result is bit-identical for any number of threads.

mod apply;
mod blend;
mod cholesky;
mod clipped_lobe;
mod clusters;
mod contact;
mod demodulate;
mod exp4;
mod grid;
pub mod guides;
mod lanes;
mod normal_fit;
mod prefilter;
mod range;
mod settings;
pub mod stage;
mod texel_fit;
mod texel_kernel;
mod vertex_apply;
mod vertex_clusters;
mod vertices;

use clusters::Clusters;
pub use guides::{Guides, texel_guides, vertex_guides};
use normal_fit::{NORMAL_SQUARINGS, power_of_two};
use range::{range_exponent, range_term, squared_difference};
pub use settings::{FINE_CLUSTERS_FROM, SHARP_FROM_ORDER, Settings};

/// Coefficients per channel the range term compares: bands 0 to 2 (band 2 tells a sun's
/// shadow edges apart better than bands 0 and 1 alone: 0.58 -> 0.55 % at 256 rays on the
/// Cornell room).
const SIGNAL_COEFFICIENTS: usize = 9;
/// κ of the guide's prefilter, on the raw signal: more tolerant than the filter's own, as
/// the raw signal is noisier than the guide.
const GUIDE_KAPPA: f32 = 3.0;
/// How far apart two texels' raw signals may be to share a cluster, as the range term's
/// exponent at κ = [`GUIDE_KAPPA`]: d² up to 3.25, what noise alone gives but for 1 pair in
/// 1,000. At 0 (d² ≤ 1) the clusters split twice as often: the filter costs 2 ×, for 1.5 %
/// of a 64-ray bake's error. Looser, the courtyard's 64-ray filter takes 0.88 × the
/// instructions at 0.5 and 0.83 × at 1.0, for 1–2 % and 3–4 % more error.
const SIMILAR: f32 = 0.25;
/// The wide pass's grid cells, in radii: each group's cells are half its reach across, at
/// its median spacing.
const WIDE_CELL: f32 = 0.5;
/// The least members a cluster needs to be its own guide ([`Filter::new`]).
const GUIDE_MASS: f32 = 3.0;

/// What the wide pass reads of one cluster.
struct Tap {
    /// The members' weighted centroid.
    at: glam::Vec3,
    /// The representative's shading normal.
    normal: glam::Vec3,
    /// How many receivers the cluster stands for.
    mass: f32,
    /// The representative's guide's variance.
    noise: f32,
    /// The guide's row in [`Filter::tap_guide`].
    guide: u32,
}

/// The weights of one bake's receivers, ready to apply to any per-receiver values.
pub struct Filter<'g> {
    guides: &'g Guides,
    settings: Settings,
    /// The prefilter's grid over every receiver.
    fine: grid::Grid,
    /// The wide pass's grids over the clusters, one per group (cluster indices).
    wide: grid::GroupedGrid,
    /// Built cell by cell, the fine grid's cells in the order of their first receiver: a
    /// cluster's neighbours are numbered close to it, and the wide pass reads their data,
    /// and writes its members' values, about in sequence.
    clusters: Clusters,
    /// What the wide pass reads of each cluster, in cluster order.
    taps: Vec<Tap>,
    /// Each cluster's mean of the signal, `signal_width` floats per cluster in cluster
    /// order, then the prefiltered guides of the clusters too small to be their own guide
    /// ([`Tap::guide`] is a cluster's row).
    tap_guide: Vec<f32>,
    /// The rows of `tap_guide` in vector registers' lanes, zero-padded to
    /// [`range::guide_lanes`] of them: what the kernels' fits read.
    tap_lanes: Vec<glam::Vec4>,
    /// Each receiver's cluster.
    cluster_of: Vec<u32>,
    /// Each cluster's tangent frame (its representative's plane): the fit's axes.
    frames: Vec<(glam::Vec3, glam::Vec3)>,
    /// Texels of groups fitted in the normal: each cluster's members' mean shading normal,
    /// where [`normal_fit`] reads the cluster's normal (empty otherwise).
    tap_normals: Vec<glam::Vec3>,
    /// Texels: per group (object and material), whether its clusters try [`normal_fit`].
    normal_groups: Vec<normal_fit::Normals>,
    /// Texels ([`Settings::contact`]): each receiver's contact term and each cluster's, which
    /// the fits of groups fitted over the plane read, and the planes that part texels in
    /// contact from their neighbours ([`contact`]); empty otherwise.
    contact: contact::Contacts,
    tap_contact: Vec<f32>,
    /// Each cluster's [`Filter::cluster_separator`] (empty where there are no contact terms).
    separators: Vec<Option<glam::Vec4>>,
    signal_width: usize,
    /// Whether `tap_guide`'s first rows, the clusters' means, are those of the transfer the
    /// filter was formed for (its signal is the whole transfer, up to order 3): the means
    /// [`Filter::apply_to_transfer`] would otherwise form again.
    transfer_means: bool,
    /// Texels over a normal map: which receivers' lobes the transfer's filter takes out and
    /// puts back ([`demodulate`]).
    demodulation: Option<demodulate::Demodulation>,
}

impl<'g> Filter<'g> {
    /// The filter of `guides`'s receivers for `transfer`, `width` floats per receiver in
    /// `channels` blocks of `per_channel` (n² for vectors, n⁴ for matrices: the first
    /// coefficients of each block are the range term's signal).
    pub fn new(
        guides: &'g Guides,
        settings: Settings,
        transfer: &[f32],
        channels: usize,
        per_channel: usize,
    ) -> Filter<'g> {
        let count = guides.points.len();
        let used = per_channel.min(SIGNAL_COEFFICIENTS);
        let width = channels * per_channel;
        let signal_width = channels * used;
        let mut spacings: Vec<f32> = guides.spacing.clone();
        let typical = match spacings.is_empty() {
            true => 1.0,
            false => *spacings.select_nth_unstable_by(count / 2, f32::total_cmp).1,
        }
        .max(1e-12);
        // Cells a cluster across (`step` typical spacings), which the clustering walks and
        // the prefilter reads; with no clusters, as wide as the prefilter's reach.
        let cell = settings.step.unwrap_or(settings.guide_radius) * typical;
        // Texels in clusters: what the contact term is for.
        let texels = settings.step.is_some() && !settings.quadratic;
        let fine = grid::Grid::new(&guides.points, cell);
        // Texels: how each group is fitted.
        let normals = match settings.quadratic {
            true => Vec::new(),
            false => normal_fit::groups(guides, &fine),
        };
        let contact = match texels && settings.contact {
            true => contact::terms(guides, &fine),
            false => contact::Contacts::default(),
        };
        // Over a normal map, the transfer less each texel's unoccluded lobe.
        let demodulation = match texels {
            true => demodulate::Demodulation::new(guides, &normals, per_channel),
            false => None,
        };
        // Up to order 3 the signal is the whole transfer: read in place, not copied, but
        // where it is demodulated.
        let signal: std::borrow::Cow<[f32]> = match (used == per_channel, &demodulation) {
            (true, None) => std::borrow::Cow::Borrowed(&transfer[..count * width]),
            _ => {
                let mut signal = Vec::with_capacity(count * signal_width);
                let mut scratch = demodulate::Scratch::default();
                for (i, receiver) in transfer.chunks_exact(width.max(1)).take(count).enumerate() {
                    let start = signal.len();
                    for block in receiver.chunks_exact(per_channel.max(1)) {
                        signal.extend_from_slice(&block[..used]);
                    }
                    if let Some(d) = &demodulation {
                        let values = (&mut signal[start..], used);
                        d.shift_receiver(guides, i, values, &mut scratch, -1.0);
                    }
                }
                std::borrow::Cow::Owned(signal)
            }
        };
        let input = (&signal[..], signal_width, used == per_channel);
        let mut filter = Filter::on_lattice(guides, settings, input, fine, (contact, normals));
        filter.demodulation = demodulation;
        filter
    }

    /// [`Filter::new`] on one lattice of clusters, the cells of `fine`, for the range term's
    /// `signal`, `signal_width` floats per receiver, which is the whole transfer where
    /// `whole`, with each receiver's `contact` term (empty where not fitted in) and each
    /// group's way of fitting its `normals` (empty for vertices).
    fn on_lattice(
        guides: &'g Guides,
        settings: Settings,
        (signal, signal_width, whole): (&[f32], usize, bool),
        fine: grid::Grid,
        (contact, normals): (contact::Contacts, Vec<normal_fit::Normals>),
    ) -> Filter<'g> {
        let count = guides.points.len();
        let mut filter = Filter {
            guides,
            settings,
            wide: grid::GroupedGrid::new(&[], &[], &[], 1.0),
            fine,
            clusters: Clusters::singletons(&[]),
            taps: Vec::new(),
            tap_guide: Vec::new(),
            tap_lanes: Vec::new(),
            cluster_of: Vec::new(),
            frames: Vec::new(),
            tap_normals: Vec::new(),
            normal_groups: normals,
            contact,
            tap_contact: Vec::new(),
            separators: Vec::new(),
            signal_width,
            transfer_means: false,
            demodulation: None,
        };
        let from_rays = guides.noise.iter().any(|&v| v > 0.0);
        let noise: std::borrow::Cow<[f32]> = match (from_rays, settings.quadratic) {
            (true, true) => {
                vertices::fill_noise(&guides.noise, || filter.noise_from_signal(signal)).into()
            }
            (true, false) => std::borrow::Cow::Borrowed(&guides.noise),
            (false, _) => filter.noise_from_signal(signal).into(),
        };
        if !from_rays && settings.quadratic {
            filter.settings.kappa *= vertices::NEIGHBOUR_KAPPA;
        }
        let sw = signal_width;
        let (clusters, mut means) = match settings.step {
            // Every receiver its own cluster, its guide prefiltered.
            None => {
                let clusters = Clusters {
                    points: guides.points.clone(),
                    ..Clusters::singletons(&noise)
                };
                (clusters, Vec::new())
            }
            // Vertices gather around seeds, each within its own spacings.
            Some(step) if settings.quadratic => {
                vertex_clusters::build(guides, &filter.fine, step, &noise, (signal, sw))
            }
            Some(step) => {
                let within = (signal, sw);
                // Texels in contact with another surface join only each other, at the same
                // distance from the same surface.
                let contact = &filter.contact;
                Clusters::build(guides, &filter.fine, step, &noise, within, |seed, m| {
                    if !contact.joinable((seed, m), guides.spacing[seed]) {
                        return false;
                    }
                    let variance = (noise[m] + noise[seed]) * sw as f32;
                    let (s, g) = (&signal[m * sw..][..sw], &signal[seed * sw..][..sw]);
                    range_exponent(s, g, variance, GUIDE_KAPPA) <= SIMILAR
                })
            }
        };
        // A cluster of at least GUIDE_MASS like texels is its own guide: its members'
        // mean, of variance Σ w² σ² (the members are alike by construction, so the mean is
        // the prefilter's answer at a fraction of its cost). Smaller clusters (a shadow's
        // edge, a chart's corner) and every vertex prefilter their representative, into
        // rows after the means: the guides and the means share one buffer, no row copied.
        let own_guide = |k: usize| settings.step.is_some() && clusters.mass[k] >= GUIDE_MASS;
        let prefiltered: Vec<u32> = (0..clusters.reps.len())
            .filter(|&k| !own_guide(k))
            .map(|k| clusters.reps[k])
            .collect();
        let first = means.len() / sw.max(1);
        means.resize(means.len() + prefiltered.len() * sw, 0.0);
        let mut guide_noise = vec![0.0f32; prefiltered.len()];
        filter.prefilter(
            signal,
            &noise,
            &prefiltered,
            (&mut means[first * sw..], &mut guide_noise),
        );
        let (rep_groups, rep_spacing): (Vec<u32>, Vec<f32>) = clusters
            .reps
            .iter()
            .map(|&r| (guides.groups[r as usize], guides.spacing[r as usize]))
            .unzip();
        filter.wide = grid::GroupedGrid::new(
            &clusters.points,
            &rep_groups,
            &rep_spacing,
            WIDE_CELL * settings.radius,
        );
        let mut next = first;
        filter.taps = Vec::with_capacity(clusters.reps.len());
        for k in 0..clusters.reps.len() {
            let (guide, noise) = match own_guide(k) {
                true => (k, clusters.noise[k]),
                false => {
                    next += 1;
                    (next - 1, guide_noise[next - 1 - first])
                }
            };
            filter.taps.push(Tap {
                at: clusters.points[k],
                normal: guides.normals[clusters.reps[k] as usize],
                mass: clusters.mass[k],
                noise,
                guide: guide as u32,
            });
        }
        // Up to order 3 the signal is the transfer: its clusters' means are the ones
        // `apply_to_transfer` reads.
        filter.transfer_means = whole && first == clusters.reps.len();
        filter.tap_lanes = range::to_lanes(&means, signal_width);
        filter.tap_guide = means;
        filter.frames = clusters
            .reps
            .iter()
            .map(|&r| guides.surfaces[r as usize].any_orthonormal_pair())
            .collect();
        // The clusters' mean normals, which only a fit in the normal reads.
        if (filter.normal_groups.iter()).any(|&n| n != normal_fit::Normals::Plane) {
            filter.tap_normals = (0..clusters.reps.len())
                .map(|c| {
                    let sum = clusters.row(c).iter().fold(glam::Vec3::ZERO, |s, &(m, w)| {
                        s + guides.normals[m as usize] * w
                    });
                    sum.normalize_or(guides.normals[clusters.reps[c] as usize])
                })
                .collect();
        }
        if !filter.contact.terms.is_empty() {
            filter.tap_contact = contact::cluster_terms(&clusters, &filter.contact.terms);
        }
        filter.cluster_of = vec![0; count];
        for c in 0..clusters.reps.len() {
            for &(m, _) in clusters.row(c) {
                filter.cluster_of[m as usize] = c as u32;
            }
        }
        filter.clusters = clusters;
        if !filter.contact.terms.is_empty() {
            filter.separators = filter.cluster_separators();
        }
        filter
    }

    /// Whether the texels of `group` are fitted in the normal too ([`normal_fit`]): over a
    /// normal map, or a surface that bends within a few texels. Vertices never are.
    fn fitted_in_normal(&self, group: u32) -> bool {
        (self.normal_groups.get(group as usize)).is_some_and(|&n| n != normal_fit::Normals::Plane)
    }

    /// Receiver i's weight on j, taken to lie `at` (its own point, or its cluster's): the
    /// geometric terms times exp(−`range`), 0 outside `radius` spacings. `range` (the range
    /// term's exponent) is asked only of neighbours the geometric terms keep, and the terms
    /// share one exponential.
    #[inline(always)]
    fn weight(
        &self,
        i: usize,
        (j, at): (usize, glam::Vec3),
        radius: f32,
        range: impl Fn(usize) -> f32,
    ) -> f32 {
        let g = self.guides;
        if g.groups[i] != g.groups[j] {
            return 0.0;
        }
        let d = at - g.points[i];
        let reach = radius * g.spacing[i];
        let r2 = d.length_squared() / (reach * reach);
        if r2 > 1.0 {
            return 0.0;
        }
        let facing = g.normals[i].dot(g.normals[j]);
        if facing <= 0.0 {
            return 0.0;
        }
        let off_plane = g.surfaces[i].dot(d) / g.spacing[i];
        (-2.0 * r2 - off_plane * off_plane - range(j)).exp()
            * power_of_two(facing, NORMAL_SQUARINGS)
    }

    /// Receiver i's neighbours within `radius` spacings and their weights ([`Filter::weight`]),
    /// in the fine grid's fixed order of visit (a function of the points alone, so sums over
    /// them are the same on any thread).
    fn neighbours(
        &self,
        i: usize,
        radius: f32,
        out: &mut Vec<(u32, f32)>,
        range: impl Fn(usize) -> f32,
    ) {
        out.clear();
        let reach = radius * self.guides.spacing[i];
        self.fine.visit(self.guides.points[i], reach, |j| {
            let w = self.weight(
                i,
                (j as usize, self.guides.points[j as usize]),
                radius,
                &range,
            );
            if w > 0.0 {
                out.push((j, w));
            }
        });
    }

    /// Cluster c's kernel over the clusters, in the wide grid's fixed order of visit:
    /// entries (k, e_k) such that a member m's weight on cluster k is
    /// ŵ_k(m) = e_k · (1, u_m, v_m), with (u_m, v_m) the member's place about c's centroid
    /// ([`Filter::member_place`]). The kernel multiplies the terms of [`Filter::weight`] for
    /// c's representative (its normals, group, spacing and guide) placed at c's centroid;
    /// the clusters' data is read in sequence.
    ///
    /// With `linear`, the weights are those of a weighted first-order fit over the tangent
    /// plane evaluated at the member's place: e_k = w_k A⁻¹ x_k with x_k = (1, u_k, v_k) and
    /// A = Σ w_k x_k x_kᵀ. They sum to 1 at every place and are shared by every
    /// coefficient, and a transfer that changes linearly along the surface (towards a
    /// contact shadow, across a chart's last texels, where the neighbours lie on one side)
    /// is kept unbiased. Each member evaluates the fit at its own place, so a cluster's
    /// members differ as their neighbourhoods do, though their kernel is formed once.
    ///
    /// Vertices read their guides in vector lanes, weigh normals more mildly, keep each
    /// entry's taper and turn the kernel into a second-order fit's weights
    /// ([`vertices::fit`]). The kernel is formed in `scratch.kernel`.
    fn cluster_kernel(&self, c: usize, scratch: &mut vertices::Scratch) {
        let vertices = self.settings.quadratic;
        let (out, tapers) = (&mut scratch.kernel, &mut scratch.taper);
        out.clear();
        tapers.clear();
        scratch.geometric.clear();
        let g = self.guides;
        let (sw, lanes) = (self.signal_width, range::guide_lanes(self.signal_width));
        let (radius, kappa) = (self.settings.radius, self.settings.kappa);
        let r = self.clusters.reps[c] as usize;
        let own = self.taps[c].guide as usize;
        // The squared difference of the guide in row `row` from c's.
        let squared = |row: usize| {
            squared_difference(
                &self.tap_guide[own * sw..][..sw],
                &self.tap_guide[row * sw..][..sw],
            )
        };
        // Vertices' guides, in lanes.
        let own_lanes = match vertices {
            true => &self.tap_lanes[own * lanes..][..lanes],
            false => &[],
        };
        let pi = self.clusters.points[c];
        let (ni, si, group) = (g.normals[r], g.surfaces[r], g.groups[r]);
        // Fitted in the normal: over a normal map, or a surface that bends.
        let mapped = self.fitted_in_normal(group);
        let squarings = match (vertices, mapped) {
            (true, _) => vertices::NORMAL_SQUARINGS,
            (false, true) => normal_fit::FITTED_POWER,
            (false, false) => NORMAL_SQUARINGS,
        };
        let (spacing, noise) = (g.spacing[r], self.taps[c].noise);
        let reach = radius * spacing;
        let (t1, t2) = self.frames[c];
        let scale = 1.0 / spacing;
        // A texel beside another object reads nothing across its plane ([`contact`]).
        let separator = match vertices {
            true => None,
            false => self.cluster_separator(c),
        };
        let plane = separator.unwrap_or(glam::Vec4::ZERO);
        // The taps within reach, facing c and on its side, gathered first without a branch
        // per tap: which of a cell's taps lie within reach is hard to predict, and a
        // mispredicted branch cost more than the test. Each is kept as (k, [r², facing, 0]).
        self.wide.visit(group, pi, reach, |k| {
            let tap = &self.taps[k as usize];
            let r2 = (tap.at - pi).length_squared() / (reach * reach);
            let facing = ni.dot(tap.normal);
            let across = contact::Contacts::across(plane.dot(tap.at.extend(1.0)));
            out.push((k, [r2, facing, 0.0]));
            out.truncate(out.len() - usize::from((r2 > 1.0) | (facing <= 0.0) | across));
        });
        // Their weights, in place: entry `kept` is written after entry `kept` is read.
        let mut kept = 0;
        for at in 0..out.len() {
            let (k, [r2, facing, _]) = out[at];
            let tap = &self.taps[k as usize];
            let d = tap.at - pi;
            let off_plane = si.dot(d) / spacing;
            let variance = (noise + tap.noise) * sw as f32;
            let facing = power_of_two(facing, squarings);
            let w = match vertices {
                false => {
                    let range = range_term(squared(tap.guide as usize), variance, kappa);
                    let exponent = -2.0 * r2 - off_plane * off_plane;
                    // Over a normal map, every entry the geometric terms weigh is kept,
                    // with those terms: the robust range term weighs it again
                    // ([`normal_fit::reweigh`]).
                    if mapped && exponent < vertices::LN_NEGLIGIBLE {
                        continue;
                    }
                    // The exponentials are taken four at a time below.
                    scratch.geometric.push((exponent, facing * tap.mass));
                    exponent - range
                }
                // The geometric terms, and the range term on top, as exponents (taken four
                // at a time, [`vertices::weigh`]): vertices keep every entry the geometry
                // weighs, as their robust range term weighs them again.
                true => {
                    let exponent = -2.0 * r2 - off_plane * off_plane;
                    if exponent < vertices::LN_NEGLIGIBLE || facing < vertices::NEGLIGIBLE {
                        continue;
                    }
                    let row = tap.guide as usize;
                    let theirs = &self.tap_lanes[row * lanes..][..lanes];
                    let squared = vertices::squared_distance(own_lanes, theirs);
                    let range = range_term(squared, variance, kappa);
                    tapers.push([r2, 0.0]);
                    scratch.geometric.push((exponent, facing * tap.mass));
                    exponent - range
                }
            };
            // With the tap's place in c's tangent plane, in spacings: the fit's (u, v).
            let place = d * scale;
            out[kept] = (k, [w, place.dot(t1), place.dot(t2)]);
            kept += 1;
        }
        out.truncate(kept);
        // Texels: each entry's weight exp(exponent) · normal term · mass, and only those
        // it keeps where no robust range term weighs them again.
        if !vertices {
            exp4::weigh(out, &scratch.geometric);
            if !mapped {
                // No robust range term reads the geometric terms here.
                out.retain(|&(_, [w, ..])| w > 0.0);
                scratch.geometric.clear();
            }
        }
        // Neighbour cluster k's guide, in lanes, and its variance.
        let guide = |k: u32| {
            let tap = &self.taps[k as usize];
            let row = tap.guide as usize;
            (&self.tap_lanes[row * lanes..][..lanes], tap.noise)
        };
        if vertices {
            vertices::weigh(scratch);
            vertices::gather(scratch, sw, &guide);
            vertices::reweigh(scratch, (sw, kappa, noise));
            return vertices::fit(scratch, sw);
        }
        scratch.extra.clear();
        scratch.extra_terms = 0;
        if !self.settings.linear {
            let total: f32 = out.iter().map(|&(_, w)| w[0]).sum();
            for (_, e) in out.iter_mut() {
                *e = [e[0] / total, 0.0, 0.0];
            }
            return;
        }
        // Where a normal map turns the shading normals, the fit is in the normal too;
        // elsewhere over the plane, and in the contact term and the plane's squares where
        // they follow the guide closer (not over a normal map, whose members read their
        // normal's terms: [`Filter::member_extra`]).
        let in_normal = mapped.then(|| {
            let normal = |k: u32| self.tap_normals[k as usize];
            let kernel = (&mut out[..], &scratch.geometric[..], &mut scratch.extra);
            let settings = (noise, sw, kappa, self.settings.normal_quadratic);
            let fits = &mut scratch.normal_fits;
            normal_fit::fit_kernel(kernel, fits, normal, (ni, (t1, t2)), guide, settings)
        });
        let own = self.tap_contact.get(c).copied().unwrap_or(0.0);
        let contact = |k: u32| match mapped {
            true => 0.0,
            false => self.tap_contact.get(k as usize).map_or(0.0, |&t| t - own),
        };
        let at = (sw, self.settings.curved && !mapped);
        let fits = &mut scratch.texel_fits;
        let count = in_normal.flatten().or_else(|| {
            texel_kernel::fit_kernel((&mut out[..], &mut scratch.extra), fits, contact, at, guide)
        });
        if let Some(count) = count {
            scratch.extra_terms = count;
            return;
        }
        let mass: f64 = out.iter().map(|&(_, e)| f64::from(e[0])).sum();
        for (_, e) in out.iter_mut() {
            *e = [(f64::from(e[0]) / mass) as f32, 0.0, 0.0];
        }
    }
}

#[cfg(test)]
mod tests;
