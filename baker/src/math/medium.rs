//! A homogeneous scattering medium behind a smooth dielectric boundary: the optics a random
//! walk inside a translucent object needs (free flights, isotropic scattering, Fresnel
//! reflection and Snell refraction), and Jensen et al.'s (2001) dipole, kept as a closed-form
//! oracle (`docs/guides/subsurface.md`).
//!
//! Coefficients are per scene unit and per colour channel. The materials file gives the
//! reduced scattering coefficient σs′ = σs(1 − g); the walk scatters isotropically with
//! σs = σs′ (the similarity relation), which is what the dipole and Mitsuba's isotropic
//! `volpath` references assume too.

use glam::Vec3;

/// A homogeneous medium: reduced scattering σs′ and absorption σa per channel (per scene
/// unit), and the boundary's relative index of refraction η (inside over outside).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medium {
    pub scattering: Vec3,
    pub absorption: Vec3,
    pub ior: f32,
}

impl Medium {
    /// The extinction coefficient σt = σs′ + σa.
    pub fn extinction(&self) -> Vec3 {
        self.scattering + self.absorption
    }

    /// The single-scattering albedo σs′/σt per channel (0 where σt is 0).
    pub fn albedo(&self) -> Vec3 {
        let t = self.extinction();
        Vec3::select(t.cmpgt(Vec3::ZERO), self.scattering / t, Vec3::ZERO)
    }
}

/// Unpolarised Fresnel reflectance of light arriving at `cos_i` (> 0) to the normal, where
/// `eta` = n_here / n_other (the ratio Snell's law multiplies sin θ_i by); 1 under total
/// internal reflection.
pub fn fresnel(cos_i: f32, eta: f32) -> f32 {
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    // r_s and r_p with n_here = eta, n_other = 1.
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// The direction `d` (unit, travelling towards the surface, `d · n < 0`) takes through a
/// boundary with unit normal `n` facing it, where `eta` = n_here / n_other; `None` under total
/// internal reflection.
pub fn refract(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = -d.dot(n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((eta * d + (eta * cos_i - cos_t) * n).normalize())
}

/// The mirror direction of `d` about the unit normal `n`.
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// The diffuse Fresnel reflectance Fdr of a boundary of relative index `eta` (Egan & Hilgeman's
/// fit, as Jensen et al. 2001 use it).
pub fn diffuse_fresnel(eta: f64) -> f64 {
    -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta
}

/// The dipole's total diffuse reflectance ∫Rd dA of a semi-infinite medium of reduced albedo
/// `albedo` (σs′/σt′) behind a boundary of relative index `eta` (Jensen et al. 2001, eq. 5
/// integrated): the fraction of light entering that leaves again after multiple scattering.
pub fn dipole_total_reflectance(albedo: f64, eta: f64) -> f64 {
    let fdr = diffuse_fresnel(eta);
    let a = (1.0 + fdr) / (1.0 - fdr);
    let s = (3.0 * (1.0 - albedo)).sqrt();
    0.5 * albedo * (1.0 + (-(4.0 / 3.0) * a * s).exp()) * (-s).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_at_normal_incidence_is_f0() {
        for eta in [1.3f32, 1.0 / 1.3, 1.5] {
            let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!((fresnel(1.0, eta) - f0).abs() < 1e-6, "eta {eta}");
        }
        assert!(fresnel(0.3, 1.0) < 1e-6);
    }

    #[test]
    fn total_internal_reflection_past_the_critical_angle() {
        let eta = 1.3f32;
        let critical = (1.0 / eta).asin();
        let cos_past = (critical + 0.01).cos();
        assert_eq!(fresnel(cos_past, eta), 1.0);
        let d = Vec3::new((critical + 0.01).sin(), 0.0, -cos_past);
        assert!(refract(d, Vec3::Z, eta).is_none());
    }

    #[test]
    fn refraction_obeys_snell() {
        let eta = 1.0f32 / 1.3;
        let theta = 0.7f32;
        let d = Vec3::new(theta.sin(), 0.0, -theta.cos());
        let t = refract(d, Vec3::Z, eta).unwrap();
        assert!((t.x - eta * theta.sin()).abs() < 1e-6);
        assert!(t.z < 0.0 && (t.length() - 1.0).abs() < 1e-6);
        assert_eq!(refract(d, Vec3::Z, 1.0).unwrap(), d.normalize());
    }

    #[test]
    fn dipole_reflectance_matches_jensens_figures() {
        // The digest's dipole column (index-matched): 0.747, 0.385, 0.088.
        for (albedo, expected) in [(0.99, 0.747), (0.9, 0.385), (0.5, 0.088)] {
            let rd = dipole_total_reflectance(albedo, 1.0);
            assert!((rd - expected).abs() < 0.0015, "{albedo}: {rd}");
        }
        // A boundary traps light: less leaves.
        assert!(dipole_total_reflectance(0.99, 1.3) < dipole_total_reflectance(0.99, 1.0));
    }
}
