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
//! Where the transfer bends faster than a quadratic over 9 spacings (the floor under the
//! torus, a room's corner) a fit half as wide is blended in, by how far the two fits of the
//! guide differ against their difference's noise (Lepski's rule: [`fit`]).
//!
//! Measured on the torus at 64 rays, sun and sky / low sun / sky, against 16,384 rays:
//! first-order over 4 spacings 1.65 / 4.26 / 1.06 %, the second-order fit 1.49 / 4.07 / 0.91
//! %, with the narrower fit blended in 1.47 / 3.98 / 0.88 %; in clusters (1.5 vertices on
//! average) 1.46 / 3.98 / 0.88 %, transfer matrices 2.25 % against 2.20 %, for 0.74 × the
//! filter's instructions (docs/explanation/denoising.md). The blend is judged once per
//! cluster, at its centroid.

use glam::Vec4;

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
/// the glossy torus at 64 rays, 2.60 % against 2.77 % at κ = 4). Matrices at other orders
/// carry their rays' estimate ([`crate::bake::matrix`]) and keep κ: 2.33 %, and 2.32 / 2.33
/// / 2.58 % at κ = 3 / 4 / 6.
pub(super) const NEIGHBOUR_KAPPA: f32 = 0.75;

/// The narrower kernel's extra falloff, exp(−NARROW · r²) on top of the kernel's exp(−2 r²):
/// half its width.
const NARROW: f32 = 6.0;
/// The fits' squared difference over its noise variance from which the narrower fit is
/// blended in, and at which it is taken whole. Measured at 64 rays (seed 1): 1 / 4 and 2 / 8
/// blend on the torus's curvature and cost it noise (matrices 2.47 and 2.32 %); 8 / 32, 2.20
/// %; 16 / 64, 2.22 %.
const LEPSKI_START: f64 = 8.0;
const LEPSKI_FULL: f64 = 32.0;

/// A thread's buffers for the clusters it filters, reused from one cluster to the next (no
/// cluster allocates): the kernel's entries, and what the fit keeps per neighbour.
#[derive(Default)]
pub(super) struct Scratch {
    /// Entries (k, [w_k, u_k, v_k]): neighbour cluster k's kernel weight and place in the
    /// cluster's tangent plane about its centroid, in spacings.
    pub kernel: Vec<(u32, [f32; 3])>,
    /// Each entry's taper for the narrower fit, exp(−NARROW · r²), r in kernel radii.
    pub taper: Vec<f32>,
    /// After [`fit`], each entry's weight as a function of the member's place: a member at
    /// (u, v) weighs entry k by `weights[k]` · [`terms`](u, v).
    pub weights: Vec<[f32; TERMS]>,
    /// Whether the fit is read at the centroid alone (a cluster of one vertex): each entry's
    /// weight at (0, 0) alone, in `weights[k][0]`, the rest 0.
    pub centre_only: bool,
    /// The two fits' difference of the guide, per signal coefficient.
    delta: Vec<Vec4>,
}

/// The narrower fit's taper of a neighbour r² kernel radii² away: exp(−NARROW · r²).
pub(super) fn taper(r2: f32) -> f32 {
    (-NARROW * r2).exp()
}

/// The fit's terms at (u, v): 1, u, v, u², uv, v².
pub(super) fn terms(u: f32, v: f32) -> [f32; TERMS] {
    [1.0, u, v, u * u, u * v, v * v]
}

/// a · b over the fit's terms.
pub(super) fn dot(a: &[f32; TERMS], b: &[f32; TERMS]) -> f32 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

/// Vector registers' lanes (four floats) that hold a guide of `sw` floats.
pub(super) fn guide_lanes(sw: usize) -> usize {
    sw.div_ceil(4)
}

/// Guides of `sw` floats each, as [`guide_lanes`] of lanes each, the last zero-padded.
pub(super) fn to_lanes(guides: &[f32], sw: usize) -> Vec<Vec4> {
    let mut lanes = Vec::with_capacity(guides.len().div_ceil(sw.max(1)) * guide_lanes(sw));
    for guide in guides.chunks_exact(sw.max(1)) {
        for four in guide.chunks(4) {
            let mut padded = [0.0f32; 4];
            padded[..four.len()].copy_from_slice(four);
            lanes.push(Vec4::from_array(padded));
        }
    }
    lanes
}

