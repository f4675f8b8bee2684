//! Real spherical harmonics with the project's conventions (docs/reference/gltf.md): coefficient
//! (l, m) at index l(l+1)+m, θ from +z, φ from +x towards +y, Condon–Shortley phase
//! (y₁¹ = −0.488603·x). Ported from runtime/three/sh.js and baker/src/math/sh, so that a light
//! turned here is the light `prt-bake light` and `relight` turn.

use bevy::math::{DMat3, DVec3};

/// Number of coefficients of an order (n²).
pub fn coeff_count(order: usize) -> usize {
    order * order
}

/// The band l of coefficient index j (j = l(l+1)+m).
pub fn band(j: usize) -> usize {
    (j as f64 + 0.5).sqrt() as usize
}

/// y_j(d) for j < n², d a unit vector: the associated Legendre recurrence with the
/// Condon–Shortley phase, times Re/Im (x + iy)^m (the baker's `eval_recurrence`).
pub fn basis(order: usize, d: DVec3) -> Vec<f64> {
    let mut y = vec![0.0; coeff_count(order)];
    let factorial = |k: usize| (1..=k).map(|i| i as f64).product::<f64>();
    let (mut c, mut s) = (1.0, 0.0);
    let mut qmm = 1.0;
    for m in 0..order {
        if m > 0 {
            (c, s) = (c * d.x - s * d.y, c * d.y + s * d.x);
            qmm *= -((2 * m - 1) as f64);
        }
        let (mut q1, mut q2) = (qmm, 0.0);
        for l in m..order {
            let q = if l == m {
                qmm
            } else if l == m + 1 {
                d.z * (2 * m + 1) as f64 * qmm
            } else {
                (d.z * (2 * l - 1) as f64 * q1 - (l + m - 1) as f64 * q2) / (l - m) as f64
            };
            if l > m {
                (q2, q1) = (q1, q);
            }
            let k = (((2 * l + 1) as f64 / (4.0 * std::f64::consts::PI))
                * (factorial(l - m) / factorial(l + m)))
            .sqrt();
            let centre = l * (l + 1);
            if m == 0 {
                y[centre] = k * q;
            } else {
                let k = k * std::f64::consts::SQRT_2;
                y[centre + m] = k * q * c;
                y[centre - m] = k * q * s;
            }
        }
    }
    y
}

/// The SH matrix of a rotation, one (2l+1)² row-major block per band: g(s) = f(mᵀs), so a
/// light that shone from d shines from m·d. Ivanic & Ruedenberg's recurrence without the phase,
/// then conjugated by diag((−1)^m), as `shRotation` in sh.js and the baker's rotator.
pub fn rotation(order: usize, m: DMat3) -> Vec<Vec<f64>> {
    // Row-major entries of m.
    let r = |i: usize, j: usize| m.col(j)[i];
    let mut bands: Vec<Vec<f64>> = Vec::with_capacity(order);
    if order > 0 {
        bands.push(vec![1.0]);
    }
    if order > 1 {
        // Band 1 without the phase is (y, z, x).
        let axis = [1, 2, 0];
        let mut b = vec![0.0; 9];
        for i in 0..3 {
            for j in 0..3 {
                b[i * 3 + j] = r(axis[i], axis[j]);
            }
        }
        bands.push(b);
    }
    for l in 2..order {
        let next = band_block(l, &bands[1], &bands[l - 1]);
        bands.push(next);
    }
    for (l, block) in bands.iter_mut().enumerate() {
        let w = 2 * l + 1;
        for i in 0..w {
            for j in 0..w {
                if (i + j) % 2 == 1 {
                    block[i * w + j] = -block[i * w + j];
                }
            }
        }
    }
    bands
}

fn p(l: i64, r1: &[f64], prev: &[f64], i: i64, a: i64, b: i64) -> f64 {
    let r = |x: i64, y: i64| r1[((x + 1) * 3 + (y + 1)) as usize];
    let pw = 2 * l - 1;
    let q = |x: i64, y: i64| prev[((x + l - 1) * pw + (y + l - 1)) as usize];
    if b == l {
        r(i, 1) * q(a, l - 1) - r(i, -1) * q(a, -l + 1)
    } else if b == -l {
        r(i, 1) * q(a, -l + 1) + r(i, -1) * q(a, l - 1)
    } else {
        r(i, 0) * q(a, b)
    }
}

