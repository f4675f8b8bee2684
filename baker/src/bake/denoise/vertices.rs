//! Vertex kernels (`Settings::VERTICES`): a weighted **second-order** fit over the tangent
//! plane, in place of the texels' first-order one, formed once per cluster of like vertices
//! ([`super::vertex_clusters`]) and evaluated by each member at its own place
//! ([`super::vertex_apply`]).
//!
//! A mesh is sparse beside a lightmap: the torus's floor has a vertex every 0.2 units, and
//! its contact shadow, the room's corners and the torus's own curvature change the transfer
//! within a few vertices. A first-order fit over 4 spacings blurs those curves (averaging 8
//! seeds' denoised bakes left a 0.9 % bias against the 1.2 % error of a raw bake with 8 × the
//! rays); a quadratic fit, 1, u, v, u², uv, v² (Cleveland & Devlin 1988, *Locally weighted
//! regression*; Moon, Carr & Yoon 2014 for rendering), is unbiased for a transfer curving
//! along the surface, so it can read neighbours twice as far away (9 spacings) and average
//! more noise away at a lower bias. Its weights are one set per vertex, shared by every
//! coefficient and channel, and sum to 1 at every member's place.
//!
//! The shading normals' term is milder than the texels' ((n_i · n_j)^8 against ^32): on a
//! smoothly curved mesh the fit, not the term, accounts for the normal's turn, and a strong
//! term leaves a curved surface's vertex only its closest neighbours. Normals facing apart
//! (a crease past 90°), the plane distance, the group and the range term cut as for texels.
//!
//! The range term is **robust** ([`reweigh`]): a neighbour is weighed by how far its guide lies
//! from a first quadratic fit of its neighbourhood, not from the vertex's own guide, which on a
//! curved mesh cut the neighbours the fit would follow and left the fit their noise.
//!
//! Where the transfer bends faster than a quadratic over 9 spacings (the floor under the
//! torus, a room's corner) fits a half and a quarter as wide are blended in, by how far the
//! fits of the guide differ against their difference's noise (Lepski's rule: [`fit`]).
//!
//! Measured on the torus at 64 rays, sun and sky / low sun / sky, against 16,384 rays:
//! first-order over 4 spacings 1.65 / 4.26 / 1.06 %, the second-order fit 1.49 / 4.07 / 0.91
//! %, with the narrower fit blended in 1.47 / 3.98 / 0.88 %; in clusters (1.5 vertices on
//! average) 1.46 / 3.98 / 0.88 %, for 0.74 × the filter's instructions; with joint strata
//! 1.29 / 3.51 / 0.80 %; with the robust range term, κ = 3 and the quarter-width fit 1.11 /
//! 2.84 / 0.69 % (a raw bake of 512 rays: 1.16 / 3.24 / 0.65 %), the filter's time 1.9 ×
//! (docs/explanation/denoising-record.md). The blend is judged once per cluster, at its centroid.

use glam::Vec4;

use super::cholesky;
use super::exp4::{self, exp4};
use super::range::{guide_lanes, range_term};

/// Terms of the fit: 1, u, v, u², uv, v².
pub(super) const TERMS: usize = 6;
/// The vertices' clusters' reach, in vertex spacings ([`super::clusters`]).
pub(super) const STEP: f32 = 2.5;
/// The power of the shading normals' dot product for vertices, 2³ = 8, as squarings.
pub(super) const NORMAL_SQUARINGS: u32 = 3;
/// The ridge on the slopes (and 4 × on the curvatures), times the kernel's mass: a
/// neighbourhood along a line (a strip one vertex wide, a mesh's border) fits no slope or
/// curvature across it.
const RIDGE: f64 = 1e-2;
/// κ's scale where every vertex's noise is estimated from its neighbours (transfer matrices
/// at order 2, whose range-term signal is not one row): that estimate
/// holds the transfer's true change between neighbours too, so it overstates the noise (on
/// the glossy torus at 64 rays, 2.60 % against 2.77 % at κ = 4, before the robust range
/// term). Matrices at other orders carry their rays' estimate ([`crate::bake::matrix`]) and
/// keep κ.
pub(super) const NEIGHBOUR_KAPPA: f32 = 0.75;

