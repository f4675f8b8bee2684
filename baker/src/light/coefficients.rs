//! A light's RGB SH coefficients, the one thing every light becomes.

use glam::DVec3;
use serde::Serialize;

use crate::math::sh;
use crate::math::sh::rotation::ShRotation;

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
