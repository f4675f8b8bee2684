//! The real SH basis: its indexing, normalisation and evaluation, Gauss–Legendre quadrature
//! and the projection rotator ([`Rotator`]), the independent check of [`super::rotation`].

use glam::Vec3;
use std::f64::consts::PI;

/// Highest order the library accepts (2,025 coefficients); the recurrences stay accurate far
/// beyond what low-frequency PRT needs.
pub const MAX_ORDER: usize = 45;

/// Orders at or below this use the hard-coded polynomials.
pub const HARDCODED_MAX_ORDER: usize = 4;

/// Number of coefficients of an order-n projection: n².
pub const fn coeff_count(order: usize) -> usize {
    order * order
}

/// Storage index of coefficient (l, m): l(l+1)+m.
pub const fn index(l: usize, m: i32) -> usize {
    ((l * (l + 1)) as isize + m as isize) as usize
}

/// The inverse of [`index`]: (l, m) for a storage index.
pub fn band_and_m(i: usize) -> (usize, i32) {
    let l = (i as f64).sqrt() as usize;
    (l, i as i32 - (l * (l + 1)) as i32)
}

/// K_l^m = sqrt((2l+1)/(4π) · (l−|m|)!/(l+|m|)!), with the factorial ratio as a running
/// product so it neither overflows nor loses precision for high bands.
pub fn normalization(l: usize, m: i32) -> f64 {
    let m = m.unsigned_abs() as usize;
    let ratio: f64 = ((l - m + 1)..=(l + m)).map(|k| 1.0 / k as f64).product();
    ((2 * l + 1) as f64 / (4.0 * PI) * ratio).sqrt()
}

/// P_l^m(x) for 0 ≤ m ≤ l by the thesis's three relations, Condon–Shortley phase included.
pub fn legendre(l: usize, m: usize, x: f64) -> f64 {
    assert!(m <= l, "legendre: m = {m} > l = {l}");
    // (3) P_m^m = (−1)^m (2m−1)!! (1−x²)^{m/2}
    let mut pmm = 1.0;
    let somx2 = ((1.0 - x) * (1.0 + x)).max(0.0).sqrt();
    for i in 1..=m {
        pmm *= -((2 * i - 1) as f64) * somx2;
    }
    if l == m {
        return pmm;
    }
    // (2) P_{m+1}^m = x(2m+1) P_m^m
    let mut pmmp1 = x * (2 * m + 1) as f64 * pmm;
    // (1) (l−m) P_l^m = x(2l−1) P_{l−1}^m − (l+m−1) P_{l−2}^m
    for ll in (m + 2)..=l {
        let pll = (x * (2 * ll - 1) as f64 * pmmp1 - (ll + m - 1) as f64 * pmm) / (ll - m) as f64;
        pmm = pmmp1;
        pmmp1 = pll;
    }
    pmmp1
}

/// y_l^m(θ, φ) exactly as the thesis writes it. Slow (trigonometry, no reuse); kept public as
/// the reference the fast paths are tested against.
pub fn eval_slow(l: usize, m: i32, theta: f64, phi: f64) -> f64 {
    let k = normalization(l, m);
    let am = m.unsigned_abs() as usize;
    let p = legendre(l, am, theta.cos());
    match m {
        0 => k * p,
        m if m > 0 => std::f64::consts::SQRT_2 * k * (m as f64 * phi).cos() * p,
        _ => std::f64::consts::SQRT_2 * k * (am as f64 * phi).sin() * p,
    }
}

/// Spherical angles (θ, φ) of a direction, in this module's convention.
pub fn angles(dir: glam::DVec3) -> (f64, f64) {
    let d = dir.normalize();
    (d.z.clamp(-1.0, 1.0).acos(), d.y.atan2(d.x))
}

/// Evaluates all n² basis functions of one order at unit directions.
#[derive(Clone, Debug)]
pub struct Basis {
    order: usize,
    /// √2·K_l^m for m > 0 and K_l^0 for m = 0, indexed like the coefficients (m ≥ 0 slots).
    scale: Vec<f64>,
}