/// Σ (a − b)² over two guides' lanes (the range term's distance, for every neighbour of
/// every vertex), four at a time, in a fixed order: the same on every thread.
pub(super) fn squared_distance(a: &[Vec4], b: &[Vec4]) -> f32 {
    let mut sum = Vec4::ZERO;
    for (x, y) in a.iter().zip(b) {
        let d = *x - *y;
        sum += d * d;
    }
    (sum.x + sum.y) + (sum.z + sum.w)
}

/// Monomials of degree at most 4 in (u, v), by degree and then by the power of v: the
/// distinct entries of x xᵀ for x = (1, u, v, u², uv, v²).
const MOMENTS: usize = 15;

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
    ];
    (x, m)
}

/// Turns a cluster's kernel, `scratch.kernel`'s entries (k, [w_k, u_k, v_k]) with their
/// tapers, into the weights of a weighted quadratic fit over its tangent plane, as functions
/// of the place it is evaluated at: `scratch.weights`, e_k = w_k A⁻¹ x_k with
/// x = (1, u, v, u², uv, v²) and A = Σ w_k x_k x_kᵀ, so that a member at x_m weighs entry k
/// by e_k · x_m. These sum to 1 at every place. `guide(k)` is neighbour k's guide (`sw`
/// floats, in [`guide_lanes`]) and the guide's variance.
///
/// Where the transfer bends faster than a quadratic over the kernel (a contact shadow, a
/// room's corner), the fit is biased. The fit over a kernel half as wide is then blended in
/// (Lepski's rule, as in Katkovnik's intersection of confidence intervals): where the two
/// fits of the guide at the cluster's centroid differ by more than their difference's noise,
/// Σ (a_k − b_k)² σ²_k, allows. One blend per cluster, which all its members share.
///
/// A = Σ w x xᵀ holds 15 distinct sums of monomials, formed once per neighbour for both
/// fits; one inverse per fit gives its weights.
pub(super) fn fit<'g>(scratch: &mut Scratch, sw: usize, guide: impl Fn(u32) -> (&'g [Vec4], f32)) {
    let Scratch {
        kernel,
        taper,
        weights,
        centre_only,
        delta,
    } = scratch;
    // The terms the weights are formed for: the first alone at the centroid.
    let used = if *centre_only { 1 } else { TERMS };
    weights.clear();
    // Each moment's sums for the wide fit and the narrower one, side by side: one vector
    // register's two lanes.
    let mut sums = [[0.0f64; 2]; MOMENTS];
    for (&(_, [w, u, v]), &taper) in kernel.iter().zip(taper.iter()) {
        let (_, m) = monomials(u, v);
        let w = f64::from(w);
        let w = [w, w * f64::from(taper)];
        for (s, m) in sums.iter_mut().zip(m) {
            s[0] += w[0] * m;
            s[1] += w[1] * m;
        }
    }
    let (wide, narrow) = (sums.map(|s| s[0]), sums.map(|s| s[1]));
    let Some(b) = invert_moments(&wide) else {
        let mass = wide[0];
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
    let bn = invert_moments(&narrow);
    let t = match &bn {
        Some(bn) => blend(kernel, taper, delta, (&b[0], &bn[0]), sw, guide),
        None => 0.0,
    };
    for (&(_, [w, u, v]), &taper) in kernel.iter().zip(taper.iter()) {
        let (x, _) = monomials(u, v);
        let w = f64::from(w);
        let mut e = times(&b, &x, w * (1.0 - t), used);
        if let (Some(bn), true) = (&bn, t > 0.0) {
            let en = times(bn, &x, w * f64::from(taper) * t, used);
            e.iter_mut().zip(en).for_each(|(e, n)| *e += n);
        }
        weights.push(e.map(|e| e as f32));
    }
}

/// s · B x for the symmetric B, its first `used` entries (the rest 0).
fn times(b: &[[f64; TERMS]; TERMS], x: &[f64; TERMS], s: f64, used: usize) -> [f64; TERMS] {
    let mut out = [0.0; TERMS];
    for (o, row) in out.iter_mut().zip(b).take(used) {
        *o = s * row.iter().zip(x).map(|(b, x)| b * x).sum::<f64>();
    }
    out
}

/// The narrower fit's share of the blend (Lepski's rule), from both fits' weights at the
/// centroid, w_k y · x_k and w_k τ_k yₙ · x_k.
fn blend<'g>(
    kernel: &[(u32, [f32; 3])],
    taper: &[f32],
    delta: &mut Vec<Vec4>,
    (y, yn): (&[f64; TERMS], &[f64; TERMS]),
    sw: usize,
    guide: impl Fn(u32) -> (&'g [Vec4], f32),
) -> f64 {
    let dot =
        |y: &[f64; TERMS], x: &[f64; TERMS]| -> f64 { y.iter().zip(x).map(|(y, x)| y * x).sum() };
    delta.clear();
    delta.resize(guide_lanes(sw), Vec4::ZERO);
    let mut variance = 0.0f64;
    for (&(k, [w, u, v]), &taper) in kernel.iter().zip(taper.iter()) {
        let (x, _) = monomials(u, v);
        let w = f64::from(w);
        let (a, b) = (dot(y, &x) * w, dot(yn, &x) * (w * f64::from(taper)));
        let (g, noise) = guide(k);
        variance += (a - b) * (a - b) * f64::from(noise);
        let difference = (a - b) as f32;
        for (d, g) in delta.iter_mut().zip(g) {
            *d += difference * *g;
        }
    }
    let squared: f64 = (delta.iter().flat_map(|d| d.to_array()))
        .map(|d| f64::from(d) * f64::from(d))
        .sum();
    let d2 = squared / (sw.max(1) as f64 * variance);
    let t = (d2 - LEPSKI_START) / (LEPSKI_FULL - LEPSKI_START);
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
    let l = cholesky(&a)?;
    let mut inverse = [[0.0f64; TERMS]; TERMS];
    for (column, out) in inverse.iter_mut().enumerate() {
        *out = solve(&l, column);
    }
    Some(inverse).filter(|b| b.iter().flatten().all(|v| v.is_finite()))
}

/// The Cholesky factor L (A = L Lᵀ) of the symmetric `a`, or `None` where it is not
/// positive definite.
fn cholesky(a: &[[f64; TERMS]; TERMS]) -> Option<[[f64; TERMS]; TERMS]> {
    let mut l = [[0.0f64; TERMS]; TERMS];
    for i in 0..TERMS {
        for j in 0..=i {
            let s: f64 = a[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
            if i != j {
                l[i][j] = s / l[j][j];
            } else if s > 1e-12 * a[0][0] {
                l[i][i] = s.sqrt();
            } else {
                return None;
            }
        }
    }
    Some(l)
}

/// y with L Lᵀ y = e_`column`.
fn solve(l: &[[f64; TERMS]; TERMS], column: usize) -> [f64; TERMS] {
    let mut z = [0.0f64; TERMS];
    for i in 0..TERMS {
        let b = f64::from(u8::from(i == column));
        z[i] = (b - (0..i).map(|k| l[i][k] * z[k]).sum::<f64>()) / l[i][i];
    }
    let mut y = [0.0f64; TERMS];
    for i in (0..TERMS).rev() {
        y[i] = (z[i] - (i + 1..TERMS).map(|k| l[k][i] * y[k]).sum::<f64>()) / l[i][i];
    }
    y
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
                scratch.taper.push((-NARROW * r2).exp());
            }
            fit(&mut scratch, 1, |k| (&guides[k as usize][..], noise));
            let at = terms(0.0, 0.0);
            (scratch.kernel.iter().zip(&scratch.weights))
                .map(|(&(k, _), e)| dot(e, &at) * guides[k as usize][0].x)
                .sum::<f32>()
        };
        let (quiet, noisy) = ((read(1e-6) - 1.0).abs(), (read(1e9) - 1.0).abs());
        assert!(quiet < 0.3 * noisy, "quiet {quiet}, noisy {noisy}");
    }
}