fn band_block(l: usize, r1: &[f64], prev: &[f64]) -> Vec<f64> {
    let l = l as i64;
    let w = (2 * l + 1) as usize;
    let mut block = vec![0.0; w * w];
    let pp = |i, a, b| p(l, r1, prev, i, a, b);
    for m in -l..=l {
        for n in -l..=l {
            let d0 = if m == 0 { 1.0 } else { 0.0 };
            let denominator = if n.abs() == l {
                (2 * l * (2 * l - 1)) as f64
            } else {
                ((l + n) * (l - n)) as f64
            };
            let am = m.abs();
            let u = (((l + m) * (l - m)) as f64 / denominator).sqrt();
            let v = 0.5
                * ((1.0 + d0) * ((l + am - 1) * (l + am)) as f64 / denominator).sqrt()
                * (1.0 - 2.0 * d0);
            let wc = -0.5 * (((l - am - 1) * (l - am)) as f64 / denominator).sqrt() * (1.0 - d0);
            let mut value = 0.0;
            if u != 0.0 {
                value += u * pp(0, m, n);
            }
            if v != 0.0 {
                let s2 = std::f64::consts::SQRT_2;
                let big_v = if m == 0 {
                    pp(1, 1, n) + pp(-1, -1, n)
                } else if m > 0 {
                    pp(1, m - 1, n) * if m == 1 { s2 } else { 1.0 }
                        - if m == 1 { 0.0 } else { pp(-1, -m + 1, n) }
                } else {
                    (if m == -1 { 0.0 } else { pp(1, m + 1, n) })
                        + pp(-1, -m - 1, n) * if m == -1 { s2 } else { 1.0 }
                };
                value += v * big_v;
            }
            if wc != 0.0 {
                let big_w = if m > 0 {
                    pp(1, m + 1, n) + pp(-1, -m - 1, n)
                } else {
                    pp(1, m - 1, n) - pp(-1, -m + 1, n)
                };
                value += wc * big_w;
            }
            block[((m + l) as usize) * w + (n + l) as usize] = value;
        }
    }
    block
}

/// `c` (n² coefficients) turned by the rotation blocks of [`rotation`].
pub fn rotate(bands: &[Vec<f64>], c: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; c.len()];
    for (l, block) in bands.iter().enumerate() {
        let (start, w) = (l * l, 2 * l + 1);
        if start + w > c.len() {
            break;
        }
        for i in 0..w {
            out[start + i] = (0..w).map(|j| block[i * w + j] * c[start + j]).sum();
        }
    }
    out
}

/// The turn from the baker's z-up world to glTF's +Y-up frame: (x, y, z) ↦ (x, z, −y).
pub fn z_up_to_gltf() -> DMat3 {
    DMat3::from_cols(DVec3::X, -DVec3::Z, DVec3::Y)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y₁¹ = −0.488603·x (Condon–Shortley), y₁⁰ = 0.488603·z, y₀⁰ = 0.282095.
    #[test]
    fn basis_has_the_project_conventions() {
        let y = basis(2, DVec3::X);
        assert!((y[0] - 0.282_094_79).abs() < 1e-8);
        assert!((y[3] + 0.488_602_51).abs() < 1e-8);
        let y = basis(2, DVec3::Z);
        assert!((y[2] - 0.488_602_51).abs() < 1e-8);
    }

    /// Turning a delta's coefficients equals the delta at the turned direction, any order.
    #[test]
    fn rotation_carries_a_delta_to_the_turned_direction() {
        let m = DMat3::from_axis_angle(DVec3::new(0.36, 0.8, 0.48).normalize(), 0.87);
        let d = DVec3::new(0.2, -0.5, 0.84).normalize();
        let turned = rotate(&rotation(6, m), &basis(6, d));
        let expected = basis(6, m * d);
        for (a, b) in turned.iter().zip(&expected) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
        assert!((z_up_to_gltf() * DVec3::Z - DVec3::Y).length() < 1e-12);
    }
}
