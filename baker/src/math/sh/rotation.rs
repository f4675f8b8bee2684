//! Rotation of SH coefficient vectors by explicit band matrices.
//!
//! A rotation R acts on a function by g(s) = f(Rᵀs) (the function is carried along with the
//! rotation: a light at +z rotated by R shines from R·z). Its matrix on coefficients is
//! block-diagonal, one orthogonal (2l+1)×(2l+1) block per band, and composes like R:
//! M(R₁R₂) = M(R₁)·M(R₂). Rows and columns of a block run over m = −l..l.
//!
//! Two independent constructions, both exact up to rounding and for any order:
//!
//! * [`ZyzRotator`]: the thesis's (§5) product of fixed and angle-dependent factors,
//!   `R_SH(α, β, γ) = Z_γ · X_−90 · Z_β · X_+90 · Z_α` for `R = Rz(γ)·Ry(β)·Rz(α)`. Z_α mixes
//!   each (m, −m) pair by cos mα and sin mα; the y-rotation is written as a z-rotation between
//!   two fixed 90° x-rotations, Ry(β) = Rx(−90°)·Rz(β)·Rx(+90°), because X_±90 do not depend on
//!   the angle and so are built once per order. A matrix or quaternion is first split into
//!   those ZYZ angles ([`euler_zyz`]), gimbal cases included. The baker turns every
//!   receiver's transfer into world space by these factors applied to the vector in turn
//!   ([`ZyzRotator::rotate`]), which costs far less than building the blocks.
//! * [`ShRotation::from_matrix_recurrence`]: Ivanic & Ruedenberg's recurrence (J. Phys. Chem.
//!   1996, 100, 6342, with the 1998 erratum), which builds band l from band l−1 and the 3×3
//!   matrix. It supplies the X_+90 blocks of the first construction, the blocks of a transfer
//!   matrix's rotation ([`RecurrenceRotator`], applied to every row and column), and the tests
//!   use it and the projection method [`crate::math::sh::Rotator`] to check the ZYZ path.
//!
//! The recurrence is stated for real harmonics without the Condon–Shortley phase; this
//! project's harmonics carry (−1)^m on every m ≠ 0 function, so its blocks are conjugated by
//! diag((−1)^m): entry (m, m′) changes sign when m + m′ is odd.

use glam::{DMat3, DQuat};

use super::basis::coeff_count;

/// The block-diagonal SH matrix of one rotation, for one order.
#[derive(Clone, Debug, PartialEq)]
pub struct ShRotation {
    order: usize,
    /// Band l: the (2l+1)² block, row-major, rows the output m, columns the input m′.
    bands: Vec<Vec<f64>>,
}

impl ShRotation {
    /// The identity of `order` (n² coefficients).
    pub fn identity(order: usize) -> ShRotation {
        ShRotation {
            order,
            bands: (0..order).map(|l| identity_block(2 * l + 1)).collect(),
        }
    }

    /// The thesis's ZYZ construction for R = Rz(γ)·Ry(β)·Rz(α) (radians). Builds X_+90 for
    /// this call; a caller rotating many times should keep a [`ZyzRotator`].
    pub fn from_euler_zyz(order: usize, alpha: f64, beta: f64, gamma: f64) -> ShRotation {
        ZyzRotator::new(order).rotation(alpha, beta, gamma)
    }

    /// The rotation that takes +z to the direction (θ, φ): R = Rz(φ)·Ry(θ), so a light whose
    /// coefficients were projected about +z shines from (θ, φ) after it. This is how the thesis
    /// steers a light: always from its unrotated coefficients and the absolute angles.
    pub fn from_light_angles(order: usize, theta: f64, phi: f64) -> ShRotation {
        ShRotation::from_euler_zyz(order, 0.0, theta, phi)
    }

    /// The ZYZ construction for a rotation matrix (orthonormal, determinant +1).
    pub fn from_matrix(order: usize, m: DMat3) -> ShRotation {
        let (alpha, beta, gamma) = euler_zyz(m);
        ShRotation::from_euler_zyz(order, alpha, beta, gamma)
    }

    /// The ZYZ construction for a unit quaternion.
    pub fn from_quat(order: usize, q: DQuat) -> ShRotation {
        ShRotation::from_matrix(order, DMat3::from_quat(q.normalize()))
    }