impl Basis {
    /// Panics if `order` is 0 or above [`MAX_ORDER`]; callers validate user input first.
    pub fn new(order: usize) -> Basis {
        assert!(
            (1..=MAX_ORDER).contains(&order),
            "SH order {order} outside 1..={MAX_ORDER}"
        );
        let mut scale = vec![0.0; coeff_count(order)];
        for l in 0..order {
            for m in 0..=l as i32 {
                let k = normalization(l, m);
                scale[index(l, m)] = if m == 0 {
                    k
                } else {
                    std::f64::consts::SQRT_2 * k
                };
            }
        }
        Basis { order, scale }
    }

    pub fn order(&self) -> usize {
        self.order
    }

    pub fn coeff_count(&self) -> usize {
        coeff_count(self.order)
    }

    /// Writes y_i(dir) for i < n² into `out[..n²]`. `dir` must be unit length.
    #[inline]
    pub fn eval(&self, dir: Vec3, out: &mut [f32]) {
        if self.order <= HARDCODED_MAX_ORDER {
            eval_hardcoded(self.order, dir, out);
        } else {
            self.recurrence(dir.as_dvec3(), |i, y| out[i] = y as f32);
        }
    }

    /// The recurrence path in f64, for any order: relations (1)–(3) applied to
    /// Q_l^m(z) = P_l^m(z)/(1−z²)^{m/2}, times Re/Im (x+iy)^m = sin^m θ·(cos mφ, sin mφ).
    pub fn eval_recurrence(&self, dir: glam::DVec3, out: &mut [f64]) {
        self.recurrence(dir, |i, y| out[i] = y);
    }

    #[inline]
    fn recurrence(&self, dir: glam::DVec3, mut store: impl FnMut(usize, f64)) {
        let (x, y, z) = (dir.x, dir.y, dir.z);
        let (mut c, mut s) = (1.0f64, 0.0f64); // (x + iy)^m
        let mut qmm = 1.0f64; // Q_m^m = (−1)^m (2m−1)!!
        for m in 0..self.order {
            if m > 0 {
                (c, s) = (c * x - s * y, c * y + s * x);
                qmm *= -((2 * m - 1) as f64);
            }
            let (mut q2, mut q1) = (0.0f64, qmm); // Q_{l−2}^m, Q_{l−1}^m
            for l in m..self.order {
                let q = if l == m {
                    qmm
                } else if l == m + 1 {
                    z * (2 * m + 1) as f64 * qmm
                } else {
                    (z * (2 * l - 1) as f64 * q1 - (l + m - 1) as f64 * q2) / (l - m) as f64
                };
                if l > m {
                    (q2, q1) = (q1, q);
                }
                let k = self.scale[index(l, m as i32)];
                if m == 0 {
                    store(index(l, 0), k * q);
                } else {
                    store(index(l, m as i32), k * q * c);
                    store(index(l, -(m as i32)), k * q * s);
                }
            }
        }
    }
}

/// Hard-coded polynomials for orders 1–4 (bands 0–3), derived from the definitions above;
/// the tests check them against the recurrence.
#[inline]
pub fn eval_hardcoded(order: usize, d: Vec3, out: &mut [f32]) {
    debug_assert!((1..=HARDCODED_MAX_ORDER).contains(&order));
    let (x, y, z) = (d.x, d.y, d.z);
    out[0] = 0.282_094_8;
    if order == 1 {
        return;
    }
    out[1] = -0.488_602_5 * y;
    out[2] = 0.488_602_5 * z;
    out[3] = -0.488_602_5 * x;
    if order == 2 {
        return;
    }
    let (xx, yy, zz) = (x * x, y * y, z * z);
    out[4] = 1.092_548_4 * x * y;
    out[5] = -1.092_548_4 * y * z;
    out[6] = 0.315_391_57 * (3.0 * zz - 1.0);
    out[7] = -1.092_548_4 * x * z;
    out[8] = 0.546_274_2 * (xx - yy);
    if order == 3 {
        return;
    }
    let five_zz_minus_one = 5.0 * zz - 1.0;
    out[9] = -0.590_043_6 * y * (3.0 * xx - yy);
    out[10] = 2.890_611_4 * x * y * z;
    out[11] = -0.457_045_8 * y * five_zz_minus_one;
    out[12] = 0.373_176_33 * z * (5.0 * zz - 3.0);
    out[13] = -0.457_045_8 * x * five_zz_minus_one;
    out[14] = 1.445_305_7 * z * (xx - yy);
    out[15] = -0.590_043_6 * x * (xx - 3.0 * yy);
}

