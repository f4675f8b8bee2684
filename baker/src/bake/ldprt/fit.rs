//! Fitting zonal-harmonic lobes to one vertex's SH transfer (Sloan, Luna & Snyder 2005).
//!
//! A lobe with axis a and zonal coefficients g_l has the SH coefficients
//! f_l^m = c_l g_l y_l^m(a), c_l = sqrt(4π/(2l+1)): moving the axis rotates it, so transfer
//! stored as lobes about axes in a vertex's frame follows the frame when the mesh deforms.
//!
//! * One lobe about the normal (what D3DX's LDPRT stored) is a closed form: by the addition
//!   theorem Σ_m y_l^m(a)² = 1/c_l², so least squares gives g_l = c_l Σ_m t_l^m y_l^m(a).
//! * K lobes: for fixed axes the g are linear (a K×K solve per band and channel), so the
//!   axes alone are optimised (variable projection) by Levenberg–Marquardt over two tangent
//!   offsets per axis, from two starts: the normal, the band-1 direction and axes tilted
//!   from the normal; and every axis tilted 45° about the normal.
//!   The start holds the normal, so K lobes are never worse than one about the normal.

use glam::DVec3;

use crate::math::sh::{Basis, coeff_count, index};

/// Most lobes a vertex may have (`--lobes`).
pub const MAX_LOBES: usize = 8;
/// Levenberg–Marquardt iterations at most per vertex.
const ITERATIONS: usize = 60;
/// Relative ridge on each band's K×K normal equations: band 0 of every lobe is the same
/// constant, so without it that band's system is singular.
const RIDGE: f64 = 1e-9;

/// c_l = sqrt(4π / (2l+1)).
pub fn zh_scale(l: usize) -> f64 {
    (4.0 * std::f64::consts::PI / (2 * l + 1) as f64).sqrt()
}

/// The fitted lobes of one vertex: world axes, and per lobe, channel and band g.
#[derive(Clone, Debug, PartialEq)]
pub struct Lobes {
    pub axes: Vec<DVec3>,
    /// Index `(k * channels + c) * order + l`.
    pub g: Vec<f64>,
    /// ‖t − fit‖ / ‖t‖ over every channel's coefficients (0 where t is zero).
    pub relative_error: f64,
}

/// The SH coefficients (n², into `out`) of one lobe: c_l g_l y_l^m(axis) added to `out`.
pub fn add_lobe(basis: &Basis, axis: DVec3, g: &[f64], y: &mut [f64], out: &mut [f64]) {
    basis.eval_recurrence(axis, y);
    for (l, gl) in g.iter().enumerate() {
        let s = zh_scale(l) * gl;
        for m in -(l as i32)..=l as i32 {
            let i = index(l, m);
            out[i] += s * y[i];
        }
    }
}

/// The closed-form lobe about `axis`: g_l = c_l Σ_m t_l^m y_l^m(axis), per channel.
pub fn fit_about(basis: &Basis, t: &[f64], channels: usize, axis: DVec3) -> Lobes {
    let order = basis.order();
    let n = coeff_count(order);
    let mut y = vec![0.0; n];
    basis.eval_recurrence(axis, &mut y);
    let mut g = vec![0.0; channels * order];
    for c in 0..channels {
        for l in 0..order {
            let dot: f64 = (-(l as i32)..=l as i32)
                .map(|m| t[c * n + index(l, m)] * y[index(l, m)])
                .sum();
            g[c * order + l] = zh_scale(l) * dot;
        }
    }
    let mut lobes = Lobes {
        axes: vec![axis],
        g,
        relative_error: 0.0,
    };
    lobes.relative_error = relative_error(basis, t, channels, &lobes);
    lobes
}