    /// Ivanic–Ruedenberg's recurrence for a rotation matrix: the second, independent method.
    /// Builds the recurrence's constants for this call; a caller rotating many times should
    /// keep a [`RecurrenceRotator`].
    pub fn from_matrix_recurrence(order: usize, m: DMat3) -> ShRotation {
        RecurrenceRotator::new(order).rotation(m)
    }

    pub fn order(&self) -> usize {
        self.order
    }

    /// Band l's (2l+1)² block, row-major.
    pub fn band(&self, l: usize) -> &[f64] {
        &self.bands[l]
    }

    /// `out` = the coefficients of g(s) = f(Rᵀs), where `c` holds f's; both n² long.
    pub fn apply(&self, c: &[f64], out: &mut [f64]) {
        let n = coeff_count(self.order);
        assert!(
            c.len() >= n && out.len() >= n,
            "coefficient vectors too short"
        );
        for (l, block) in self.bands.iter().enumerate() {
            let (start, w) = (l * l, 2 * l + 1);
            let input = &c[start..start + w];
            for (i, o) in out[start..start + w].iter_mut().enumerate() {
                *o = block[i * w..(i + 1) * w]
                    .iter()
                    .zip(input)
                    .map(|(a, b)| a * b)
                    .sum();
            }
        }
    }

    /// [`Self::apply`] into a new vector.
    pub fn rotate(&self, c: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; coeff_count(self.order)];
        self.apply(c, &mut out);
        out
    }

    /// The inverse rotation: every block is orthogonal, so its transpose.
    pub fn inverse(&self) -> ShRotation {
        ShRotation {
            order: self.order,
            bands: self
                .bands
                .iter()
                .enumerate()
                .map(|(l, b)| transpose(b, 2 * l + 1))
                .collect(),
        }
    }

    /// `self · other`: the rotation that applies `other` first.
    pub fn then_after(&self, other: &ShRotation) -> ShRotation {
        assert_eq!(self.order, other.order, "rotations of different orders");
        ShRotation {
            order: self.order,
            bands: self
                .bands
                .iter()
                .zip(&other.bands)
                .enumerate()
                .map(|(l, (a, b))| matmul(a, b, 2 * l + 1))
                .collect(),
        }
    }
}

/// Ivanic–Ruedenberg's recurrence with its per-entry constants computed once for an order:
/// for order 4 about 80 entries of a few products each. Where the blocks would be applied
/// once, [`ZyzRotator::rotate`] costs less.
#[derive(Clone, Debug)]
pub struct RecurrenceRotator {
    order: usize,
    /// Band l ≥ 2 at index l − 2: per entry (m, n), row-major, the paper's (u, v, w).
    constants: Vec<Vec<[f64; 3]>>,
}

/// Storage reused by [`ZyzRotator::rotate`]: the coefficients between its factors.
#[derive(Clone, Debug, Default)]
pub struct RotationScratch {
    between: Vec<f64>,
}

impl RecurrenceRotator {
    pub fn new(order: usize) -> RecurrenceRotator {
        RecurrenceRotator {
            order,
            constants: (2..order).map(band_constants).collect(),
        }
    }

    pub fn order(&self) -> usize {
        self.order
    }

    /// The SH matrix of the rotation `m` (orthonormal, determinant +1).
    pub fn rotation(&self, m: DMat3) -> ShRotation {
        let mut plain = self.plain_blocks(m);
        for (l, block) in plain.iter_mut().enumerate() {
            let w = 2 * l + 1;
            for i in 0..w {
                for j in 0..w {
                    if (i + j) % 2 == 1 {
                        // m + m′ = (i − l) + (j − l) is odd exactly when i + j is.
                        block[i * w + j] = -block[i * w + j];
                    }
                }
            }
        }
        ShRotation {
            order: self.order,
            bands: plain,
        }
    }

    /// The band blocks of `m` without the Condon–Shortley phase, band l at index l.
    fn plain_blocks(&self, m: DMat3) -> Vec<Vec<f64>> {
        let mut plain: Vec<Vec<f64>> = (0..self.order)
            .map(|l| vec![0.0; (2 * l + 1) * (2 * l + 1)])
            .collect();
        if self.order > 0 {
            plain[0][0] = 1.0;
        }
        if self.order > 1 {
            // Band 1 without the Condon–Shortley phase is (y, z, x) up to one constant, so its
            // block is R with rows and columns permuted to that order.
            let r = |i: usize, j: usize| m.col(j)[i];
            let axis = [1, 2, 0];
            for (i, &ai) in axis.iter().enumerate() {
                for (j, &aj) in axis.iter().enumerate() {
                    plain[1][i * 3 + j] = r(ai, aj);
                }
            }
        }
        for l in 2..self.order {
            let (done, rest) = plain.split_at_mut(l);
            ivanic_ruedenberg_band(
                l,
                &self.constants[l - 2],
                &done[1],
                &done[l - 1],
                &mut rest[0],
            );
        }
        plain
    }
}