/// Gauss–Legendre quadrature on [−1, 1]: `n` nodes and weights, exact for polynomials of
/// degree ≤ 2n−1. Used for exact projections of zonal functions and by the tests.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(n >= 1, "gauss_legendre needs at least one node");
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        // Newton's method on P_n from Tricomi's initial guess.
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut derivative = 0.0;
        for _ in 0..100 {
            // (p_prev, p) = (P_{n−1}(x), P_n(x)) by Bonnet's recurrence.
            let (mut p_prev, mut p) = (1.0, x);
            for k in 2..=n {
                (p_prev, p) = (
                    p,
                    ((2 * k - 1) as f64 * x * p - (k - 1) as f64 * p_prev) / k as f64,
                );
            }
            derivative = n as f64 * (x * p - p_prev) / (x * x - 1.0);
            let step = p / derivative;
            x -= step;
            if step.abs() < 1e-16 {
                break;
            }
        }
        nodes[i] = -x;
        nodes[n - 1 - i] = x;
        let w = 2.0 / ((1.0 - x * x) * derivative * derivative);
        weights[i] = w;
        weights[n - 1 - i] = w;
    }
    (nodes, weights)
}

/// Rotates SH coefficient vectors by arbitrary rotations, band by band.
///
/// Method: projection of the rotated basis. Each band's functions span a rotation-invariant
/// space, so for K ≥ 2l+1 well-spread directions s_k the band-l coefficients c' of the rotated
/// function f(Rᵀs) satisfy A c' = B c exactly, with A_km = y_lm(s_k) and B_km = y_lm(Rᵀ s_k).
/// A's pseudo-inverse is computed once; a rotation then costs K basis evaluations and two
/// small matrix-vector products per band. Exact up to rounding, for any order; the baker
/// uses it once per vertex to bring local-frame transfer into world space.
#[derive(Clone, Debug)]
pub struct Rotator {
    basis: Basis,
    /// Fibonacci-sphere directions.
    dirs: Vec<glam::DVec3>,
    /// Per band l: the (2l+1) × K pseudo-inverse of A, row-major.
    pinv: Vec<Vec<f64>>,
}