/// Per narrower fit, the squared difference of the guide's fits over its noise variance from
/// which it is blended in, and at which it is taken whole (Lepski's rule, [`fit`]). Measured
/// on the torus at 64 rays, 8 seeds, sun and sky / low sun / sky, the robust range term on:
/// one narrower fit at 8 / 32, 1.12 / 2.91 / 0.72 % (4 seeds); at 4 / 16, 1.11 / 2.88 /
/// 0.71 %; the quarter-width fit added at 6 / 24, 1.10 / 2.85 / 0.68 % (at 4 / 16, 1.11 /
/// 2.86 / 0.68 %).
const LEPSKI: [(f64, f64); 2] = [(4.0, 16.0), (6.0, 24.0)];

/// A thread's buffers for the clusters it filters, reused from one cluster to the next (no
/// cluster allocates): the kernel's entries, and what the fit keeps per neighbour.
#[derive(Default)]
pub(super) struct Scratch {
    /// Entries (k, [w_k, u_k, v_k]): neighbour cluster k's kernel weight and place in the
    /// cluster's tangent plane about its centroid, in spacings.
    pub kernel: Vec<(u32, [f32; 3])>,
    /// Each entry's weight without the range term ([`reweigh`] forms it again), as
    /// (e, s) for s · exp(e).
    pub geometric: Vec<(f32, f32)>,
    /// Each entry's tapers for the narrower fits ([`weigh`]).
    pub taper: Vec<[f32; 2]>,
    /// After [`fit`], each entry's weight as a function of the member's place: a member at
    /// (u, v) weighs entry k by `weights[k]` · [`terms`](u, v).
    pub weights: Vec<[f32; TERMS]>,
    /// Whether the fit is read at the centroid alone (a cluster of one vertex): each entry's
    /// weight at (0, 0) alone, in `weights[k][0]`, the rest 0.
    pub centre_only: bool,
    /// Texels: each entry's weights on the fit's terms past the plane's (1, u, v), where
    /// the cluster's fit has them: the shading normal's (a, b, and a², ab, b² where the fit
    /// is quadratic in it; [`super::normal_fit`]), or the contact term and the plane's
    /// squares (c, u², uv, v²; [`super::texel_kernel`]); empty where the fit is in the
    /// plane alone.
    pub extra: Vec<[f32; super::normal_fit::NORMAL]>,
    /// Texels: how many of `extra`'s terms the fit has (0 where it is empty).
    pub extra_terms: usize,
    /// Texels: what their fits read.
    pub normal_fits: super::normal_fit::Fits,
    pub texel_fits: super::texel_kernel::Fits,
    /// The fits' weights while they are blended.
    blended: Vec<[f64; TERMS]>,
    /// Per coefficient of the guide, in lanes: two fits' difference ([`blend`]); per term,
    /// the guide's sums Σ w x_t g ([`reweigh`]).
    delta: Vec<Vec4>,
    /// [`reweigh`]'s fit of the guide: its coefficients, per term, in lanes.
    coefficients: Vec<Vec4>,
    /// Each entry's guide, [`guide_lanes`] lanes each in the kernel's order, and its
    /// variance, gathered once ([`gather`]) for the four passes that read them.
    rows: Vec<Vec4>,
    row_noise: Vec<f32>,
    /// Each entry's monomials ([`monomials`]), formed once for the four fits' sums.
    monomials: Vec<[f64; MOMENTS]>,
}