/// The thesis's ZYZ construction with the fixed X_+90 blocks built once for an order.
#[derive(Clone, Debug)]
pub struct ZyzRotator {
    /// X_+90, the SH matrix of Rx(+90°); X_−90 is its transpose.
    x_plus: ShRotation,
    x_minus: ShRotation,
    /// The same without their zero entries, for [`ZyzRotator::rotate`].
    x_plus_entries: NonZero,
    x_minus_entries: NonZero,
}

impl ZyzRotator {
    pub fn new(order: usize) -> ZyzRotator {
        // Rx(+90°) written exactly: cos 90° rounds to 6e-17 in floating point.
        let rx90 = DMat3::from_cols_array(&[1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0]);
        let x_plus = ShRotation::from_matrix_recurrence(order, rx90);
        let x_minus = x_plus.inverse();
        ZyzRotator {
            x_plus_entries: NonZero::new(&x_plus),
            x_minus_entries: NonZero::new(&x_minus),
            x_plus,
            x_minus,
        }
    }

    pub fn order(&self) -> usize {
        self.x_plus.order
    }

    /// R_SH(α, β, γ) = Z_γ · X_−90 · Z_β · X_+90 · Z_α, the SH matrix of Rz(γ)·Ry(β)·Rz(α).
    pub fn rotation(&self, alpha: f64, beta: f64, gamma: f64) -> ShRotation {
        let bands = (0..self.order())
            .map(|l| {
                let w = 2 * l + 1;
                let mut m = z_block(l, alpha);
                m = matmul(&self.x_plus.bands[l], &m, w);
                m = matmul(&z_block(l, beta), &m, w);
                m = matmul(&self.x_minus.bands[l], &m, w);
                matmul(&z_block(l, gamma), &m, w)
            })
            .collect();
        ShRotation {
            order: self.order(),
            bands,
        }
    }

    /// The rotation taking +z to (θ, φ); see [`ShRotation::from_light_angles`].
    pub fn light_angles(&self, theta: f64, phi: f64) -> ShRotation {
        self.rotation(0.0, theta, phi)
    }

    /// `out` = the coefficients of g(s) = f(mᵀs), where `c` holds f's (both n² long), as
    /// `ShRotation::from_matrix(order, m).apply(c, out)` computes them, without building a
    /// block: the five factors are applied to the vector in turn. The two fixed ones cost a
    /// quarter of Σ (2l+1)² products each and the three turns about z 4 per pair, where
    /// building every block by the recurrence costs tens of operations an entry: at order 12,
    /// 1.4 µs against 20 µs for [`RecurrenceRotator::rotation`] and its blocks applied
    /// (`cargo test --release -p prt-baker rotation_speed -- --ignored --nocapture`). The
    /// baker turns every receiver with it.
    pub fn rotate(&self, m: DMat3, c: &[f64], out: &mut [f64], scratch: &mut RotationScratch) {
        let n = coeff_count(self.order());
        let (alpha, beta, gamma) = euler_zyz(m);
        let between = &mut scratch.between;
        between.resize(n, 0.0);
        out[..n].copy_from_slice(&c[..n]);
        turn_about_z(self.order(), alpha, out);
        self.x_plus_entries.apply(out, between);
        turn_about_z(self.order(), beta, between);
        self.x_minus_entries.apply(between, out);
        turn_about_z(self.order(), gamma, out);
    }
}

/// A rotation's blocks with their zero entries left out, row by row: three quarters of X_±90's
/// entries are zeros (an entry couples m and m′ of like parity and like sign only).
#[derive(Clone, Debug)]
struct NonZero {
    /// Output coefficient i's entries are `entries[starts[i]..starts[i + 1]]`.
    starts: Vec<usize>,
    /// (input coefficient, value).
    entries: Vec<(usize, f64)>,
}