/// ‖t − lobes‖ / ‖t‖ over every channel (0 where t is zero).
pub fn relative_error(basis: &Basis, t: &[f64], channels: usize, lobes: &Lobes) -> f64 {
    let order = basis.order();
    let n = coeff_count(order);
    let mut y = vec![0.0; n];
    let (mut diff, mut norm) = (0.0, 0.0);
    for c in 0..channels {
        let mut f = vec![0.0; n];
        for (k, axis) in lobes.axes.iter().enumerate() {
            let start = (k * channels + c) * order;
            add_lobe(basis, *axis, &lobes.g[start..start + order], &mut y, &mut f);
        }
        for i in 0..n {
            diff += (t[c * n + i] - f[i]).powi(2);
            norm += t[c * n + i].powi(2);
        }
    }
    if norm > 0.0 {
        (diff / norm).sqrt()
    } else {
        0.0
    }
}

/// The best g for fixed `axes` (least squares per band and channel, with [`RIDGE`]), and the
/// residual vector t − fit (channels × n²) in `residual`.
fn solve_g(
    basis: &Basis,
    t: &[f64],
    channels: usize,
    axes: &[DVec3],
    residual: &mut Vec<f64>,
) -> Vec<f64> {
    let order = basis.order();
    let n = coeff_count(order);
    let k_count = axes.len();
    let ys: Vec<Vec<f64>> = axes
        .iter()
        .map(|a| {
            let mut y = vec![0.0; n];
            basis.eval_recurrence(*a, &mut y);
            y
        })
        .collect();
    let mut g = vec![0.0; k_count * channels * order];
    residual.clear();
    residual.extend_from_slice(&t[..channels * n]);
    for l in 0..order {
        let ms = -(l as i32)..=l as i32;
        let cols: Vec<Vec<f64>> = ys
            .iter()
            .map(|y| ms.clone().map(|m| zh_scale(l) * y[index(l, m)]).collect())
            .collect();
        let col = |k: usize| cols[k].iter().copied();
        let mut gram = vec![0.0; k_count * k_count];
        for a in 0..k_count {
            for b in 0..k_count {
                gram[a * k_count + b] = col(a).zip(col(b)).map(|(x, y)| x * y).sum();
            }
        }
        let trace: f64 = (0..k_count).map(|a| gram[a * k_count + a]).sum();
        let ridge = RIDGE * trace / k_count as f64 + 1e-300;
        for a in 0..k_count {
            gram[a * k_count + a] += ridge;
        }
        for c in 0..channels {
            let tl: Vec<f64> = ms.clone().map(|m| t[c * n + index(l, m)]).collect();
            let mut rhs: Vec<f64> = (0..k_count)
                .map(|a| col(a).zip(&tl).map(|(x, y)| x * y).sum())
                .collect();
            solve(&mut gram.clone(), &mut rhs, k_count);
            for (k, gk) in rhs.iter().enumerate() {
                g[(k * channels + c) * order + l] = *gk;
                for (j, x) in col(k).enumerate() {
                    residual[c * n + index(l, j as i32 - l as i32)] -= gk * x;
                }
            }
        }
    }
    g
}

/// Solves the symmetric positive-definite `a` x = `b` in place (Gaussian elimination with
/// partial pivoting; `b` becomes x). Sizes here are at most 2·[`MAX_LOBES`].
fn solve(a: &mut [f64], b: &mut [f64], n: usize) {
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))
            .unwrap_or(col);
        if pivot != col {
            for j in 0..n {
                a.swap(col * n + j, pivot * n + j);
            }
            b.swap(col, pivot);
        }
        let d = a[col * n + col];
        if d == 0.0 {
            continue;
        }
        for row in col + 1..n {
            let f = a[row * n + col] / d;
            for j in col..n {
                a[row * n + j] -= f * a[col * n + j];
            }
            b[row] -= f * b[col];
        }
    }
    for col in (0..n).rev() {
        let d = a[col * n + col];
        let s: f64 = (col + 1..n).map(|j| a[col * n + j] * b[j]).sum();
        b[col] = if d == 0.0 { 0.0 } else { (b[col] - s) / d };
    }
}

/// Two unit vectors perpendicular to `a` and to each other.
fn tangent_basis(a: DVec3) -> (DVec3, DVec3) {
    let u = a.any_orthonormal_vector();
    (u, a.cross(u))
}