/// Gathers each kernel entry's guide lanes (`guide(k)`: neighbour k's guide, `sw` floats in
/// [`guide_lanes`], and its variance) and monomials into `scratch`, in the kernel's order,
/// once the kernel's entries and places are formed: [`reweigh`] and [`fit`] read the guides
/// in four passes and the monomials in five, which each looked the guide up by its tap or
/// formed the monomials again.
pub(super) fn gather<'g>(
    scratch: &mut Scratch,
    sw: usize,
    guide: &impl Fn(u32) -> (&'g [Vec4], f32),
) {
    // The common guides' lanes as constants, as in [`reweigh`].
    match guide_lanes(sw) {
        1 => gather_in_lanes(scratch, 1, guide),
        3 => gather_in_lanes(scratch, 3, guide),
        7 => gather_in_lanes(scratch, 7, guide),
        lanes => gather_in_lanes(scratch, lanes, guide),
    }
}

/// [`gather`] for guides of `lanes` lanes.
#[inline(always)]
fn gather_in_lanes<'g>(
    scratch: &mut Scratch,
    lanes: usize,
    guide: &impl Fn(u32) -> (&'g [Vec4], f32),
) {
    let Scratch {
        kernel,
        rows,
        row_noise,
        monomials: mono,
        ..
    } = scratch;
    // Resized, not cleared: every entry is written below.
    rows.resize(kernel.len() * lanes, Vec4::ZERO);
    row_noise.resize(kernel.len(), 0.0);
    mono.resize(kernel.len(), [0.0; MOMENTS]);
    let gathered_rows = rows.chunks_exact_mut(lanes).zip(row_noise.iter_mut());
    for ((&(k, [_, u, v]), (row, noise)), m) in
        kernel.iter().zip(gathered_rows).zip(mono.iter_mut())
    {
        let (g, variance) = guide(k);
        for (o, g) in row.iter_mut().zip(&g[..lanes]) {
            *o = *g;
        }
        *noise = variance;
        *m = monomials(u, v).1;
    }
}

/// Adds Σ w m over the `weighted` entries (w, m) to `sums`, in order, in registers.
#[inline(always)]
fn add_moments<'m>(
    sums: &mut [f64; MOMENTS],
    weighted: impl Iterator<Item = (f64, &'m [f64; MOMENTS])>,
) {
    let mut local = *sums;
    for (w, m) in weighted {
        for (s, m) in local.iter_mut().zip(m) {
            *s += w * m;
        }
    }
    *sums = local;
}

/// The least weight of the geometric terms (all but the range term, at most 1) that an entry
/// needs to be kept: a neighbour far off the cluster's plane (around the torus's tube) or
/// facing away weighs less, and skipping it (its range term, its tapers, its share of every
/// fit; a tenth of the torus's entries) moved the torus's denoised transfer by 4e-7 of its
/// largest coefficient; at 1e-5, by 9e-6.
pub(super) const NEGLIGIBLE: f32 = 1e-6;

/// ln [`NEGLIGIBLE`]: the kernel keeps an entry whose Gaussian terms' exponent and whose
/// normals' term are both above their least.
pub(super) const LN_NEGLIGIBLE: f32 = -13.815_511;

/// A cluster's kernel as [`super::Filter::cluster_kernel`] gathers it, each entry's weight
/// as its exponent (w = s · exp(e), e and s the geometric terms' [`Scratch::geometric`],
/// less the range term in e) and its r² (kernel radii²) in its first taper, turned into its
/// weight and its tapers, four entries at a time ([`exp4`]).
///
/// The narrower fits' tapers, their extra falloffs on top of the kernel's exp(−2 r²) (about
/// half its width, and a quarter), are exp(−6 r²) and exp(−20 r²): that Gaussian's cube and
/// tenth power, one exponential where two were (the same but for rounding).
#[inline(never)]
pub(super) fn weigh(scratch: &mut Scratch) {
    let Scratch {
        kernel,
        geometric,
        taper,
        ..
    } = scratch;
    exp4::weigh(kernel, geometric);
    let tapers = |r2: Vec4| {
        let a = exp4(r2 * -2.0);
        let (a2, a5) = (a * a, a * a * a * a * a);
        ((a2 * a).to_array(), (a5 * a5).to_array())
    };
    let mut chunks = taper.chunks_exact_mut(4);
    for four in &mut chunks {
        let (t1, t2) = tapers(Vec4::from_array(std::array::from_fn(|l| four[l][0])));
        for (l, t) in four.iter_mut().enumerate() {
            *t = [t1[l], t2[l]];
        }
    }
    for t in chunks.into_remainder() {
        let (t1, t2) = tapers(Vec4::splat(t[0]));
        *t = [t1[0], t2[0]];
    }
}