impl NonZero {
    fn new(rotation: &ShRotation) -> NonZero {
        let (mut starts, mut entries) = (vec![0], Vec::new());
        for (l, block) in rotation.bands.iter().enumerate() {
            let w = 2 * l + 1;
            for row in block.chunks_exact(w) {
                let columns = row.iter().enumerate().filter(|&(_, &v)| v != 0.0);
                entries.extend(columns.map(|(j, &v)| (l * l + j, v)));
                starts.push(entries.len());
            }
        }
        NonZero { starts, entries }
    }

    /// As [`ShRotation::apply`]: the zeros it leaves out add nothing to a finite sum.
    fn apply(&self, c: &[f64], out: &mut [f64]) {
        for (o, range) in out.iter_mut().zip(self.starts.windows(2)) {
            *o = self.entries[range[0]..range[1]]
                .iter()
                .map(|&(j, v)| v * c[j])
                .sum();
        }
    }
}

/// Z_α ([`z_block`]) applied to every band of `c` in place; cos mα and sin mα by the angle
/// sum from mα's predecessor.
fn turn_about_z(order: usize, alpha: f64, c: &mut [f64]) {
    let (sin, cos) = alpha.sin_cos();
    let (mut s, mut co) = (0.0, 1.0);
    for m in 1..order {
        (s, co) = (s * cos + co * sin, co * cos - s * sin);
        for l in m..order {
            let centre = l * l + l;
            let (plus, minus) = (c[centre + m], c[centre - m]);
            c[centre + m] = plus * co - minus * s;
            c[centre - m] = plus * s + minus * co;
        }
    }
}

/// ZYZ Euler angles (α, β, γ) with `m` = Rz(γ)·Ry(β)·Rz(α), β in [0, π], α and γ in (−π, π].
///
/// Near β = 0 only α + γ is defined, near β = π only γ − α; each is read from the entries
/// that stay well conditioned there ((1 ± cos β)·cos, sin of the sum or difference), and α
/// from the third row, so the angles rebuild `m` to rounding even in the gimbal cases.
pub fn euler_zyz(m: DMat3) -> (f64, f64, f64) {
    let r = |i: usize, j: usize| m.col(j)[i];
    let beta = r(2, 0).hypot(r(2, 1)).atan2(r(2, 2));
    // sin β·(cos α, sin α) = (−r20, r21); at sin β = 0 any α will do, 0 is the convention.
    let alpha = if r(2, 0) == 0.0 && r(2, 1) == 0.0 {
        0.0
    } else {
        r(2, 1).atan2(-r(2, 0))
    };
    let gamma = if r(2, 2) >= 0.0 {
        // (1 + cos β)·(cos, sin)(α + γ) = (r00 + r11, r10 − r01)
        let sum = (r(1, 0) - r(0, 1)).atan2(r(0, 0) + r(1, 1));
        sum - alpha
    } else {
        // (1 − cos β)·(cos, sin)(γ − α) = (r11 − r00, −(r10 + r01))
        let difference = (-(r(1, 0) + r(0, 1))).atan2(r(1, 1) - r(0, 0));
        difference + alpha
    };
    (alpha, beta, wrap_angle(gamma))
}

/// An angle in (−π, π].
fn wrap_angle(a: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    let wrapped = a - tau * (a / tau).round();
    if wrapped <= -std::f64::consts::PI {
        wrapped + tau
    } else {
        wrapped
    }
}

/// Z_α for band l: g(s) = f(Rz(α)ᵀs) turns cos mφ, sin mφ into cos m(φ−α), sin m(φ−α), so
/// (c₊, c₋) ↦ (c₊ cos mα − c₋ sin mα, c₊ sin mα + c₋ cos mα). The phase convention does not
/// enter: the two functions of a pair carry the same sign.
fn z_block(l: usize, alpha: f64) -> Vec<f64> {
    let w = 2 * l + 1;
    let mut z = vec![0.0; w * w];
    z[l * w + l] = 1.0;
    for m in 1..=l {
        let (s, c) = (m as f64 * alpha).sin_cos();
        let (plus, minus) = (l + m, l - m);
        z[plus * w + plus] = c;
        z[plus * w + minus] = -s;
        z[minus * w + plus] = s;
        z[minus * w + minus] = c;
    }
    z
}

