//! [`PrtLight`]: the distant light PRT meshes are relit by, as SH coefficients in the glTF
//! frame (+Y up) of the exports, and the turn applied to it every frame.
//!
//! Sources: the JSON `prt-bake light RIG --order N --up y` writes (any rig, environment maps
//! included), the light an export carries (`export --lights`: `asset.extras.prt.light`), a rig
//! file's suns, skies and constants projected here, or a sun direction and sky colours.

use std::path::{Path, PathBuf};

use bevy::math::{DMat3, DVec3};
use bevy::prelude::Resource;
use serde::Deserialize;

use crate::sh;

/// Why a light could not be read.
#[derive(Debug, thiserror::Error)]
pub enum LightError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not a prt-bake light JSON: {message}")]
    Json { path: PathBuf, message: String },
    #[error("{path}:{line}: {message}")]
    Rig {
        path: PathBuf,
        line: usize,
        message: String,
    },
}

/// The Sun's mean angular radius (16′), a rig sun's default (as the baker's).
const SUN_ANGULAR_RADIUS_DEGREES: f64 = 0.2666;

/// A distant light in SH and the rotation it is turned by before each frame.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct PrtLight {
    /// The order n: n² coefficients per channel.
    pub order: usize,
    /// R, G, B coefficients in the exports' glTF frame (+Y up), unturned.
    pub rgb: [Vec<f64>; 3],
    /// What shone from d shines from `rotation`·d (glTF frame); set it every frame to move the
    /// light at no extra bake.
    pub rotation: DMat3,
}

#[derive(Deserialize)]
struct LightJson {
    order: usize,
    coefficients: Vec<Vec<f64>>,
}

impl PrtLight {
    /// No light, of an order.
    pub fn zero(order: usize) -> PrtLight {
        let n = sh::coeff_count(order);
        PrtLight {
            order,
            rgb: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            rotation: DMat3::IDENTITY,
        }
    }

    /// `prt-bake light RIG --order N --up y`'s JSON (or an export's `asset.extras.prt.light`).
    pub fn from_json_value(value: &serde_json::Value, path: &Path) -> Result<PrtLight, LightError> {
        let error = |message: String| LightError::Json {
            path: path.to_path_buf(),
            message,
        };
        let json: LightJson =
            serde_json::from_value(value.clone()).map_err(|e| error(e.to_string()))?;
        let n = sh::coeff_count(json.order);
        if !(1..=16).contains(&json.order) || json.coefficients.len() != 3 {
            return Err(error(
                "needs an order in 1..16 and 3 coefficient arrays".into(),
            ));
        }
        if json.coefficients.iter().any(|c| c.len() != n) {
            return Err(error(format!(
                "order {} needs {n} coefficients a channel",
                json.order
            )));
        }
        let [r, g, b]: [Vec<f64>; 3] = json.coefficients.try_into().expect("3 channels");
        Ok(PrtLight {
            order: json.order,
            rgb: [r, g, b],
            rotation: DMat3::IDENTITY,
        })
    }