/// The fit's terms at (u, v): 1, u, v, u², uv, v².
pub(super) fn terms(u: f32, v: f32) -> [f32; TERMS] {
    [1.0, u, v, u * u, u * v, v * v]
}

/// a · b over the fit's terms.
pub(super) fn dot(a: &[f32; TERMS], b: &[f32; TERMS]) -> f32 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

/// Σ (a − b)² over two guides' lanes (the range term's distance, for every neighbour of
/// every vertex), four at a time, in a fixed order: the same on every thread. The common
/// guides' lanes are constants, so that the loop unrolls.
#[inline(always)]
pub(super) fn squared_distance(a: &[Vec4], b: &[Vec4]) -> f32 {
    #[inline(always)]
    fn in_lanes(a: &[Vec4], b: &[Vec4], lanes: usize) -> f32 {
        let (a, b) = (&a[..lanes], &b[..lanes]);
        let mut sum = Vec4::ZERO;
        for l in 0..lanes {
            let d = a[l] - b[l];
            sum += d * d;
        }
        (sum.x + sum.y) + (sum.z + sum.w)
    }
    match a.len().min(b.len()) {
        1 => in_lanes(a, b, 1),
        3 => in_lanes(a, b, 3),
        7 => in_lanes(a, b, 7),
        lanes => in_lanes(a, b, lanes),
    }
}

/// Monomials of degree at most 4 in (u, v), by degree and then by the power of v: the 15
/// distinct entries of x xᵀ for x = (1, u, v, u², uv, v²), and a 0 after them, so that
/// their sums pair into vector registers.
const MOMENTS: usize = 16;

/// Where x_p x_q lies among the [`MOMENTS`].
const PRODUCT: [[usize; TERMS]; TERMS] = [
    [0, 1, 2, 3, 4, 5],
    [1, 3, 4, 6, 7, 8],
    [2, 4, 5, 7, 8, 9],
    [3, 6, 7, 10, 11, 12],
    [4, 7, 8, 11, 12, 13],
    [5, 8, 9, 12, 13, 14],
];

/// The fit's coordinates x = (1, u, v, u², uv, v²) and the monomials of x xᵀ.
#[inline(always)]
fn monomials(u: f32, v: f32) -> ([f64; TERMS], [f64; MOMENTS]) {
    let (u, v) = (f64::from(u), f64::from(v));
    let (uu, uv, vv) = (u * u, u * v, v * v);
    let x = [1.0, u, v, uu, uv, vv];
    let m = [
        1.0,
        u,
        v,
        uu,
        uv,
        vv,
        uu * u,
        uu * v,
        u * vv,
        vv * v,
        uu * uu,
        uu * uv,
        uu * vv,
        uv * vv,
        vv * vv,
        0.0,
    ];
    (x, m)
}

