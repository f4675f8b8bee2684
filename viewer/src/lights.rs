//! The lights the viewer shows and steers, for both shading models.
//!
//! Every light of a rig becomes a [`SteerableLight`], as in the thesis: its coefficients about
//! +z, kept unrotated, and its absolute direction (θ, φ). The controls change the angles and
//! each frame turns the unrotated coefficients by them (`ZyzRotator`, R = Rz(φ)·Ry(θ)), so no
//! error accumulates however long a light is moved. What the angles mean per kind:
//!
//! * directional, sun, sphere: the direction toward the light;
//! * hemisphere: the sky's zenith;
//! * environment: where the map's own zenith (after the rig's `rotation`) is turned; it starts
//!   at θ = φ = 0, the map as the rig places it;
//! * constant: nothing (a constant sky looks the same turned any way).
//!
//! Blinn-Phong mode has no SH: it shows each light the way a classic renderer would
//! ([`PhongShape`]), with the same units as PRT so the two modes are comparable in
//! brightness: a directional light of irradiance E gives a white facing surface radiance E/π
//! in both, a constant sky of radiance L gives L.

use std::path::Path;

use glam::{DVec3, Vec3};
use prt_baker::light::{Light, LightCoefficients, Rig, SteerableLight, Window};
use prt_baker::math::sh;
use prt_baker::scene::Up;

use crate::error::Result;

/// Lights that keys 1–8 can select, and the size of Blinn-Phong's light array (the thesis's
/// OpenGL limit, kept for the comparison). PRT itself sums any number of lights.
pub const MAX_LIGHTS: usize = 8;

/// The rig used when none is given: a warm sun and a sky.
pub const DEFAULT_RIG: &str = include_str!("default-rig.toml");

/// How Blinn-Phong mode shows a light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PhongShape {
    /// Directional, sun and sphere lights: irradiance E arriving from the light's direction
    /// (a sphere's E = πL·sin²δ), with a specular highlight.
    Directional { irradiance: Vec3 },
    /// A sky over a ground about the light's direction: the classic hemisphere ambient,
    /// sky·(1 + n·up)/2 + ground·(1 − n·up)/2, exact for an unoccluded diffuse surface.
    Hemisphere { sky: Vec3, ground: Vec3 },
    /// Constant skies and environment maps: their mean radiance from every direction, an
    /// ambient term (an environment map's structure is PRT's to show).
    Ambient { radiance: Vec3 },
}

/// One light of the scene.
#[derive(Clone, Debug)]
pub struct SceneLight {
    /// The rig's `kind`, for the readout.
    pub kind: &'static str,
    pub steerable: SteerableLight,
    pub phong: PhongShape,
}

impl SceneLight {
    /// Splits a rig light into its coefficients about +z and its direction.
    pub fn new(light: &Light, order: usize) -> SceneLight {
        let Some((kind, phong)) = analytic_shape(light) else {
            return SceneLight::environment(light, order);
        };
        let steerable = match along_z(light) {
            Some((direction, about_z)) => {
                let (theta, phi) = sh::angles(direction);
                SteerableLight::new(about_z.project(order), theta, phi)
            }
            None => SteerableLight::new(light.project(order), 0.0, 0.0),
        };
        SceneLight {
            kind,
            steerable,
            phong,
        }
    }

    /// An environment map: projected once, its Phong stand-in the map's mean radiance.
    fn environment(light: &Light, order: usize) -> SceneLight {
        let coefficients = light.project(order);
        // y_00 = 1/√(4π), so the mean radiance is c_00/√(4π).
        let mean = |c: usize| (coefficients.rgb[c][0] / (4.0 * std::f64::consts::PI).sqrt()) as f32;
        let radiance = Vec3::new(mean(0), mean(1), mean(2));
        SceneLight {
            kind: "environment",
            steerable: SteerableLight::new(coefficients, 0.0, 0.0),
            phong: PhongShape::Ambient { radiance },
        }
    }

    /// The light's current direction (unit), from its absolute angles.
    pub fn direction(&self) -> Vec3 {
        direction(self.steerable.theta, self.steerable.phi).as_vec3()
    }

    /// Whether turning the light changes anything (not for a constant sky).
    pub fn is_directed(&self) -> bool {
        self.kind != "constant"
    }

    /// A colour to draw the light's vector in: its colour at unit brightness.
    pub fn display_colour(&self) -> Vec3 {
        let c = match self.phong {
            PhongShape::Directional { irradiance } => irradiance,
            PhongShape::Hemisphere { sky, .. } => sky,
            PhongShape::Ambient { radiance } => radiance,
        };
        c / c.max_element().max(f32::MIN_POSITIVE)
    }
}

