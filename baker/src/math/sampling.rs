//! Directions for the Monte Carlo transfer estimators.
//!
//! The diffuse transfer integrand is (1/π)·V(s)·max(n·s, 0)·y_j(s). Drawing s from the
//! cosine-weighted density p(s) = max(n·s, 0)/π turns the estimator into
//!
//! ```text
//!     T_j ≈ (1/N) Σ_i V(s_i) · y_j(s_i)
//! ```
//!
//! the cosine and the 1/π cancel, every ray goes into the upper hemisphere, and none is
//! wasted below the horizon (the thesis samples the whole sphere and throws half away).
//!
//! [`Sampling::OwenSobol`] (the default) takes the first N points of the 2-D Sobol
//! (0,2)-sequence with hash-based Owen scrambling (Burley, "Practical Hash-based Owen
//! Scrambling", JCGT 2020): an unbiased, stratified point set. For N a power of two it is a
//! scrambled (0,m,2)-net, whose variance for any square-integrable integrand is at most
//! e ≈ 2.72 times that of N independent samples (Owen 1997, t = 0, base b ≥ s) and, for the
//! smooth parts of the integrand, far lower. The tests derive their tolerances from that
//! bound. How the baker shares one such set between vertices is described in
//! [`crate::bake::transfer`].
//!
//! [`Sampling::ThesisRandom`] is the thesis's method, kept as the baseline to beat: independent
//! uniform directions on the sphere, θ = 2·arccos √(1−X), φ = 2πY, weighted by 4π/N.
//!
//! Everything is a pure function of (seed, vertex, sample index), so bakes are bit-identical
//! whatever the number of threads.

use glam::Vec3;

/// How the directions of a vertex are chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Sampling {
    /// Owen-scrambled Sobol points, cosine-weighted over the hemisphere.
    #[default]
    OwenSobol,
    /// The thesis's independent uniform directions over the whole sphere.
    ThesisRandom,
}

impl Sampling {
    pub fn name(self) -> &'static str {
        match self {
            Sampling::OwenSobol => "owen-sobol",
            Sampling::ThesisRandom => "thesis-random",
        }
    }
}

/// A 64-bit finaliser (splitmix64) used to derive independent per-vertex seeds.
#[inline]
pub fn mix64(mut x: u64) -> u64 {
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// The seed of one vertex's point set: depends only on the bake seed and the vertex index.
#[inline]
pub fn vertex_seed(seed: u64, vertex: u64) -> u64 {
    mix64(mix64(seed ^ 0x5052_545f_6261_6b65).wrapping_add(vertex))
}

/// Sobol's second dimension: generator columns v_0 = 2^31, v_k = v_{k−1} ⊕ (v_{k−1} >> 1).
#[inline]
fn sobol_dim1(index: u32) -> u32 {
    let (mut result, mut v, mut i) = (0u32, 1u32 << 31, index);
    while i != 0 {
        if i & 1 != 0 {
            result ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    result
}

/// Laine–Karras-style hash permutation (Burley 2020, listing 3): applied to bit-reversed
/// values it is a nested uniform (Owen) scramble.
#[inline]
fn laine_karras_permutation(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

#[inline]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras_permutation(x.reverse_bits(), seed).reverse_bits()
}

/// 32 random bits to a float in [0, 1): the top 24 bits, so the result is never 1.
#[inline]
pub fn to_unit_float(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// The Owen-scrambled Sobol points of one vertex.
#[derive(Clone, Copy, Debug)]
pub struct OwenSobol {
    seeds: [u32; 2],
}

impl OwenSobol {
    pub fn new(vertex_seed: u64) -> OwenSobol {
        let h = mix64(vertex_seed);
        OwenSobol {
            seeds: [h as u32, (h >> 32) as u32],
        }
    }

    /// Point `i` of the set, in [0, 1)².
    #[inline]
    pub fn point(&self, i: u32) -> (f32, f32) {
        let (x, y) = self.bits(i);
        (to_unit_float(x), to_unit_float(y))
    }

    /// Point `i` as 32-bit fixed-point coordinates (u = bits / 2³²): exact, so the cells of
    /// the net it belongs to are its leading bits.
    #[inline]
    pub fn bits(&self, i: u32) -> (u32, u32) {
        (
            owen_scramble(i.reverse_bits(), self.seeds[0]),
            owen_scramble(sobol_dim1(i), self.seeds[1]),
        )
    }
}

/// PCG32 (O'Neill 2014, XSH-RR): the independent random numbers of the thesis baseline.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    pub fn new(seed: u64, stream: u64) -> Pcg32 {
        let mut rng = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        to_unit_float(self.next_u32())
    }
}

/// Position of a point of [0, 1)² along a Hilbert curve over a 2^16 × 2^16 grid. Sorting
/// sample points by it makes consecutive points, and so consecutive rays, close in direction.
pub fn hilbert_index(x: f32, y: f32) -> u64 {
    const SIDE: u32 = 1 << 16;
    let quantize = |t: f32| ((t * SIDE as f32) as u32).min(SIDE - 1);
    let (mut x, mut y) = (quantize(x), quantize(y));
    let mut d = 0u64;
    let mut s = SIDE / 2;
    while s > 0 {
        let rx = u32::from(x & s != 0);
        let ry = u32::from(y & s != 0);
        d += u64::from(s) * u64::from(s) * u64::from((3 * rx) ^ ry);
        // Rotate the quadrant so the curve stays continuous.
        if ry == 0 {
            if rx == 1 {
                x = SIDE - 1 - x;
                y = SIDE - 1 - y;
            }
            std::mem::swap(&mut x, &mut y);
        }
        s /= 2;
    }
    d
}

/// Maps [0, 1)² to the cosine-weighted hemisphere around +z (Malley's method on the polar
/// disk mapping): density cos θ / π.
#[inline]
pub fn cosine_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let (s, c) = (std::f32::consts::TAU * u2).sin_cos();
    Vec3::new(r * c, r * s, (1.0 - u1).max(0.0).sqrt())
}

/// The thesis's mapping of [0, 1)² to uniform directions on the sphere: θ = 2·arccos √(1−X),
/// φ = 2πY (density 1/4π).
#[inline]
pub fn uniform_sphere(x: f32, y: f32) -> Vec3 {
    let cos_theta = 1.0 - 2.0 * x; // cos(2·arccos √(1−X)) = 2(1−X) − 1
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let (s, c) = (std::f32::consts::TAU * y).sin_cos();
    Vec3::new(sin_theta * c, sin_theta * s, cos_theta)
}

/// An orthonormal frame around a unit normal (Duff et al. 2017, through glam).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub tangent: Vec3,
    pub bitangent: Vec3,
    pub normal: Vec3,
}