/// Weighs each of a cluster's kernel entries by its guide's distance from a quadratic fit
/// of the guides, rather than from the cluster's own guide: the **robust range term**.
///
/// The range term of [`super::Filter::weight`] compares a neighbour's guide with the
/// centre's. On a curved mesh the transfer changes from vertex to vertex (the torus's turns
/// towards and away from the sky), so it cuts neighbours that the quadratic fit would follow
/// exactly, and keeps the fit from averaging them: the noise it leaves is most of a denoised
/// vertex bake's error. Here the kernel's weights as formed (that range term in them) fit the
/// guide once, and each entry is weighed again by its guide's residual from that fit, the
/// kernel's other terms unchanged: a neighbour the fit explains is kept, one across a shadow's
/// edge (far from a fit that the near side dominates) is cut. One step of iteratively
/// reweighted local regression (Cleveland 1979, *Robust locally weighted regression and
/// smoothing scatterplots*), with the range term as its weight function. Measured on the
/// torus at 64 rays, 8 seeds: 1.26 / 3.45 / 0.78 % -> 1.11 / 2.88 / 0.71 % (κ = 3, the
/// half-width fit blended from 4 / 16, before the quarter-width fit); a second step does not
/// help (1.12 / 2.92 / 0.71 %, 4 seeds).
///
/// It reads the entries' guides and variances as [`gather`] left them; `noise` is the
/// cluster's own.
///
/// Kept out of line, as are [`weigh`] and [`fit`]: each runs once per cluster, and is
/// compiled, and profiled, on its own.
#[inline(never)]
pub(super) fn reweigh(scratch: &mut Scratch, (sw, kappa, noise): (usize, f32, f32)) {
    let settings = (sw, kappa, noise);
    // The common guides' lanes as constants, so that the loops over them unroll.
    match guide_lanes(sw) {
        1 => reweigh_in_lanes(scratch, 1, settings),
        3 => reweigh_in_lanes(scratch, 3, settings),
        7 => reweigh_in_lanes(scratch, 7, settings),
        lanes => reweigh_in_lanes(scratch, lanes, settings),
    }
}

/// [`reweigh`] for guides of `lanes` lanes.
#[inline(always)]
fn reweigh_in_lanes(scratch: &mut Scratch, lanes: usize, (sw, kappa, noise): (usize, f32, f32)) {
    let Scratch {
        kernel,
        geometric,
        delta: moments,
        coefficients,
        rows,
        row_noise,
        monomials: mono,
        ..
    } = scratch;
    // A = Σ w x xᵀ's sums of monomials, and the guide's sums Σ w x_t g per term.
    let mut sums = [0.0f64; MOMENTS];
    moments.clear();
    moments.resize(TERMS * lanes, Vec4::ZERO);
    let moments = &mut moments[..TERMS * lanes];
    let entries = kernel.iter().zip(mono.iter());
    add_moments(
        &mut sums,
        entries.map(|(&(_, [w, ..]), m)| (f64::from(w), m)),
    );
    // One term and up to 8 lanes at a time, the sums in registers: all 6 terms' sums at
    // once outgrew them. The same sums in the same order (x_t from the monomials, the same
    // float: a product of two floats is exact in a double).
    for (t, sums) in moments.chunks_exact_mut(lanes).enumerate() {
        for (block, sums) in sums.chunks_mut(8).enumerate() {
            let mut local = [Vec4::ZERO; 8];
            let local = &mut local[..sums.len()];
            for ((&(_, [w, ..]), m), g) in
                kernel.iter().zip(mono.iter()).zip(rows.chunks_exact(lanes))
            {
                let wx = w * m[t] as f32;
                for (s, g) in local.iter_mut().zip(&g[block * 8..]) {
                    *s += wx * *g;
                }
            }
            sums.copy_from_slice(local);
        }
    }
    let Some(b) = invert_moments(&sums) else {
        return;
    };
    // The fit's coefficients, β = A⁻¹ Σ w x gᵀ.
    coefficients.clear();
    coefficients.resize(TERMS * lanes, Vec4::ZERO);
    let coefficients = &mut coefficients[..TERMS * lanes];
    for (beta, row) in coefficients.chunks_exact_mut(lanes).zip(&b) {
        for (sum, &a) in moments.chunks_exact(lanes).zip(row) {
            for (o, s) in beta.iter_mut().zip(sum) {
                *o += a as f32 * *s;
            }
        }
    }
    let gathered = rows.chunks_exact(lanes).zip(row_noise.iter());
    for ((entry, &(exponent, _)), (g, &variance)) in
        kernel.iter_mut().zip(geometric.iter()).zip(gathered)
    {
        let [_, u, v] = entry.1;
        let x = terms(u, v);
        let g = &g[..lanes];
        // Σ over the lanes of (g − Σ_t x_t β_t)², lane by lane in registers.
        let mut squared = Vec4::ZERO;
        for l in 0..lanes {
            let mut fitted = Vec4::ZERO;
            for (t, x) in x.iter().enumerate() {
                fitted += *x * coefficients[t * lanes + l];
            }
            let d = g[l] - fitted;
            squared += d * d;
        }
        let squared = (squared.x + squared.y) + (squared.z + squared.w);
        let range = range_term(squared, (noise + variance) * sw as f32, kappa);
        entry.1[0] = exponent - range;
    }
    exp4::weigh(kernel, geometric);
}

