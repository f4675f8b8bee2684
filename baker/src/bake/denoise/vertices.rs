//! Vertex kernels (`Settings::VERTICES`, every receiver read on its own): a weighted
//! **second-order** fit over the vertex's tangent plane, in place of the texels' first-order
//! one.
//!
//! A mesh is sparse beside a lightmap: the torus's floor has a vertex every 0.2 units, and
//! its contact shadow, the room's corners and the torus's own curvature change the transfer
//! within a few vertices. A first-order fit over 4 spacings blurs those curves (averaging 8
//! seeds' denoised bakes left a 0.9 % bias against the 1.2 % error of a raw bake with 8 × the
//! rays); a quadratic fit, 1, u, v, u², uv, v² (Cleveland & Devlin 1988, *Locally weighted
//! regression*; Moon, Carr & Yoon 2014 for rendering), is unbiased for a transfer curving
//! along the surface, so it can read neighbours twice as far away (9 spacings) and average
//! more noise away at a lower bias. Its weights are still one set per vertex, shared by every
//! coefficient and channel, and sum to 1.
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
//! %, with the narrower fit blended in 1.47 / 3.98 / 0.88 % (docs/explanation/denoising.md).

use glam::Vec3;

/// Terms of the fit: 1, u, v, u², uv, v².
const TERMS: usize = 6;
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
const NARROW: f64 = 6.0;
/// The fits' squared difference over its noise variance from which the narrower fit is
/// blended in, and at which it is taken whole. Measured at 64 rays (seed 1): 1 / 4 and 2 / 8
/// blend on the torus's curvature and cost it noise (matrices 2.47 and 2.32 %); 8 / 32, 2.20
/// %; 16 / 64, 2.22 %.
const LEPSKI_START: f64 = 8.0;
const LEPSKI_FULL: f64 = 32.0;

/// Turns a vertex's kernel, entries (k, [w_k, ..]), into the weights of a weighted quadratic
/// fit over its tangent plane (normal `surface`) evaluated at the vertex: entries
/// (k, [w, 0, 0]), so the vertex's place (1, 0, 0) in its one-receiver cluster reads w alone.
/// `offset(k)` is neighbour k's offset from the vertex, in its spacings, `radius` the
/// kernel's, and `guide(k)` its guide and the guide's variance.
///
/// Where the transfer bends faster than a quadratic over the kernel (a contact shadow, a
/// room's corner), the fit is biased. The fit over a kernel half as wide is then blended in
/// (Lepski's rule, as in Katkovnik's intersection of confidence intervals): where the two
/// fits of the guide differ by more than their difference's noise, Σ (a_k − b_k)² σ²_k, allows.
pub(super) fn fit<'g>(
    out: &mut [(u32, [f32; 3])],
    offset: impl Fn(u32) -> Vec3,
    surface: Vec3,
    radius: f32,
    guide: impl Fn(u32) -> (&'g [f32], f32),
) {
    let (t1, t2) = surface.any_orthonormal_pair();
    // Per neighbour: its fit coordinates (1, u, v, u², uv, v²) and the narrower kernel's taper.
    let xs: Vec<([f64; TERMS], f64)> = out
        .iter()
        .map(|&(k, _)| {
            let d = offset(k);
            let (u, v) = (f64::from(d.dot(t1)), f64::from(d.dot(t2)));
            let r2 = f64::from(d.length_squared() / (radius * radius));
            ([1.0, u, v, u * u, u * v, v * v], (-NARROW * r2).exp())
        })
        .collect();
    let Some(wide) = fit_weights(out, &xs, false) else {
        let mass: f64 = out.iter().map(|&(_, [w, ..])| f64::from(w)).sum();
        for (_, e) in out.iter_mut() {
            *e = [(f64::from(e[0]) / mass) as f32, 0.0, 0.0];
        }
        return;
    };
    let narrow = fit_weights(out, &xs, true);
    let t = narrow.as_ref().map_or(0.0, |narrow| {
        let sw = guide(out[0].0).0.len().max(1);
        let (mut delta, mut variance) = (vec![0.0f64; sw], 0.0f64);
        for (&(k, _), (a, b)) in out.iter().zip(wide.iter().zip(narrow)) {
            let (g, noise) = guide(k);
            for (d, x) in delta.iter_mut().zip(g) {
                *d += (a - b) * f64::from(*x);
            }
            variance += (a - b) * (a - b) * f64::from(noise);
        }
        let d2 = delta.iter().map(|d| d * d).sum::<f64>() / (sw as f64 * variance);
        let t = (d2 - LEPSKI_START) / (LEPSKI_FULL - LEPSKI_START);
        if t.is_finite() {
            t.clamp(0.0, 1.0)
        } else {
            0.0
        }
    });
    for (i, (_, e)) in out.iter_mut().enumerate() {
        let w = match &narrow {
            Some(narrow) if t > 0.0 => (1.0 - t) * wide[i] + t * narrow[i],
            _ => wide[i],
        };
        *e = [w as f32, 0.0, 0.0];
    }
}