impl Frame {
    pub fn from_normal(normal: Vec3) -> Frame {
        let (tangent, bitangent) = normal.any_orthonormal_pair();
        Frame {
            tangent,
            bitangent,
            normal,
        }
    }

    /// A direction given in the frame (z along the normal) in world space.
    #[inline]
    pub fn to_world(&self, local: Vec3) -> Vec3 {
        self.tangent * local.x + self.bitangent * local.y + self.normal * local.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_points_are_stratified_for_every_power_of_two() {
        let set = OwenSobol::new(vertex_seed(7, 3));
        for log_n in 0..=10 {
            let n = 1u32 << log_n;
            // A (0, m, 2)-net: every elementary interval of area 1/n holds exactly one point.
            for log_cols in 0..=log_n {
                let (cols, rows) = (1u32 << log_cols, n >> log_cols);
                let mut seen = vec![false; n as usize];
                for i in 0..n {
                    let (x, y) = set.point(i);
                    let cell = (y * rows as f32) as u32 * cols + (x * cols as f32) as u32;
                    assert!(
                        !seen[cell as usize],
                        "n={n} {cols}x{rows}: cell {cell} twice"
                    );
                    seen[cell as usize] = true;
                }
            }
        }
    }

    #[test]
    fn vertex_scrambles_differ_and_repeat() {
        let a = OwenSobol::new(vertex_seed(1, 0));
        let b = OwenSobol::new(vertex_seed(1, 1));
        let c = OwenSobol::new(vertex_seed(2, 0));
        assert_ne!(a.point(5), b.point(5));
        assert_ne!(a.point(5), c.point(5));
        assert_eq!(a.point(5), OwenSobol::new(vertex_seed(1, 0)).point(5));
    }

    #[test]
    fn cosine_hemisphere_has_the_right_moments() {
        // Under p = cos θ / π: E[z] = 2/3, E[z²] = 1/2, E[x] = E[y] = 0.
        let n = 1 << 16;
        let set = OwenSobol::new(11);
        let (mut ez, mut ez2, mut ex) = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..n {
            let (u1, u2) = set.point(i);
            let d = cosine_hemisphere(u1, u2);
            assert!((d.length() - 1.0).abs() < 1e-5 && d.z >= 0.0);
            ez += d.z as f64;
            ez2 += (d.z * d.z) as f64;
            ex += d.x as f64;
        }
        let n = n as f64;
        assert!((ez / n - 2.0 / 3.0).abs() < 1e-4, "{}", ez / n);
        assert!((ez2 / n - 0.5).abs() < 1e-4);
        assert!((ex / n).abs() < 1e-4);
    }

    #[test]
    fn thesis_mapping_is_uniform_on_the_sphere() {
        // Uniform on the sphere: z is uniform on [−1, 1], so E[z] = 0 and E[z²] = 1/3.
        let mut rng = Pcg32::new(5, 0);
        let n = 200_000;
        let (mut ez, mut ez2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let d = uniform_sphere(rng.next_f32(), rng.next_f32());
            assert!((d.length() - 1.0).abs() < 1e-5);
            ez += d.z as f64;
            ez2 += (d.z * d.z) as f64;
        }
        // Standard errors: sqrt(1/3 / n) ≈ 1.3e-3 and sqrt((1/5 − 1/9)/n) ≈ 6.7e-4; 5σ bounds.
        assert!((ez / n as f64).abs() < 6.5e-3);
        assert!((ez2 / n as f64 - 1.0 / 3.0).abs() < 3.4e-3);
    }

    #[test]
    fn frames_are_orthonormal_and_right_handed() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.81).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!(f.tangent.dot(f.bitangent).abs() < 1e-6);
            assert!(f.tangent.dot(n).abs() < 1e-6 && f.bitangent.dot(n).abs() < 1e-6);
            assert!((f.tangent.cross(f.bitangent) - n).length() < 1e-5);
            assert!((f.to_world(Vec3::Z) - n).length() < 1e-6);
        }
    }
}