/// Turns a cluster's kernel, `scratch.kernel`'s entries (k, [w_k, u_k, v_k]) with their
/// tapers, into the weights of a weighted quadratic fit over its tangent plane, as functions
/// of the place it is evaluated at: `scratch.weights`, e_k = w_k A⁻¹ x_k with
/// x = (1, u, v, u², uv, v²) and A = Σ w_k x_k x_kᵀ, so that a member at x_m weighs entry k
/// by e_k · x_m. These sum to 1 at every place. It reads the entries' guides (`sw` floats,
/// in [`guide_lanes`]) and variances as [`gather`] left them.
///
/// Where the transfer bends faster than a quadratic over the kernel (a contact shadow, a
/// room's corner), the fit is biased. The fits over kernels a half and a quarter as wide are
/// then blended in, one after the other (Lepski's rule, as in Katkovnik's intersection of
/// confidence intervals): where the blend so far and the next narrower fit, read at the
/// cluster's centroid, differ in the guide by more than their difference's noise,
/// Σ (a_k − b_k)² σ²_k, allows ([`LEPSKI`]). One blend per cluster, which all its members
/// share.
///
/// A = Σ w x xᵀ holds 15 distinct sums of monomials, formed once per neighbour for every
/// fit; one inverse per fit gives its weights.
#[inline(never)]
pub(super) fn fit(scratch: &mut Scratch, sw: usize) {
    // The common guides' lanes as constants, as in [`reweigh`].
    match guide_lanes(sw) {
        1 => fit_in_lanes(scratch, 1, sw),
        3 => fit_in_lanes(scratch, 3, sw),
        7 => fit_in_lanes(scratch, 7, sw),
        lanes => fit_in_lanes(scratch, lanes, sw),
    }
}