/// Axes moved by `delta` (two tangent offsets per axis), renormalised.
fn moved(axes: &[DVec3], delta: &[f64]) -> Vec<DVec3> {
    axes.iter()
        .enumerate()
        .map(|(k, a)| {
            let (u, v) = tangent_basis(*a);
            (*a + u * delta[2 * k] + v * delta[2 * k + 1]).normalize()
        })
        .collect()
}

/// The starting axes for `count` lobes: the normal, the band-1 direction of the channels'
/// sum where it is not the normal, then axes tilted 60° from the normal towards the tangent
/// frame's directions.
fn start_axes(
    basis: &Basis,
    t: &[f64],
    channels: usize,
    frame: [DVec3; 3],
    count: usize,
) -> Vec<DVec3> {
    let n = coeff_count(basis.order());
    let [tangent, bitangent, normal] = frame;
    let mut axes = vec![normal];
    if basis.order() > 1 {
        // y_1^{-1} ∝ −y, y_1^0 ∝ z, y_1^1 ∝ −x (Condon–Shortley).
        let sum = |i: usize| (0..channels).map(|c| t[c * n + i]).sum::<f64>();
        let d = DVec3::new(-sum(3), -sum(1), sum(2));
        if let Some(d) = d.try_normalize().filter(|d| d.dot(normal) < 0.999) {
            axes.push(d);
        }
    }
    let tilt = 60f64.to_radians();
    let mut turn = 0usize;
    while axes.len() < count {
        let phi = turn as f64 * std::f64::consts::FRAC_PI_2 + (turn / 4) as f64 * 0.785;
        let side = tangent * phi.cos() + bitangent * phi.sin();
        axes.push((normal * tilt.cos() + side * tilt.sin()).normalize());
        turn += 1;
    }
    axes.truncate(count);
    axes
}

/// Fits `count` lobes to `t` (channels × n² world-space coefficients) of a vertex whose
/// world frame is `frame` (tangent, bitangent, normal): one lobe about the normal in closed
/// form, more by [`fit_lobes`]'s optimisation.
pub fn fit_vertex(
    basis: &Basis,
    t: &[f64],
    channels: usize,
    frame: [DVec3; 3],
    count: usize,
) -> Lobes {
    if count == 1 {
        return fit_about(basis, t, channels, frame[2]);
    }
    // Two starts, the better fit kept: one holds the normal (so the fit is never worse than
    // one lobe about it), the other spreads every axis 45° around it (a pair of lobes on
    // either side of the normal is a valley the first start can miss).
    let held = fit_lobes(
        basis,
        t,
        channels,
        start_axes(basis, t, channels, frame, count),
    );
    let [tangent, bitangent, normal] = frame;
    let tilt = 45f64.to_radians();
    let spread: Vec<DVec3> = (0..count)
        .map(|k| {
            let phi = std::f64::consts::TAU * k as f64 / count as f64;
            let side = tangent * phi.cos() + bitangent * phi.sin();
            (normal * tilt.cos() + side * tilt.sin()).normalize()
        })
        .collect();
    let spread = fit_lobes(basis, t, channels, spread);
    if spread.relative_error < held.relative_error {
        spread
    } else {
        held
    }
}

