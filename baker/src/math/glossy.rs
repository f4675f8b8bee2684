//! The glossy BRDF: a normalised Phong lobe about the mirror direction, applied
//! to a transfer matrix's incident radiance by zonal-harmonic convolution (Sloan, Kautz &
//! Snyder 2002, §5; Ramamoorthi & Hanrahan 2001 for the convolution).
//!
//! A matrix bake stores, per receiver, the matrix M that turns the light's coefficients L into
//! the coefficients L′ = M·L of the receiver's shadowed incident radiance (zero below its
//! surface). The radiance it sends towards the eye is then
//!
//! ```text
//!     radiance = kd · Σ_lm ĝ_l(1) L′_lm y_lm(n)  +  ks · Σ_lm ĝ_l(s) L′_lm y_lm(r)
//!     r = 2 (n·v) n − v          (v: unit vector from the receiver towards the eye)
//! ```
//!
//! where the lobe G_s(ω) = (s + 1)/(2π) · max(ω·r, 0)^s integrates to 1 over the sphere, so
//! `ks` is the fraction of light the lobe reflects, and by the Funk–Hecke theorem its
//! convolution scales band l by
//!
//! ```text
//!     ĝ_l(s) = 2π ∫₀¹ G_s(t) P_l(t) dt = (s + 1) ∫₀¹ t^s P_l(t) dt.
//! ```
//!
//! With s = 1 the lobe is the clamped cosine over π, so the diffuse term uses the same
//! function: ĝ(1) = (1, 2/3, 1/4, 0, −1/24, …), Ramamoorthi & Hanrahan's Â_l / π. Like every
//! Phong-style PRT lobe this one is centred on the mirror direction and leaves out the
//! cosine at the receiver, which is what lets it be a zonal function; the band limit keeps
//! lobes sharper than about s ≈ order² from being represented (their ĝ_l ≈ exp(−l²/2s) stay
//! near 1 in every stored band).
//!
//! The integral is exact: P_l's monomial coefficients (Bonnet's recurrence, in f64) each
//! integrate to 1/(s + k + 1). No crate offers this small a piece.

use glam::Vec3;

/// The sharpest lobe accepted: a glTF roughness of 0 would give an infinite exponent, and at
/// every order we store the lobe is a mirror long before this.
pub const MAX_EXPONENT: f32 = 10_000.0;

/// The Phong exponent of a Wavefront MTL material: its `Ns` is that exponent (0 to 1000 by
/// the format's convention), clamped to [0, [`MAX_EXPONENT`]].
pub fn exponent_from_ns(ns: f32) -> f32 {
    if ns.is_nan() {
        return 0.0;
    }
    ns.clamp(0.0, MAX_EXPONENT)
}

/// The Phong exponent equivalent to a glTF `roughnessFactor` r.
///
/// glTF's α = r² is the GGX width; the Blinn-Phong exponent with the same
/// Beckmann-equivalent width is 2/α² − 2 (Walter et al. 2007), and a lobe about the mirror
/// direction is four times as narrow in exponent as one about the half vector (the half
/// vector turns half as fast as the mirror direction, and the exponent goes with the inverse
/// square of the width), so s = (2/r⁴ − 2) / 4 = 1/(2r⁴) − 1/2, clamped to [0, MAX].
pub fn exponent_from_roughness(roughness: f32) -> f32 {
    if roughness.is_nan() {
        return 0.0;
    }
    let r = roughness.clamp(0.0, 1.0);
    let r4 = (r * r) * (r * r);
    if r4 * 2.0 * MAX_EXPONENT <= 1.0 {
        return MAX_EXPONENT;
    }
    (0.5 / r4 - 0.5).clamp(0.0, MAX_EXPONENT)
}

/// ĝ_l(s) for bands l = 0 .. order − 1: the factor by which the normalised Phong lobe of
/// exponent s scales band l of the radiance it is convolved with (ĝ_0 = 1 for every s).
pub fn lobe_bands(exponent: f32, order: usize) -> Vec<f32> {
    let s = f64::from(exponent.max(0.0));
    legendre_coefficients(order)
        .iter()
        .map(|p| {
            let integral: f64 = p
                .iter()
                .enumerate()
                .map(|(k, &c)| c / (s + k as f64 + 1.0))
                .sum();
            ((s + 1.0) * integral) as f32
        })
        .collect()
}