/// [`fit`] for guides of `lanes` lanes.
#[inline(always)]
fn fit_in_lanes(scratch: &mut Scratch, lanes: usize, sw: usize) {
    let Scratch {
        kernel,
        taper,
        weights,
        centre_only,
        blended,
        delta,
        rows,
        row_noise,
        monomials: mono,
        ..
    } = scratch;
    weights.clear();
    // The moments' sums for the wide fit and for the narrower ones, each in its own row,
    // one fit at a time: the three fits' sums at once outgrew the vector registers.
    let mut sums = [[0.0f64; MOMENTS]; 3];
    let entries = kernel.iter().zip(mono.iter());
    add_moments(
        &mut sums[0],
        entries.map(|(&(_, [w, ..]), m)| (f64::from(w), m)),
    );
    for level in 0..LEPSKI.len() {
        let entries = kernel.iter().zip(taper.iter()).zip(mono.iter());
        let weighted =
            entries.map(|((&(_, [w, ..]), t), m)| (f64::from(w) * f64::from(t[level]), m));
        add_moments(&mut sums[level + 1], weighted);
    }
    let Some(b) = invert_moments(&sums[0]) else {
        let mass = sums[0][0];
        let mean = |w: f32| {
            std::array::from_fn(|t| {
                if t == 0 {
                    (f64::from(w) / mass) as f32
                } else {
                    0.0
                }
            })
        };
        weights.extend(kernel.iter().map(|&(_, [w, ..])| mean(w)));
        return;
    };
    // The weights' terms formed: the first alone, at the centroid, for a cluster of one.
    let times = |b: &[[f64; TERMS]; TERMS], x: &[f64; TERMS], s: f64| match *centre_only {
        true => times(b, x, s, 1),
        false => times(b, x, s, TERMS),
    };
    blended.clear();
    let x = |m: &[f64; MOMENTS]| -> [f64; TERMS] { std::array::from_fn(|t| m[t]) };
    blended.extend(
        (kernel.iter().zip(mono.iter())).map(|(&(_, [w, ..]), m)| times(&b, &x(m), f64::from(w))),
    );
    for (level, &thresholds) in LEPSKI.iter().enumerate() {
        let Some(bn) = invert_moments(&sums[level + 1]) else {
            continue;
        };
        // The narrower fit's weight and its coordinates.
        let narrow = |&(_, [w, ..]): &(u32, [f32; 3]), taper: &[f32; 2], m| {
            (f64::from(w) * f64::from(taper[level]), x(m))
        };
        let entries = || kernel.iter().zip(taper.iter()).zip(mono.iter());
        // Both fits' weights at the centroid, their first terms.
        let at_centroid = entries()
            .zip(blended.iter())
            .map(|(((entry, taper), m), e)| {
                let (s, x) = narrow(entry, taper, m);
                (e[0], s * dot6(&bn[0], &x))
            });
        let gathered = (rows.chunks_exact(lanes), &row_noise[..]);
        let t = blend(at_centroid, gathered, (delta, lanes), sw, thresholds);
        if t > 0.0 {
            for (((entry, taper), m), e) in entries().zip(blended.iter_mut()) {
                let (s, x) = narrow(entry, taper, m);
                let n = times(&bn, &x, s);
                e.iter_mut()
                    .zip(n)
                    .for_each(|(e, n)| *e = *e * (1.0 - t) + n * t);
            }
        }
    }
    weights.extend(blended.iter().map(|e| e.map(|e| e as f32)));
}

/// a · x over the fit's terms, in order.
#[inline(always)]
fn dot6(a: &[f64; TERMS], x: &[f64; TERMS]) -> f64 {
    a.iter().zip(x).map(|(a, x)| a * x).sum()
}

/// s · B x for the symmetric B, its first `used` entries (the rest 0).
#[inline(always)]
fn times(b: &[[f64; TERMS]; TERMS], x: &[f64; TERMS], s: f64, used: usize) -> [f64; TERMS] {
    let mut out = [0.0; TERMS];
    for (o, row) in out.iter_mut().zip(b).take(used) {
        *o = s * dot6(row, x);
    }
    out
}

