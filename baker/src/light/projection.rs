//! The lights a rig names (suns, skies, disks, environment maps) and their projection to SH.

use glam::DVec3;

use crate::math::sh::rotation::ShRotation;
use crate::math::sh::{self, Basis};

use super::coefficients::LightCoefficients;
use super::environment::EnvironmentMap;

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
