//! Distant lights projected to SH, in RGB, for relighting baked transfer.
//!
//! A vertex's outgoing radiance is albedo · Σ_j T_j·c_j per colour channel, where T is its
//! stored transfer (which already holds the 1/π of a diffuse surface) and c the light's
//! coefficients c_j = ∫ L(s) y_j(s) ds. Lights are linear: the coefficients of several lights
//! are the sum of theirs, so a renderer pays the same per vertex for one light as for fifty.
//!
//! # Units (`docs/lights.md` has the full table)
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

mod environment;
pub mod rig;
mod window;

use glam::DVec3;
use serde::Serialize;

use crate::math::sh::rotation::ShRotation;
use crate::math::sh::{self, Basis};

pub use environment::EnvironmentMap;
pub use rig::Rig;
pub use window::Window;

/// The conventions of every coefficient vector this module produces, as written into the
/// `prt-bake light` JSON.
pub const CONVENTION: &str = "real orthonormal SH, coefficient (l,m) at index l(l+1)+m, \
     theta from +z, phi from +x towards +y, Condon-Shortley phase (y_1^1 = -0.488603 x); \
     c_lm = integral of radiance times y_lm over the sphere";

/// RGB SH coefficients of a distant light of one order.
#[derive(Clone, Debug, PartialEq)]
pub struct LightCoefficients {
    order: usize,
    /// Per channel (R, G, B), n² coefficients.
    pub rgb: [Vec<f64>; 3],
}

impl LightCoefficients {
    /// No light: all coefficients zero.
    pub fn zero(order: usize) -> LightCoefficients {
        let n = sh::coeff_count(order);
        LightCoefficients {
            order,
            rgb: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
        }
    }

    /// A grey vector `c` times the colour `rgb`.
    pub fn tinted(order: usize, c: &[f64], rgb: DVec3) -> LightCoefficients {
        let channel = |k: f64| c.iter().map(|x| x * k).collect();
        LightCoefficients {
            order,
            rgb: [channel(rgb.x), channel(rgb.y), channel(rgb.z)],
        }
    }

    pub fn order(&self) -> usize {
        self.order
    }

    /// Adds another light of the same order.
    pub fn add(&mut self, other: &LightCoefficients) {
        assert_eq!(self.order, other.order, "adding lights of different orders");
        for (a, b) in self.rgb.iter_mut().zip(&other.rgb) {
            for (x, y) in a.iter_mut().zip(b) {
                *x += y;
            }
        }
    }

    /// The light rotated by `rotation` (which must have the same order).
    pub fn rotated(&self, rotation: &ShRotation) -> LightCoefficients {
        assert_eq!(self.order, rotation.order(), "rotation of another order");
        LightCoefficients {
            order: self.order,
            rgb: self.rgb.clone().map(|c| rotation.rotate(&c)),
        }
    }

    /// The light, given in the z-up frame that rigs are written in, turned into the
    /// coordinates of a scene whose up axis is `up` (see [`crate::scene::Up`]): unchanged for
    /// z-up, rotated by (x, y, z) ↦ (x, z, −y) for y-up. Every light of a rig (its directions,
    /// the hemisphere's zenith, an environment map's pole) turns with it.
    pub fn in_scene_frame(&self, up: crate::scene::Up) -> LightCoefficients {
        match up {
            crate::scene::Up::Z => self.clone(),
            up => self.rotated(&ShRotation::from_matrix(self.order, up.from_z_up())),
        }
    }

    /// Scales band l of every channel by `factors[l]` (see [`Window`]).
    pub fn scale_bands(&mut self, factors: &[f64]) {
        for channel in &mut self.rgb {
            for (j, c) in channel.iter_mut().enumerate() {
                *c *= factors[sh::band_and_m(j).0];
            }
        }
    }