/// The narrower fit's share of the blend (Lepski's rule, between `thresholds`), from both
/// fits' weights at the centroid, (a_k, b_k) per entry, and the entries' gathered guides
/// and variances.
#[inline(always)]
fn blend<'r>(
    at_centroid: impl Iterator<Item = (f64, f64)>,
    (rows, row_noise): (impl Iterator<Item = &'r [Vec4]>, &[f32]),
    (delta, lanes): (&mut Vec<Vec4>, usize),
    sw: usize,
    (start, full): (f64, f64),
) -> f64 {
    // The difference's sums in registers, up to 8 lanes.
    let mut local = [Vec4::ZERO; 8];
    let delta = match lanes <= local.len() {
        true => &mut local[..lanes],
        false => {
            delta.clear();
            delta.resize(lanes, Vec4::ZERO);
            &mut delta[..]
        }
    };
    let mut variance = 0.0f64;
    for (((a, b), g), &noise) in at_centroid.zip(rows).zip(row_noise) {
        let g = &g[..lanes];
        variance += (a - b) * (a - b) * f64::from(noise);
        let difference = (a - b) as f32;
        for l in 0..lanes {
            delta[l] += difference * g[l];
        }
    }
    let squared: f64 = (delta.iter().flat_map(|d| d.to_array()))
        .map(|d| f64::from(d) * f64::from(d))
        .sum();
    let d2 = squared / (sw.max(1) as f64 * variance);
    let t = (d2 - start) / (full - start);
    if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// A⁻¹ from the sums of `moments` ([`MOMENTS`]), the ridge added (A's first row and column
/// untouched, so Σ_k w_k A⁻¹ x_k = e₀ still: the weights sum to 1 at every place); `None`
/// where A is singular.
fn invert_moments(moments: &[f64; MOMENTS]) -> Option<[[f64; TERMS]; TERMS]> {
    let mut a = [[0.0f64; TERMS]; TERMS];
    for (p, row) in a.iter_mut().enumerate() {
        for (q, entry) in row.iter_mut().enumerate() {
            *entry = moments[PRODUCT[p][q]];
        }
    }
    let mass = a[0][0];
    for (p, row) in a.iter_mut().enumerate().skip(1) {
        row[p] += RIDGE * mass * if p >= 3 { 4.0 } else { 1.0 };
    }
    let l = cholesky::factor(&a, 1e-12 * a[0][0])?;
    let mut inverse = [[0.0f64; TERMS]; TERMS];
    for (column, out) in inverse.iter_mut().enumerate() {
        out[column] = 1.0;
        cholesky::solve(&l, out);
    }
    Some(inverse).filter(|b| b.iter().flatten().all(|v| v.is_finite()))
}

/// Each vertex's noise: its rays' estimate where it has one, else (0: a subsurface vertex,
/// whose random walks replaced the opaque pass's transfer and carry no estimate, or a vertex
/// no ray reached) the estimate from its neighbours' signal, `from_signal`.
pub(super) fn fill_noise(rays: &[f32], from_signal: impl FnOnce() -> Vec<f32>) -> Vec<f32> {
    if rays.iter().all(|&v| v > 0.0) {
        return rays.to_vec();
    }
    rays.iter()
        .zip(from_signal())
        .map(|(&r, s)| if r > 0.0 { r } else { s })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A vertex on a 19 × 19 grid of neighbours (one spacing apart, radius 9) whose guide
    /// bends faster than a quadratic (a contact shadow's exp): with a noise far below the
    /// fits' difference the narrower fit is taken, and reads the vertex's value far closer;
    /// with a noise far above it the wide fit is kept unchanged.
    #[test]
    fn the_narrower_fit_is_taken_where_the_guide_bends_beyond_its_noise() {
        let radius = 9.0f32;
        let points: Vec<Vec3> = (-9..=9)
            .flat_map(|x| (-9..=9).map(move |y| Vec3::new(x as f32, y as f32, 0.0)))
            .collect();
        let guides: Vec<[Vec4; 1]> = points
            .iter()
            .map(|p| [Vec4::new((p.x * 0.6).exp(), 0.0, 0.0, 0.0)])
            .collect();
        let read = |noise: f32| {
            let mut scratch = Scratch::default();
            for (k, p) in points.iter().enumerate() {
                let r2 = p.length_squared() / (radius * radius);
                let w = (-2.0 * r2).exp() * f32::from(u8::from(r2 <= 1.0));
                scratch.kernel.push((k as u32, [w, p.x, p.y]));
                scratch.taper.push([(-6.0 * r2).exp(), (-20.0 * r2).exp()]);
            }
            gather(&mut scratch, 1, &|k| (&guides[k as usize][..], noise));
            fit(&mut scratch, 1);
            let at = terms(0.0, 0.0);
            (scratch.kernel.iter().zip(&scratch.weights))
                .map(|(&(k, _), e)| dot(e, &at) * guides[k as usize][0].x)
                .sum::<f32>()
        };
        let (quiet, noisy) = ((read(1e-6) - 1.0).abs(), (read(1e9) - 1.0).abs());
        assert!(quiet < 0.3 * noisy, "quiet {quiet}, noisy {noisy}");
    }
}
