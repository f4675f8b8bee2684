//! Texels whose shading normals vary (a normal map) are fitted in the normal too: a
//! first-order fit in (u, v, a, b), where (a, b) is a neighbour's shading normal less the
//! cluster's, in the cluster's tangent frame.
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

use glam::Vec3;

use super::cholesky;

/// Below this spread of the neighbours' normal offsets (about 0.6°) the fit stays in the
/// plane.
pub(super) const SPREAD: f32 = 0.01;
/// A ridge on the normal's slopes, relative to the kernel's mass: a neighbourhood whose
/// normals vary along one direction only fits no slope across it. Small beside the offsets'
/// own second moment (about 10⁻² for a normal map's ±6°).
const RIDGE: f64 = 1e-4;
/// The plane slopes' ridge, as the plane-only fit's.
const PLANE_RIDGE: f64 = 1e-2;

/// The fit's terms: 1, u, v, a, b.
pub(super) const TERMS: usize = 5;

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

/// Turns kernel entries (k, [w, u, v]) with normal offsets `offsets` into the fit's weights:
/// entry k's weight at a member's (1, u, v, a, b) is the dot of that with
/// (entry[0], entry[1], entry[2], normal[0], normal[1]); `normal` receives the last two.
/// Returns false (entries untouched) where the system is singular.
pub(super) fn fit(
    kernel: &mut [(u32, [f32; 3])],
    offsets: &[[f32; 2]],
    normal: &mut Vec<[f32; 2]>,
) -> bool {
    let x = |[_, u, v]: [f32; 3], [a, b]: [f32; 2]| [1.0, u, v, a, b].map(f64::from);
    let mut m = [[0.0f64; TERMS]; TERMS];
    for (&(_, e), &o) in kernel.iter().zip(offsets) {
        let (x, w) = (x(e, o), f64::from(e[0]));
        for p in 0..TERMS {
            for q in 0..=p {
                m[p][q] += w * x[p] * x[q];
            }
        }
    }
    let mass = m[0][0];
    m[1][1] += PLANE_RIDGE * mass;
    m[2][2] += PLANE_RIDGE * mass;
    m[3][3] += RIDGE * mass;
    m[4][4] += RIDGE * mass;
    let Some(l) = cholesky::factor(&m, 0.0) else {
        return false;
    };
    normal.clear();
    for (entry, &o) in kernel.iter_mut().zip(offsets) {
        let e = entry.1;
        let mut y = x(e, o);
        cholesky::solve(&l, &mut y);
        let w = f64::from(e[0]);
        entry.1 = [y[0], y[1], y[2]].map(|y| (y * w) as f32);
        normal.push([y[3], y[4]].map(|y| (y * w) as f32));
    }
    true
}

#[cfg(test)]
mod tests {
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
        let mut normal = Vec::new();
        assert!(varies(&offsets));
        assert!(fit(&mut kernel, &offsets, &mut normal));
        for (u, v, a, b) in [(0.0, 0.0, 0.0, 0.0), (1.0, -0.5, 0.1, 0.05)] {
            let place = [1.0, u, v, a, b];
            let weight = |n: usize| {
                let (e, o) = (kernel[n].1, normal[n]);
                e[0] * place[0]
                    + e[1] * place[1]
                    + e[2] * place[2]
                    + o[0] * place[3]
                    + o[1] * place[4]
            };
            let total: f32 = (0..kernel.len()).map(weight).sum();
            let fitted: f32 = (0..kernel.len()).map(|n| weight(n) * values[n]).sum();
            assert!((total - 1.0).abs() < 1e-4, "weights sum to {total}");
            // The ridges shrink the slopes a little.
            let want = value(u, v, a, b);
            assert!((fitted - want).abs() < 0.02, "{fitted} against {want}");
        }
    }
}