/// The kind and Phong stand-in of an analytic light; `None` for an environment map, whose
/// stand-in needs its projection ([`SceneLight::environment`]).
fn analytic_shape(light: &Light) -> Option<(&'static str, PhongShape)> {
    Some(match light {
        Light::Constant { radiance } => (
            "constant",
            PhongShape::Ambient {
                radiance: radiance.as_vec3(),
            },
        ),
        Light::Directional { irradiance, .. } => (
            "directional",
            PhongShape::Directional {
                irradiance: irradiance.as_vec3(),
            },
        ),
        Light::Sun { irradiance, .. } => (
            "sun",
            PhongShape::Directional {
                irradiance: irradiance.as_vec3(),
            },
        ),
        Light::Sphere {
            radiance,
            angular_radius,
            ..
        } => (
            "sphere",
            PhongShape::Directional {
                irradiance: (*radiance * (std::f64::consts::PI * angular_radius.sin().powi(2)))
                    .as_vec3(),
            },
        ),
        Light::Hemisphere { sky, ground, .. } => (
            "hemisphere",
            PhongShape::Hemisphere {
                sky: sky.as_vec3(),
                ground: ground.as_vec3(),
            },
        ),
        Light::Environment { .. } => return None,
    })
}

/// A directed light's direction and the same light shining about +z, which is projected
/// once and then steered; `None` for lights that are not turned (constant, environment).
fn along_z(light: &Light) -> Option<(DVec3, Light)> {
    Some(match light {
        Light::Constant { .. } | Light::Environment { .. } => return None,
        Light::Directional {
            direction,
            irradiance,
        } => (
            *direction,
            Light::Directional {
                direction: DVec3::Z,
                irradiance: *irradiance,
            },
        ),
        Light::Sun {
            direction,
            irradiance,
            angular_radius,
        } => (
            *direction,
            Light::Sun {
                direction: DVec3::Z,
                irradiance: *irradiance,
                angular_radius: *angular_radius,
            },
        ),
        Light::Sphere {
            direction,
            radiance,
            angular_radius,
        } => (
            *direction,
            Light::Sphere {
                direction: DVec3::Z,
                radiance: *radiance,
                angular_radius: *angular_radius,
            },
        ),
        Light::Hemisphere { up, sky, ground } => (
            *up,
            Light::Hemisphere {
                up: DVec3::Z,
                sky: *sky,
                ground: *ground,
            },
        ),
    })
}

/// The unit vector at (θ, φ): θ from +z, φ from +x towards +y.
pub fn direction(theta: f64, phi: f64) -> DVec3 {
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// A Blinn-Phong light as the shaders take it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhongLight {
    /// Unit vector toward the light (directional) or the sky's zenith (hemisphere).
    pub direction: Vec3,
    pub shape: PhongShape,
}

/// What Blinn-Phong mode draws: up to [`MAX_LIGHTS`] directional and hemisphere lights, and
/// the ambient radiance of the rest.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PhongLights {
    pub ambient: Vec3,
    pub lights: Vec<PhongLight>,
    /// Directional or hemisphere lights beyond [`MAX_LIGHTS`], left out.
    pub dropped: usize,
}

/// The scene's lights, in rig order, and the rig's ringing window.
#[derive(Clone, Debug)]
pub struct Lights {
    lights: Vec<SceneLight>,
    window: Window,
    order: usize,
    /// The bake's up axis: PRT's light is turned from the rig's z-up frame to it.
    up: Up,
}

impl Lights {
    /// The rig's lights at the bake's order.
    pub fn from_rig(rig: &Rig, order: usize) -> Lights {
        Lights {
            lights: rig
                .lights
                .iter()
                .map(|l| SceneLight::new(l, order))
                .collect(),
            window: rig.window,
            order,
            up: Up::Z,
        }
    }

    /// The lights for a bake whose scene has this up axis: directions and controls stay in
    /// the z-up frame the viewer shows, [`Lights::prt`] turns the summed light to the
    /// transfer's coordinates.
    pub fn for_up(mut self, up: Up) -> Lights {
        self.up = up;
        self
    }

    /// [`DEFAULT_RIG`], parsed by the baker's rig parser.
    pub fn default_rig() -> Rig {
        Rig::parse(DEFAULT_RIG, Path::new("<built-in rig>")).expect("the built-in rig parses")
    }

    /// Loads `--lights RIG.toml`, or the default rig.
    pub fn load(rig: Option<&Path>, order: usize) -> Result<Lights> {
        let rig = match rig {
            Some(path) => Rig::load(path)?,
            None => Lights::default_rig(),
        };
        Ok(Lights::from_rig(&rig, order))
    }

    /// `count` white suns spread around the sky, `2.5/count` each: the benchmark's
    /// configurations (the thesis measured 1 and 8 lights).
    pub fn suns(count: usize, order: usize) -> Lights {
        let lights = (0..count)
            .map(|k| {
                let theta = (40.0 + 10.0 * (k % 3) as f64).to_radians();
                let phi = (-60.0 + 360.0 * k as f64 / count as f64).to_radians();
                let irradiance = DVec3::splat(2.5 / count as f64);
                Light::Sun {
                    direction: direction(theta, phi),
                    irradiance,
                    angular_radius: 1f64.to_radians(),
                }
            })
            .map(|l| SceneLight::new(&l, order))
            .collect();
        Lights {
            lights,
            window: Window::None,
            order,
            up: Up::Z,
        }
    }