/// P^i_{a,b} of the paper, from band 1 `r1` and band l−1 `prev`, both indexed by m from
/// −1..1 and −(l−1)..l−1.
#[inline(always)]
fn recurrence_p(l: usize, r1: &[f64], prev: &[f64], i: i64, a: i64, b: i64) -> f64 {
    let li = l as i64;
    let r = |i: i64, j: i64| r1[((i + 1) * 3 + (j + 1)) as usize];
    let pw = (2 * l - 1) as i64;
    let p_el = |a: i64, b: i64| prev[((a + li - 1) * pw + (b + li - 1)) as usize];
    if b == li {
        r(i, 1) * p_el(a, li - 1) - r(i, -1) * p_el(a, -li + 1)
    } else if b == -li {
        r(i, 1) * p_el(a, -li + 1) + r(i, -1) * p_el(a, li - 1)
    } else {
        r(i, 0) * p_el(a, b)
    }
}

/// The Ivanic–Ruedenberg constants (u, v, w) of band l ≥ 2, per entry (m, n) row-major.
fn band_constants(l: usize) -> Vec<[f64; 3]> {
    let li = l as i64;
    let mut constants = Vec::with_capacity((2 * l + 1) * (2 * l + 1));
    for m in -li..=li {
        for n in -li..=li {
            let d0 = if m == 0 { 1.0 } else { 0.0 };
            let denominator = if n.abs() == li {
                (2 * li * (2 * li - 1)) as f64
            } else {
                ((li + n) * (li - n)) as f64
            };
            let am = m.abs();
            let u = (((li + m) * (li - m)) as f64 / denominator).sqrt();
            let v = 0.5
                * ((1.0 + d0) * ((li + am - 1) * (li + am)) as f64 / denominator).sqrt()
                * (1.0 - 2.0 * d0);
            let w = -0.5 * (((li - am - 1) * (li - am)) as f64 / denominator).sqrt() * (1.0 - d0);
            constants.push([u, v, w]);
        }
    }
    constants
}

/// Band l of the Ivanic–Ruedenberg recurrence (no Condon–Shortley phase) into `block`, from
/// its constants, band 1 `r1` and band l−1 `prev`.
fn ivanic_ruedenberg_band(
    l: usize,
    constants: &[[f64; 3]],
    r1: &[f64],
    prev: &[f64],
    block: &mut [f64],
) {
    let li = l as i64;
    let w = 2 * l + 1;
    let p = |i: i64, a: i64, b: i64| recurrence_p(l, r1, prev, i, a, b);
    // √(1 + δ), written out: √2 and √1 exactly as `sqrt` rounds them.
    let root = |delta: bool| if delta { std::f64::consts::SQRT_2 } else { 1.0 };
    for m in -li..=li {
        for n in -li..=li {
            let index = ((m + li) as usize) * w + (n + li) as usize;
            let [u, v, wc] = constants[index];
            let mut value = 0.0;
            if u != 0.0 {
                value += u * p(0, m, n);
            }
            if v != 0.0 {
                let big_v = if m == 0 {
                    p(1, 1, n) + p(-1, -1, n)
                } else if m > 0 {
                    p(1, m - 1, n) * root(m == 1)
                        - p(-1, -m + 1, n) * if m == 1 { 0.0 } else { 1.0 }
                } else {
                    p(1, m + 1, n) * if m == -1 { 0.0 } else { 1.0 }
                        + p(-1, -m - 1, n) * root(m == -1)
                };
                value += v * big_v;
            }
            if wc != 0.0 {
                let big_w = if m > 0 {
                    p(1, m + 1, n) + p(-1, -m - 1, n)
                } else {
                    p(1, m - 1, n) - p(-1, -m + 1, n)
                };
                value += wc * big_w;
            }
            block[index] = value;
        }
    }
}

fn identity_block(w: usize) -> Vec<f64> {
    let mut m = vec![0.0; w * w];
    for i in 0..w {
        m[i * w + i] = 1.0;
    }
    m
}

fn transpose(a: &[f64], w: usize) -> Vec<f64> {
    let mut t = vec![0.0; w * w];
    for i in 0..w {
        for j in 0..w {
            t[j * w + i] = a[i * w + j];
        }
    }
    t
}

fn matmul(a: &[f64], b: &[f64], w: usize) -> Vec<f64> {
    let mut c = vec![0.0; w * w];
    for i in 0..w {
        for k in 0..w {
            let aik = a[i * w + k];
            if aik != 0.0 {
                for j in 0..w {
                    c[i * w + j] += aik * b[k * w + j];
                }
            }
        }
    }
    c
}

#[cfg(test)]
mod tests;