    /// The JSON that `prt-bake light` writes:
    /// `{"order": n, "convention": "…", "coefficients": [[R…], [G…], [B…]]}`.
    pub fn to_json(&self) -> String {
        #[derive(Serialize)]
        struct Json<'a> {
            order: usize,
            convention: &'a str,
            coefficients: &'a [Vec<f64>; 3],
        }
        let json = Json {
            order: self.order,
            convention: CONVENTION,
            coefficients: &self.rgb,
        };
        serde_json::to_string_pretty(&json).expect("plain numbers serialise")
    }
}

/// One distant light. Colours are linear RGB and already include the intensity.
#[derive(Clone, Debug)]
pub enum Light {
    /// Radiance L from every direction: c_00 = L·√(4π), nothing else.
    Constant { radiance: DVec3 },
    /// A delta of irradiance E from `direction` (unit, pointing toward the light):
    /// c_lm = E·y_lm(direction).
    Directional { direction: DVec3, irradiance: DVec3 },
    /// A uniformly bright disk of angular radius δ < 90° around `direction`, whose radiance is
    /// chosen so that a surface facing it receives irradiance E: L = E/(π sin²δ). δ = 0 is the
    /// directional light.
    Sun {
        direction: DVec3,
        irradiance: DVec3,
        angular_radius: f64,
    },
    /// A sphere of uniform radiance L seen under the angular radius δ (sin δ = radius /
    /// distance) around `direction`: a sun with E = π L sin²δ.
    Sphere {
        direction: DVec3,
        radiance: DVec3,
        angular_radius: f64,
    },
    /// Radiance `sky` over the hemisphere around `up`, `ground` over the other.
    Hemisphere {
        up: DVec3,
        sky: DVec3,
        ground: DVec3,
    },
    /// A latitude–longitude map (see [`EnvironmentMap`]), its radiance times `scale`, turned
    /// by `rotation` (the map's +z goes to rotation·z).
    Environment {
        map: std::sync::Arc<EnvironmentMap>,
        scale: DVec3,
        rotation: glam::DMat3,
    },
}

impl Light {
    /// The light's coefficients of order `order` (1..=[`sh::MAX_ORDER`]).
    pub fn project(&self, order: usize) -> LightCoefficients {
        match self {
            Light::Constant { radiance } => {
                let mut c = vec![0.0; sh::coeff_count(order)];
                c[0] = (4.0 * std::f64::consts::PI).sqrt();
                LightCoefficients::tinted(order, &c, *radiance)
            }
            Light::Directional {
                direction,
                irradiance,
            } => LightCoefficients::tinted(
                order,
                &zonal_lobe(order, *direction, &vec![1.0; order]),
                *irradiance,
            ),
            Light::Sun {
                direction,
                irradiance,
                angular_radius,
            } => LightCoefficients::tinted(
                order,
                &zonal_lobe(
                    order,
                    *direction,
                    &disk_band_factors(order, *angular_radius),
                ),
                *irradiance,
            ),
            Light::Sphere {
                direction,
                radiance,
                angular_radius,
            } => {
                let sin = angular_radius.sin();
                Light::Sun {
                    direction: *direction,
                    irradiance: *radiance * (std::f64::consts::PI * sin * sin),
                    angular_radius: *angular_radius,
                }
                .project(order)
            }
            Light::Hemisphere { up, sky, ground } => {
                // Ground everywhere, plus (sky − ground) on the upper hemisphere: a 90° disk
                // whose facing irradiance is π·(sky − ground).
                let mut lights = Light::Constant { radiance: *ground }.project(order);
                let cap = zonal_lobe(
                    order,
                    *up,
                    &disk_band_factors(order, std::f64::consts::FRAC_PI_2),
                );
                lights.add(&LightCoefficients::tinted(
                    order,
                    &cap,
                    (*sky - *ground) * std::f64::consts::PI,
                ));
                lights
            }
            Light::Environment {
                map,
                scale,
                rotation,
            } => {
                let mut c = map.project(order);
                for (channel, k) in c.rgb.iter_mut().zip(scale.to_array()) {
                    channel.iter_mut().for_each(|x| *x *= k);
                }
                c.rotated(&ShRotation::from_matrix(order, *rotation))
            }
        }
    }
}