/// Levenberg–Marquardt over the axes (the g solved for each trial), from `axes`.
pub fn fit_lobes(basis: &Basis, t: &[f64], channels: usize, mut axes: Vec<DVec3>) -> Lobes {
    let params = 2 * axes.len();
    let mut residual = Vec::new();
    let mut g = solve_g(basis, t, channels, &axes, &mut residual);
    let mut cost: f64 = residual.iter().map(|r| r * r).sum();
    let norm: f64 = t[..residual.len()].iter().map(|x| x * x).sum();
    let mut mu = 1e-3;
    let h = 1e-6;
    let mut trial = Vec::new();
    for _ in 0..ITERATIONS {
        if cost <= 1e-20 * norm {
            break;
        }
        // Forward-difference Jacobian of the residual in the tangent offsets.
        let mut jacobian = vec![Vec::new(); params];
        for (p, column) in jacobian.iter_mut().enumerate() {
            let mut delta = vec![0.0; params];
            delta[p] = h;
            solve_g(basis, t, channels, &moved(&axes, &delta), &mut trial);
            *column = trial
                .iter()
                .zip(&residual)
                .map(|(a, b)| (a - b) / h)
                .collect();
        }
        let mut jtj = vec![0.0; params * params];
        let mut jtr = vec![0.0; params];
        for a in 0..params {
            jtr[a] = -jacobian[a]
                .iter()
                .zip(&residual)
                .map(|(x, r)| x * r)
                .sum::<f64>();
            for b in 0..params {
                jtj[a * params + b] = jacobian[a]
                    .iter()
                    .zip(&jacobian[b])
                    .map(|(x, y)| x * y)
                    .sum();
            }
        }
        let mut improved = false;
        for _ in 0..8 {
            let mut system = jtj.clone();
            for a in 0..params {
                system[a * params + a] += mu * (jtj[a * params + a] + 1e-12 * norm);
            }
            let mut step = jtr.clone();
            solve(&mut system, &mut step, params);
            let candidate = moved(&axes, &step);
            let g_new = solve_g(basis, t, channels, &candidate, &mut trial);
            let c: f64 = trial.iter().map(|r| r * r).sum();
            if c < cost {
                improved = (cost - c) > 1e-12 * cost;
                (axes, g, cost) = (candidate, g_new, c);
                std::mem::swap(&mut residual, &mut trial);
                mu = (mu / 3.0).max(1e-9);
                break;
            }
            mu *= 4.0;
        }
        if !improved {
            break;
        }
    }
    let relative_error = if norm > 0.0 {
        (cost / norm).sqrt()
    } else {
        0.0
    };
    Lobes {
        axes,
        g,
        relative_error,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SH coefficients of lobes, channel 0.
    fn project(basis: &Basis, lobes: &Lobes, channels: usize) -> Vec<f64> {
        let n = basis.coeff_count();
        let order = basis.order();
        let mut y = vec![0.0; n];
        let mut out = vec![0.0; n * channels];
        for c in 0..channels {
            for (k, a) in lobes.axes.iter().enumerate() {
                let g = &lobes.g[(k * channels + c) * order..][..order];
                add_lobe(basis, *a, g, &mut y, &mut out[c * n..(c + 1) * n]);
            }
        }
        out
    }

    #[test]
    fn one_lobe_about_the_normal_is_exact_for_a_zonal_function() {
        let basis = Basis::new(4);
        let axis = DVec3::new(0.3, -0.5, 0.8).normalize();
        let truth = Lobes {
            axes: vec![axis],
            g: vec![0.9, 0.6, 0.25, -0.05],
            relative_error: 0.0,
        };
        let t = project(&basis, &truth, 1);
        let fit = fit_about(&basis, &t, 1, axis);
        for (a, b) in fit.g.iter().zip(&truth.g) {
            assert!((a - b).abs() < 1e-12, "{:?} vs {:?}", fit.g, truth.g);
        }
        assert!(fit.relative_error < 1e-12);
    }

    #[test]
    fn two_lobes_recover_two_lobes_off_the_normal() {
        let basis = Basis::new(4);
        let truth = Lobes {
            axes: vec![
                DVec3::new(0.5, 0.1, 0.86).normalize(),
                DVec3::new(-0.6, 0.3, 0.74).normalize(),
            ],
            g: vec![0.8, 0.5, 0.2, 0.05, 0.3, 0.4, 0.3, 0.1],
            relative_error: 0.0,
        };
        let t = project(&basis, &truth, 1);
        let frame = [DVec3::X, DVec3::Y, DVec3::Z];
        let one = fit_vertex(&basis, &t, 1, frame, 1);
        let two = fit_vertex(&basis, &t, 1, frame, 2);
        assert!(one.relative_error > 0.1, "{}", one.relative_error);
        assert!(two.relative_error < 1e-4, "{}", two.relative_error);
    }
}