    /// Reads a `prt-bake light … --up y` JSON file.
    pub fn from_json_file(path: &Path) -> Result<PrtLight, LightError> {
        let text = std::fs::read_to_string(path).map_err(|source| LightError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let value = serde_json::from_str(&text).map_err(|e| LightError::Json {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        PrtLight::from_json_value(&value, path)
    }

    /// A rig file (docs/reference/lights.md, written z-up) projected at `order` and turned
    /// into the glTF frame. Suns, directional, sphere-less skies and constants are projected
    /// here; environment maps, spheres and windows are refused with a pointer to
    /// `prt-bake light RIG --up y`, whose JSON [`PrtLight::from_json_file`] reads.
    pub fn from_rig_file(path: &Path, order: usize) -> Result<PrtLight, LightError> {
        let text = std::fs::read_to_string(path).map_err(|source| LightError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        crate::rig::project(&text, path, order)
    }

    /// The suns and directional lights of a rig file, for Bevy lights of their own (Bevy's
    /// specular, [`crate::PrtExtension::specular`]), in the glTF frame.
    pub fn rig_suns(path: &Path) -> Result<Vec<crate::RigSun>, LightError> {
        let text = std::fs::read_to_string(path).map_err(|source| LightError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        crate::rig::suns(&text, path)
    }

    /// A sun of irradiance `sun` (linear RGB, W/m² on a facing surface) from `direction`
    /// (glTF frame, towards the sun) over a sky of radiance `sky` above `up` and `ground`
    /// below: the rig `sun` + `hemisphere` of docs/reference/lights.md.
    pub fn sun_and_sky(
        order: usize,
        direction: DVec3,
        sun: DVec3,
        sky: DVec3,
        ground: DVec3,
        up: DVec3,
    ) -> PrtLight {
        let mut light = PrtLight::zero(order);
        light.add_sun(direction, sun, SUN_ANGULAR_RADIUS_DEGREES.to_radians());
        light.add_hemisphere(up, sky, ground);
        light
    }

    /// Adds c_lm = E·g_l(δ)·y_lm(direction): a disk of angular radius δ giving irradiance E.
    pub fn add_sun(&mut self, direction: DVec3, irradiance: DVec3, angular_radius: f64) {
        let factors = disk_band_factors(self.order, angular_radius);
        self.add_zonal(direction, &factors, irradiance);
    }

    /// Adds radiance `ground` everywhere and `sky − ground` over the hemisphere around `up`.
    pub fn add_hemisphere(&mut self, up: DVec3, sky: DVec3, ground: DVec3) {
        self.add_constant(ground);
        let factors = disk_band_factors(self.order, std::f64::consts::FRAC_PI_2);
        self.add_zonal(up, &factors, (sky - ground) * std::f64::consts::PI);
    }

    /// Adds a constant radiance: c₀₀ = L·√(4π).
    pub fn add_constant(&mut self, radiance: DVec3) {
        let k = (4.0 * std::f64::consts::PI).sqrt();
        for (c, x) in self.rgb.iter_mut().zip(radiance.to_array()) {
            c[0] += k * x;
        }
    }

    /// Adds factors[l]·y_lm(direction) times `colour`.
    pub fn add_zonal(&mut self, direction: DVec3, factors: &[f64], colour: DVec3) {
        let y = sh::basis(self.order, direction.normalize());
        for (c, k) in self.rgb.iter_mut().zip(colour.to_array()) {
            for (j, x) in c.iter_mut().enumerate() {
                *x += k * factors[sh::band(j)] * y[j];
            }
        }
    }

    /// The coefficients turned by `rotation`, cut or zero-padded to `order`.
    pub fn turned(&self, order: usize) -> [Vec<f64>; 3] {
        let bands = sh::rotation(self.order, self.rotation);
        let n = sh::coeff_count(order);
        self.rgb.clone().map(|c| {
            let mut out = sh::rotate(&bands, &c);
            out.resize(n, 0.0);
            out
        })
    }

    /// The light turned by `m` first (the unturned coefficients rotated once).
    pub fn rotated(&self, m: DMat3) -> PrtLight {
        let bands = sh::rotation(self.order, m);
        PrtLight {
            order: self.order,
            rgb: self.rgb.clone().map(|c| sh::rotate(&bands, &c)),
            rotation: self.rotation,
        }
    }
}

/// Band factors g_l(δ) of a uniform disk of angular radius δ scaled to unit irradiance on a
/// facing surface, relative to a unit delta (baker/src/light/projection.rs): g_0 =
/// 1/cos²(δ/2), g_l = 2 P_l′(cos δ)/(l(l+1)).
pub fn disk_band_factors(order: usize, angular_radius: f64) -> Vec<f64> {
    let x = angular_radius.cos();
    let half = (0.5 * angular_radius).cos();
    let (mut p, mut dp, mut p_prev) = (1.0f64, 0.0f64, 0.0f64);
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