    pub fn len(&self) -> usize {
        self.lights.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    pub fn get(&self, i: usize) -> Option<&SceneLight> {
        self.lights.get(i)
    }

    pub fn get_mut(&mut self, i: usize) -> Option<&mut SceneLight> {
        self.lights.get_mut(i)
    }

    pub fn iter(&self) -> impl Iterator<Item = &SceneLight> {
        self.lights.iter()
    }

    pub fn iter_mut(&mut self) -> impl Iterator<Item = &mut SceneLight> {
        self.lights.iter_mut()
    }

    /// The order of the coefficients.
    pub fn order(&self) -> usize {
        self.order
    }

    /// PRT's light: every light turned to its current angles, summed, and windowed as the
    /// rig says. The work is per light but not per vertex: for order 4, sixteen coefficients
    /// per channel whatever the number of lights.
    pub fn prt(&self) -> LightCoefficients {
        let mut sum = LightCoefficients::zero(self.order);
        for light in &self.lights {
            sum.add(&light.steerable.coefficients());
        }
        sum.scale_bands(&self.window.factors(self.order));
        sum.in_scene_frame(self.up)
    }

    /// Blinn-Phong's lights, at their current directions.
    pub fn phong(&self) -> PhongLights {
        let mut phong = PhongLights::default();
        for light in &self.lights {
            match light.phong {
                PhongShape::Ambient { radiance } => phong.ambient += radiance,
                shape if phong.lights.len() < MAX_LIGHTS => phong.lights.push(PhongLight {
                    direction: light.direction(),
                    shape,
                }),
                _ => phong.dropped += 1,
            }
        }
        phong
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f64 rounding of a rotation of order-6 coefficients of size ≲ 10.
    const ROUNDING: f64 = 1e-12;

    fn max_difference(a: &LightCoefficients, b: &LightCoefficients) -> f64 {
        a.rgb
            .iter()
            .zip(&b.rgb)
            .flat_map(|(x, y)| x.iter().zip(y).map(|(x, y)| (x - y).abs()))
            .fold(0.0, f64::max)
    }

    const EVERY_STEERABLE_KIND: &str = r#"
        window = "hanning"
        [[light]]
        kind = "directional"
        direction = [0.3, -0.4, 0.8]
        color = [1.0, 0.5, 0.25]
        intensity = 2.0
        [[light]]
        kind = "sun"
        theta = 35
        phi = 120
        angular_radius = 3
        [[light]]
        kind = "sphere"
        direction = [-1, 0, 1]
        radius = 0.5
        distance = 4
        [[light]]
        kind = "hemisphere"
        direction = [0.2, 0.1, 1]
        color = [0.3, 0.45, 0.8]
        ground_color = [0.15, 0.12, 0.1]
        [[light]]
        kind = "constant"
        intensity = 0.1
    "#;

    /// Unmoved, the steered lights are exactly the rig's own projection (which evaluates each
    /// light at its direction, without rotations): the split into unrotated coefficients and
    /// angles loses nothing.
    #[test]
    fn unmoved_lights_equal_the_rigs_projection() {
        let rig = Rig::parse(EVERY_STEERABLE_KIND, Path::new("test.toml")).unwrap();
        let order = 6;
        let lights = Lights::from_rig(&rig, order);
        let difference = max_difference(&lights.prt(), &rig.project(order));
        assert!(difference < ROUNDING, "{difference}");
    }

    #[test]
    fn phong_keeps_directional_and_hemisphere_lights_and_sums_the_rest_as_ambient() {
        let rig = Rig::parse(EVERY_STEERABLE_KIND, Path::new("test.toml")).unwrap();
        let phong = Lights::from_rig(&rig, 4).phong();
        assert_eq!(phong.lights.len(), 4);
        assert_eq!(phong.dropped, 0);
        assert!((phong.ambient - Vec3::splat(0.1)).abs().max_element() < 1e-7);
        let d = phong.lights[0].direction;
        let want = DVec3::new(0.3, -0.4, 0.8).normalize().as_vec3();
        assert!((d - want).length() < 1e-6, "{d} vs {want}");
        // A sphere's irradiance is πL·sin²δ with sin δ = radius / distance.
        let PhongShape::Directional { irradiance } = phong.lights[2].shape else {
            panic!("a sphere is directional in Blinn-Phong mode");
        };
        let want = std::f32::consts::PI * (0.5f32 / 4.0).powi(2);
        assert!((irradiance - Vec3::splat(want)).abs().max_element() < 1e-6);
    }

    #[test]
    fn the_default_rig_parses() {
        let lights = Lights::load(None, 4).unwrap();
        assert_eq!(lights.len(), 2);
    }

    #[test]
    fn benchmark_suns_share_the_irradiance() {
        for count in [1, 8] {
            let phong = Lights::suns(count, 4).phong();
            let total: Vec3 = phong
                .lights
                .iter()
                .map(|l| match l.shape {
                    PhongShape::Directional { irradiance } => irradiance,
                    _ => panic!("suns are directional"),
                })
                .sum();
            assert!((total - Vec3::splat(2.5)).abs().max_element() < 1e-5);
        }
    }
}