/// The weights of the quadratic fit with kernel weights w_k (times the taper of `xs`, if
/// `narrow`) at the vertex, or `None` where its normal matrix is singular.
fn fit_weights(
    out: &[(u32, [f32; 3])],
    xs: &[([f64; TERMS], f64)],
    narrow: bool,
) -> Option<Vec<f64>> {
    let weight = |w: f32, taper: f64| f64::from(w) * if narrow { taper } else { 1.0 };
    // A = Σ w x xᵀ, its upper triangle.
    let mut a = [[0.0f64; TERMS]; TERMS];
    for (&(_, [w, ..]), (x, taper)) in out.iter().zip(xs) {
        let w = weight(w, *taper);
        for p in 0..TERMS {
            let wx = w * x[p];
            for q in p..TERMS {
                a[p][q] += wx * x[q];
            }
        }
    }
    let upper = a;
    for (p, row) in a.iter_mut().enumerate() {
        for (q, entry) in row.iter_mut().enumerate().take(p) {
            *entry = upper[q][p];
        }
    }
    let mass = a[0][0];
    for (p, row) in a.iter_mut().enumerate().skip(1) {
        row[p] += RIDGE * mass * if p >= 3 { 4.0 } else { 1.0 };
    }
    // The fit at the vertex is e₀ᵀ A⁻¹ x_k w_k: A y = e₀ is solved once.
    let y = solve_first(&a)?;
    Some(
        out.iter()
            .zip(xs)
            .map(|(&(_, [w, ..]), (x, taper))| {
                let dot: f64 = y.iter().zip(x).map(|(y, x)| y * x).sum();
                dot * weight(w, *taper)
            })
            .collect(),
    )
}

/// y with A y = e₀ for the symmetric `a` (Cholesky), or `None` where it is not positive
/// definite.
fn solve_first(a: &[[f64; TERMS]; TERMS]) -> Option<[f64; TERMS]> {
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
    let mut z = [0.0f64; TERMS];
    for i in 0..TERMS {
        let b = f64::from(u8::from(i == 0));
        z[i] = (b - (0..i).map(|k| l[i][k] * z[k]).sum::<f64>()) / l[i][i];
    }
    let mut y = [0.0f64; TERMS];
    for i in (0..TERMS).rev() {
        y[i] = (z[i] - (i + 1..TERMS).map(|k| l[k][i] * y[k]).sum::<f64>()) / l[i][i];
    }
    Some(y).filter(|y| y.iter().all(|v| v.is_finite()))
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
        let guides: Vec<[f32; 1]> = points.iter().map(|p| [(p.x * 0.6).exp()]).collect();
        let kernel = || -> Vec<(u32, [f32; 3])> {
            (0..points.len() as u32)
                .map(|k| {
                    let r2 = points[k as usize].length_squared() / (radius * radius);
                    (
                        k,
                        [(-2.0 * r2).exp() * f32::from(u8::from(r2 <= 1.0)), 0.0, 0.0],
                    )
                })
                .collect()
        };
        let read = |noise: f32| {
            let mut out = kernel();
            fit(
                &mut out,
                |k| points[k as usize],
                Vec3::Z,
                radius,
                |k| (&guides[k as usize][..], noise),
            );
            out.iter()
                .map(|&(k, [w, ..])| w * guides[k as usize][0])
                .sum::<f32>()
        };
        let (quiet, noisy) = ((read(1e-6) - 1.0).abs(), (read(1e9) - 1.0).abs());
        assert!(quiet < 0.3 * noisy, "quiet {quiet}, noisy {noisy}");
    }
}