impl Rotator {
    pub fn new(order: usize) -> Rotator {
        let basis = Basis::new(order);
        let k = 2 * coeff_count(order) + 2;
        let golden = PI * (3.0 - 5f64.sqrt());
        let dirs: Vec<glam::DVec3> = (0..k)
            .map(|i| {
                let z = 1.0 - (2.0 * i as f64 + 1.0) / k as f64;
                let r = (1.0 - z * z).sqrt();
                let phi = golden * i as f64;
                glam::DVec3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect();
        let mut y = vec![0.0; k * coeff_count(order)];
        for (row, d) in y.chunks_mut(coeff_count(order)).zip(&dirs) {
            basis.eval_recurrence(*d, row);
        }
        let pinv = (0..order)
            .map(|l| {
                let w = 2 * l + 1;
                let a = |kk: usize, m: usize| y[kk * coeff_count(order) + l * l + m];
                // (AᵀA)⁻¹Aᵀ by Gauss–Jordan on the small normal matrix.
                let mut ata = vec![0.0; w * w];
                for i in 0..w {
                    for j in 0..w {
                        ata[i * w + j] = (0..k).map(|kk| a(kk, i) * a(kk, j)).sum();
                    }
                }
                let inv = invert(&ata, w);
                let mut p = vec![0.0; w * k];
                for i in 0..w {
                    for kk in 0..k {
                        p[i * k + kk] = (0..w).map(|j| inv[i * w + j] * a(kk, j)).sum();
                    }
                }
                p
            })
            .collect();
        Rotator { basis, dirs, pinv }
    }

    pub fn order(&self) -> usize {
        self.basis.order()
    }

    /// `out` = coefficients of the function rotated by `r`, g(s) = f(rᵀ s), where `c` holds
    /// f's coefficients. `r` must be a rotation (orthonormal, determinant +1).
    pub fn rotate(&self, r: glam::DMat3, c: &[f64], out: &mut [f64]) {
        let n = coeff_count(self.order());
        let k = self.dirs.len();
        let rt = r.transpose();
        let mut b = vec![0.0; k * n];
        for (row, d) in b.chunks_mut(n).zip(&self.dirs) {
            self.basis.eval_recurrence(rt * *d, row);
        }
        let mut bc = vec![0.0; k];
        for l in 0..self.order() {
            let (start, w) = (l * l, 2 * l + 1);
            for (kk, value) in bc.iter_mut().enumerate() {
                let row = &b[kk * n + start..kk * n + start + w];
                *value = row
                    .iter()
                    .zip(&c[start..start + w])
                    .map(|(y, c)| y * c)
                    .sum();
            }
            for (i, o) in out[start..start + w].iter_mut().enumerate() {
                let p = &self.pinv[l][i * k..(i + 1) * k];
                *o = p.iter().zip(&bc).map(|(p, v)| p * v).sum();
            }
        }
    }
}

/// Inverse of a small, well-conditioned square matrix (row-major) by Gauss–Jordan elimination
/// with partial pivoting.
fn invert(m: &[f64], w: usize) -> Vec<f64> {
    let mut a = m.to_vec();
    let mut inv = vec![0.0; w * w];
    for i in 0..w {
        inv[i * w + i] = 1.0;
    }
    for col in 0..w {
        let pivot = (col..w)
            .max_by(|&i, &j| a[i * w + col].abs().total_cmp(&a[j * w + col].abs()))
            .expect("non-empty range");
        for j in 0..w {
            a.swap(col * w + j, pivot * w + j);
            inv.swap(col * w + j, pivot * w + j);
        }
        let d = a[col * w + col];
        assert!(d.abs() > 1e-12, "singular matrix in SH rotation set-up");
        for j in 0..w {
            a[col * w + j] /= d;
            inv[col * w + j] /= d;
        }
        for i in 0..w {
            if i != col {
                let f = a[i * w + col];
                for j in 0..w {
                    a[i * w + j] -= f * a[col * w + j];
                    inv[i * w + j] -= f * inv[col * w + j];
                }
            }
        }
    }
    inv
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn dir(theta: f64, phi: f64) -> DVec3 {
        DVec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    }

    #[test]
    fn index_round_trips() {
        for i in 0..coeff_count(12) {
            let (l, m) = band_and_m(i);
            assert_eq!(index(l, m), i);
            assert!(m.unsigned_abs() as usize <= l);
        }
    }

    #[test]
    fn band_one_has_the_stated_condon_shortley_signs() {
        let basis = Basis::new(2);
        let mut y = [0.0f32; 4];
        for d in [Vec3::X, Vec3::Y, Vec3::Z] {
            basis.eval(d, &mut y);
            let expect = [-0.488_602_5 * d.y, 0.488_602_5 * d.z, -0.488_602_5 * d.x];
            assert_eq!(&y[1..], &expect, "direction {d}");
        }
    }

    #[test]
    fn legendre_matches_closed_forms() {
        for x in [-1.0, -0.3, 0.0, 0.55, 1.0f64] {
            let s = (1.0 - x * x).sqrt();
            assert!((legendre(2, 0, x) - 0.5 * (3.0 * x * x - 1.0)).abs() < 1e-14);
            assert!((legendre(2, 1, x) + 3.0 * x * s).abs() < 1e-14);
            assert!((legendre(3, 3, x) + 15.0 * s * s * s).abs() < 1e-13);
        }
    }

    #[test]
    fn recurrence_equals_the_thesis_formulas_up_to_order_12() {
        let basis = Basis::new(12);
        let mut y = vec![0.0; basis.coeff_count()];
        for k in 0..200 {
            let theta = PI * ((k as f64 * 0.618_034) % 1.0);
            let phi = 2.0 * PI * ((k as f64 * 0.414_214) % 1.0) - PI;
            basis.eval_recurrence(dir(theta, phi), &mut y);
            for (i, &value) in y.iter().enumerate() {
                let (l, m) = band_and_m(i);
                let slow = eval_slow(l, m, theta, phi);
                assert!(
                    (value - slow).abs() < 1e-9 * (1.0 + slow.abs()),
                    "l={l} m={m}: {value} vs {slow}"
                );
            }
        }
    }

    #[test]
    fn hardcoded_path_equals_recurrence() {
        for order in 1..=HARDCODED_MAX_ORDER {
            let basis = Basis::new(order);
            let (mut fast, mut slow) = (vec![0.0f32; order * order], vec![0.0f64; order * order]);
            for k in 0..500 {
                let d = dir(
                    (k as f64 * 0.754_877) % PI,
                    (k as f64 * 2.569_858) % (2.0 * PI),
                );
                eval_hardcoded(order, d.as_vec3(), &mut fast);
                basis.eval_recurrence(d, &mut slow);
                for i in 0..order * order {
                    assert!(
                        (fast[i] as f64 - slow[i]).abs() < 2e-6,
                        "order {order} index {i}"
                    );
                }
            }
        }
    }

    /// Evaluates an SH expansion at a direction.
    fn expand(basis: &Basis, c: &[f64], d: DVec3) -> f64 {
        let mut y = vec![0.0; c.len()];
        basis.eval_recurrence(d, &mut y);
        y.iter().zip(c).map(|(y, c)| y * c).sum()
    }

    #[test]
    fn rotated_coefficients_evaluate_to_the_inversely_rotated_function() {
        for order in [1, 2, 4, 6, 8] {
            let basis = Basis::new(order);
            let rotator = Rotator::new(order);
            let n = coeff_count(order);
            for trial in 0..5 {
                let c: Vec<f64> = (0..n)
                    .map(|i| ((i * 7 + trial * 3) as f64 * 0.37).sin())
                    .collect();
                let axis =
                    DVec3::new(0.3 + trial as f64, -0.7, 0.2 * trial as f64 + 0.1).normalize();
                let r = glam::DMat3::from_axis_angle(axis, 0.4 + trial as f64);
                let mut rotated = vec![0.0; n];
                rotator.rotate(r, &c, &mut rotated);
                for k in 0..20 {
                    let d = dir((k as f64 * 0.77) % PI, k as f64 * 1.3);
                    let want = expand(&basis, &c, r.transpose() * d);
                    let got = expand(&basis, &rotated, d);
                    assert!((want - got).abs() < 1e-9, "order {order}: {want} vs {got}");
                }
            }
        }
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let (x, w) = gauss_legendre(6);
        assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-14);
        // ∫ x^10 dx over [−1, 1] = 2/11, degree 10 ≤ 2·6 − 1.
        let integral: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(10)).sum();
        assert!((integral - 2.0 / 11.0).abs() < 1e-14);
    }