/// The summed coefficients of `lights`.
pub fn project_sum<'a>(
    lights: impl IntoIterator<Item = &'a Light>,
    order: usize,
) -> LightCoefficients {
    let mut sum = LightCoefficients::zero(order);
    for light in lights {
        sum.add(&light.project(order));
    }
    sum
}

/// c_lm = factors[l]·y_lm(direction): a zonal function about `direction` whose band l is
/// `factors[l]` times that of a unit delta there.
fn zonal_lobe(order: usize, direction: DVec3, factors: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; sh::coeff_count(order)];
    Basis::new(order).eval_recurrence(direction.normalize(), &mut y);
    for (j, c) in y.iter_mut().enumerate() {
        *c *= factors[sh::band_and_m(j).0];
    }
    y
}

/// Band factors g_l(δ) of a uniform disk of angular radius δ (radians, 0 ≤ δ ≤ π/2) scaled to
/// unit irradiance on a facing surface, relative to a unit delta: its coefficients about its
/// axis are g_l·y_l0(z), so g_l → 1 as δ → 0.
///
/// The disk's radiance is L = 1/(π sin²δ), so z_l = 2π N_l L ∫_{cos δ}^1 P_l(t) dt, and with
/// ∫_x^1 P_l = (1 − x²) P_l′(x) / (l(l+1)) for l ≥ 1 (from (1 − x²)P_l′ = l(l+1)/(2l+1)·
/// (P_{l−1} − P_{l+1})) the sin²δ cancels:
///
/// ```text
///     g_0 = 2(1 − cos δ)/sin²δ = 1/cos²(δ/2),     g_l = 2 P_l′(cos δ) / (l(l+1)).
/// ```
///
/// Both forms stay exact as δ → 0 (P_l′(1) = l(l+1)/2), where the textbook
/// (P_{l−1} − P_{l+1})/(2l+1) would cancel catastrophically.
pub fn disk_band_factors(order: usize, angular_radius: f64) -> Vec<f64> {
    let x = angular_radius.cos();
    let half = (0.5 * angular_radius).cos();
    // P_l and P_l′ by Bonnet's recurrence and P_l′ = l·P_{l−1} + x·P_{l−1}′.
    let (mut p, mut dp) = (1.0f64, 0.0f64);
    let mut p_prev = 0.0f64;
    let mut factors = Vec::with_capacity(order);
    for l in 0..order {
        if l == 0 {
            factors.push(1.0 / (half * half));
            continue;
        }
        let lf = l as f64;
        let dp_next = lf * p + x * dp;
        let p_next = if l == 1 {
            x
        } else {
            ((2.0 * lf - 1.0) * x * p - (lf - 1.0) * p_prev) / lf
        };
        (p_prev, p, dp) = (p, p_next, dp_next);
        factors.push(2.0 * dp / (lf * (lf + 1.0)));
    }
    factors
}

/// A light that a viewer turns around: its coefficients about +z, kept unrotated, and its
/// absolute direction (θ, φ). The current coefficients are always the unrotated ones turned
/// by the absolute angles, never the last frame's turned by a delta, so nothing drifts however
/// long the light is moved.
#[derive(Clone, Debug)]
pub struct SteerableLight {
    unrotated: LightCoefficients,
    rotator: sh::rotation::ZyzRotator,
    pub theta: f64,
    pub phi: f64,
}

impl SteerableLight {
    /// `unrotated` holds the light as it shines about +z.
    pub fn new(unrotated: LightCoefficients, theta: f64, phi: f64) -> SteerableLight {
        let rotator = sh::rotation::ZyzRotator::new(unrotated.order());
        SteerableLight {
            unrotated,
            rotator,
            theta,
            phi,
        }
    }

    /// The light's coefficients at its current (θ, φ).
    pub fn coefficients(&self) -> LightCoefficients {
        self.unrotated
            .rotated(&self.rotator.light_angles(self.theta, self.phi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
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
