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
//! Measured on the torus at 64 rays, sun and sky / low sun / sky, against 16,384 rays:
//! first-order over 4 spacings 1.65 / 4.26 / 1.06 %, this 1.49 / 4.07 / 0.91 %
//! (docs/explanation/denoising.md).

use glam::Vec3;

/// Terms of the fit: 1, u, v, u², uv, v².
const TERMS: usize = 6;
/// The power of the shading normals' dot product for vertices.
pub(super) const NORMAL_POWER: i32 = 8;
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

/// Turns a vertex's kernel, entries (k, [w_k, ..]), into the weights of a weighted quadratic
/// fit over its tangent plane (normal `surface`) evaluated at the vertex: entries
/// (k, [w, 0, 0]), so the vertex's place (1, 0, 0) in its one-receiver cluster reads w alone.
/// `offset(k)` is neighbour k's offset from the vertex, in its spacings.
pub(super) fn fit(out: &mut [(u32, [f32; 3])], offset: impl Fn(u32) -> Vec3, surface: Vec3) {
    let (t1, t2) = surface.any_orthonormal_pair();
    let basis = |k: u32| {
        let d = offset(k);
        let (u, v) = (f64::from(d.dot(t1)), f64::from(d.dot(t2)));
        [1.0, u, v, u * u, u * v, v * v]
    };
    // A = Σ w x xᵀ.
    let mut a = [[0.0f64; TERMS]; TERMS];
    for &(k, [w, ..]) in out.iter() {
        let x = basis(k);
        let w = f64::from(w);
        for (p, row) in a.iter_mut().enumerate() {
            for (q, entry) in row.iter_mut().enumerate() {
                *entry += w * x[p] * x[q];
            }
        }
    }
    let mass = a[0][0];
    for (p, row) in a.iter_mut().enumerate().skip(1) {
        row[p] += RIDGE * mass * if p >= 3 { 4.0 } else { 1.0 };
    }
    // The fit at the vertex is e₀ᵀ A⁻¹ x_k w_k: A y = e₀ is solved once.
    let Some(y) = solve_first(&a) else {
        for (_, e) in out.iter_mut() {
            *e = [(f64::from(e[0]) / mass) as f32, 0.0, 0.0];
        }
        return;
    };
    for (k, e) in out.iter_mut() {
        let x = basis(*k);
        let dot: f64 = y.iter().zip(x).map(|(y, x)| y * x).sum();
        *e = [(dot * f64::from(e[0])) as f32, 0.0, 0.0];
    }
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