    /// Orthonormality to 1e-6 up to order 10 by a quadrature exact for every product of two
    /// basis functions of bands < 10: Gauss–Legendre in cos θ (degree ≤ 18 needs 10 nodes;
    /// 12 are used) times the trapezoid rule in φ (exact for trigonometric degree < 24).
    #[test]
    fn basis_is_orthonormal_up_to_order_10() {
        let order = 10;
        let n = coeff_count(order);
        let basis = Basis::new(order);
        let (zs, ws) = gauss_legendre(12);
        let phis = 24;
        let mut gram = vec![0.0f64; n * n];
        let mut y64 = vec![0.0; n];
        let mut y32 = vec![0.0f32; n];
        for (z, wz) in zs.iter().zip(&ws) {
            for k in 0..phis {
                let phi = 2.0 * PI * k as f64 / phis as f64;
                let r = (1.0 - z * z).sqrt();
                let d = DVec3::new(r * phi.cos(), r * phi.sin(), *z);
                basis.eval_recurrence(d, &mut y64);
                // Check the f32 entry point too: it is what bakes call.
                basis.eval(d.as_vec3(), &mut y32);
                for (a, b) in y64.iter().zip(&y32) {
                    assert!((a - *b as f64).abs() < 1e-5);
                }
                let weight = wz * 2.0 * PI / phis as f64;
                for i in 0..n {
                    for j in 0..n {
                        gram[i * n + j] += weight * y64[i] * y64[j];
                    }
                }
            }
        }
        for i in 0..n {
            for j in 0..n {
                let expect = if i == j { 1.0 } else { 0.0 };
                assert!(
                    (gram[i * n + j] - expect).abs() < 1e-6,
                    "<y{i}, y{j}> = {}",
                    gram[i * n + j]
                );
            }
        }
    }
}
