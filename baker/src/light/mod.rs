//! Distant lights projected to SH, in RGB, for relighting baked transfer.
//!
//! A vertex's outgoing radiance is albedo · Σ_j T_j·c_j per colour channel, where T is its
//! stored transfer (which already holds the 1/π of a diffuse surface) and c the light's
//! coefficients c_j = ∫ L(s) y_j(s) ds. Lights are linear: the coefficients of several lights
//! are the sum of theirs, so a renderer pays the same per vertex for one light as for fifty.
//!
//! # Units (`docs/reference/lights.md` has the full table)
//!
//! * constant, hemisphere, sphere, environment: *radiance* L of what the light shows.
//! * directional, sun: *irradiance* E that the light delivers to a surface facing it. A lit,
//!   unshadowed floor of albedo ρ facing such a light then has radiance ρ·E/π (up to the SH
//!   truncation of its clamped-cosine transfer).
//!
//! Directional, sun, sphere and hemisphere lights are zonal about their axis: projected about
//! +z, band l scaled by a factor g_l, then turned to their direction, which for a zonal
//! function is the closed form c_lm = √(4π/(2l+1))·z_l·y_lm(d). [`SteerableLight`] keeps the
//! unrotated coefficients and the absolute angles, as the thesis's lights do.
//!
//! May import: [`crate::support`], [`crate::math`], [`crate::scene`] (the up axis).

mod coefficients;
mod environment;
mod projection;
pub mod rig;
mod window;

pub use coefficients::{CONVENTION, LightCoefficients};
pub use environment::EnvironmentMap;
pub use projection::{Light, SteerableLight, disk_band_factors, project_sum};
pub use rig::Rig;
pub use window::Window;

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::math::sh;
    use std::f64::consts::PI;

    /// Far below any quantity these tests compare (f64 rounding of short sums).
    const EXACT: f64 = 1e-12;

    #[test]
    fn y_up_turns_a_rigs_zenith_to_plus_y_and_its_plus_y_to_minus_z() {
        use crate::scene::Up;
        let directional = |d: DVec3| Light::Directional {
            direction: d,
            irradiance: DVec3::new(1.0, 2.0, 3.0),
        };
        for (rig_direction, scene_direction) in [
            (DVec3::Z, DVec3::Y),
            (DVec3::Y, DVec3::NEG_Z),
            (DVec3::X, DVec3::X),
            (
                DVec3::new(0.3, -0.5, 0.8).normalize(),
                DVec3::new(0.3, 0.8, 0.5).normalize(),
            ),
        ] {
            let turned = directional(rig_direction).project(6).in_scene_frame(Up::Y);
            let expected = directional(scene_direction).project(6);
            for (a, b) in turned
                .rgb
                .iter()
                .flatten()
                .zip(expected.rgb.iter().flatten())
            {
                assert!((a - b).abs() < 1e-9, "{rig_direction} -> {scene_direction}");
            }
            let same = directional(rig_direction).project(6);
            assert_eq!(same.in_scene_frame(Up::Z), same);
        }
    }

    /// g_l by quadrature of the definition (Gauss–Legendre in t over [cos δ, 1], exact for the
    /// polynomial P_l): an independent check of the closed form.
    fn quadrature_factor(l: usize, delta: f64) -> f64 {
        let (x, w) = sh::gauss_legendre(l / 2 + 2);
        let lo = delta.cos();
        let integral: f64 = x
            .iter()
            .zip(&w)
            .map(|(x, w)| {
                let t = 0.5 * (1.0 - lo) * x + 0.5 * (1.0 + lo);
                w * 0.5 * (1.0 - lo) * sh::legendre(l, 0, t)
            })
            .sum();
        let radiance = 1.0 / (PI * delta.sin().powi(2));
        // z_l / y_l0(z) with y_l0(z) = N_l: 2π L ∫ P_l.
        2.0 * PI * radiance * integral
    }

    #[test]
    fn disk_factors_equal_the_quadrature_of_their_definition() {
        for delta in [0.05, 0.4, 1.0, PI / 2.0] {
            let factors = disk_band_factors(12, delta);
            for (l, g) in factors.iter().enumerate() {
                let q = quadrature_factor(l, delta);
                assert!(
                    (g - q).abs() < 1e-10 * (1.0 + q.abs()),
                    "δ={delta} l={l}: {g} vs {q}"
                );
            }
        }
    }

    #[test]
    fn a_zero_radius_disk_is_a_delta() {
        assert_eq!(disk_band_factors(20, 0.0), vec![1.0; 20]);
    }

    #[test]
    fn steering_from_absolute_angles_equals_projecting_at_the_direction() {
        let order = 6;
        let sun = |direction| Light::Sun {
            direction,
            irradiance: DVec3::new(1.0, 0.5, 0.25),
            angular_radius: 0.3,
        };
        let mut light = SteerableLight::new(sun(DVec3::Z).project(order), 0.0, 0.0);
        // Move it in many small steps, as a user holding a key would.
        for _ in 0..1000 {
            light.theta += 0.0021;
            light.phi -= 0.0037;
        }
        let (theta, phi) = (light.theta, light.phi);
        let d = DVec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        );
        let want = sun(d).project(order);
        let got = light.coefficients();
        for (a, b) in got.rgb.iter().zip(&want.rgb) {
            for (x, y) in a.iter().zip(b) {
                assert!((x - y).abs() < EXACT, "{x} vs {y}");
            }
        }
    }

    #[test]
    fn hemisphere_with_equal_colours_is_constant() {
        let c = DVec3::new(0.2, 0.3, 0.4);
        let hemisphere = Light::Hemisphere {
            up: DVec3::new(0.3, -0.2, 0.9),
            sky: c,
            ground: c,
        }
        .project(5);
        let constant = Light::Constant { radiance: c }.project(5);
        for (a, b) in hemisphere.rgb.iter().zip(&constant.rgb) {
            for (x, y) in a.iter().zip(b) {
                assert!((x - y).abs() < EXACT);
            }
        }
    }
}