/// Σ_lm bands[l] · radiance_lm · sh_lm: the lobe whose band factors are `bands`, convolved
/// with `radiance` (SH coefficients, l(l+1)+m order) and evaluated where `sh` (the basis at
/// the lobe's axis) was evaluated. Summed in f64, for f32 inputs (a renderer's) or f64 ones
/// (the CPU reference's).
pub fn convolve_at<T: Copy + Into<f64>>(radiance: &[T], bands: &[T], sh: &[T]) -> f64 {
    let mut sum = 0.0;
    for (l, &g) in bands.iter().enumerate() {
        let band: f64 = (l * l..(l + 1) * (l + 1))
            .map(|i| radiance[i].into() * sh[i].into())
            .sum();
        sum += g.into() * band;
    }
    sum
}

/// The mirror direction of `to_eye` (unit, from the receiver towards the eye) about the unit
/// normal `n`.
pub fn reflect(to_eye: Vec3, n: Vec3) -> Vec3 {
    2.0 * n.dot(to_eye) * n - to_eye
}

/// P_0 … P_{order−1} as monomial coefficients (index k holds the coefficient of t^k), by
/// Bonnet's recurrence (l + 1) P_{l+1} = (2l + 1) t P_l − l P_{l−1}.
fn legendre_coefficients(order: usize) -> Vec<Vec<f64>> {
    let mut polys: Vec<Vec<f64>> = Vec::with_capacity(order);
    for l in 0..order {
        let p = match l {
            0 => vec![1.0],
            1 => vec![0.0, 1.0],
            _ => {
                let n = (l - 1) as f64;
                let mut next = vec![0.0; l + 1];
                for (k, &c) in polys[l - 1].iter().enumerate() {
                    next[k + 1] += (2.0 * n + 1.0) * c / (n + 1.0);
                }
                for (k, &c) in polys[l - 2].iter().enumerate() {
                    next[k] -= n * c / (n + 1.0);
                }
                next
            }
        };
        polys.push(p);
    }
    polys
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clamped_cosine_is_the_lobe_of_exponent_one() {
        let g = lobe_bands(1.0, 6);
        let expected = [1.0, 2.0 / 3.0, 0.25, 0.0, -1.0 / 24.0, 0.0];
        for (l, (a, b)) in g.iter().zip(expected).enumerate() {
            assert!((a - b).abs() < 1e-6, "band {l}: {a} against {b}");
        }
    }

    /// The closed form against a midpoint quadrature of (s + 1) ∫₀¹ t^s P_l(t) dt, with
    /// P_l from the basis module's associated Legendre function.
    #[test]
    fn the_band_factors_match_quadrature() {
        for s in [0.0f32, 2.5, 10.0, 60.0] {
            let g = lobe_bands(s, 8);
            for (l, &gl) in g.iter().enumerate() {
                let steps = 200_000;
                let q: f64 = (0..steps)
                    .map(|i| {
                        let t = (i as f64 + 0.5) / steps as f64;
                        t.powf(f64::from(s)) * crate::math::sh::legendre(l, 0, t)
                    })
                    .sum::<f64>()
                    / steps as f64
                    * (f64::from(s) + 1.0);
                assert!(
                    (f64::from(gl) - q).abs() < 1e-4,
                    "s {s}, band {l}: {gl} against {q}"
                );
            }
        }
    }

    #[test]
    fn sharp_lobes_keep_every_band() {
        let g = lobe_bands(MAX_EXPONENT, 4);
        assert!(g.iter().all(|&x| x > 0.999), "{g:?}");
    }

    #[test]
    fn exponent_mappings() {
        assert_eq!(exponent_from_ns(96.0), 96.0);
        assert_eq!(exponent_from_ns(-3.0), 0.0);
        assert_eq!(exponent_from_roughness(1.0), 0.0);
        assert!((exponent_from_roughness(0.5) - 7.5).abs() < 1e-5);
        assert_eq!(exponent_from_roughness(0.0), MAX_EXPONENT);
        assert_eq!(exponent_from_roughness(f32::NAN), 0.0);
    }

    #[test]
    fn reflection_about_the_normal() {
        let r = reflect(Vec3::new(1.0, 0.0, 1.0).normalize(), Vec3::Z);
        assert!((r - Vec3::new(-1.0, 0.0, 1.0).normalize()).length() < 1e-6);
    }
}
