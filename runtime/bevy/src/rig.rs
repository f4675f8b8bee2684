//! Rig files (docs/reference/lights.md) projected to SH, for the kinds a runtime can project
//! without an image: `constant`, `directional`, `sun`, `hemisphere`. A rig is written in the
//! baker's z-up world; its directions are turned to glTF's +Y up, (x, y, z) ↦ (x, z, −y),
//! before projecting, which equals turning the coefficients (`prt-bake light --up y`).

use std::path::Path;

use bevy::math::{DMat3, DVec3};
use bevy::prelude::*;
use serde::Deserialize;

use crate::light::{LightError, PrtLight, disk_band_factors};
use crate::sh;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RigFile {
    light: Vec<RigLight>,
    window: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RigLight {
    kind: String,
    color: Option<[f64; 3]>,
    intensity: Option<f64>,
    direction: Option<[f64; 3]>,
    theta: Option<f64>,
    phi: Option<f64>,
    angular_radius: Option<f64>,
    ground_color: Option<[f64; 3]>,
}

/// A rig's sun or directional light, for a Bevy light of its own (Bevy's specular, see
/// [`crate::PrtExtension::specular`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigSun {
    /// Towards the light, in the glTF frame (+Y up).
    pub direction: DVec3,
    /// Its irradiance on a facing surface (linear RGB, the rig's `color` × `intensity`).
    pub irradiance: DVec3,
}

impl RigSun {
    /// A [`DirectionalLight`] shining as this sun after `rotation` (the [`PrtLight`]'s
    /// rotation): its illuminance is the irradiance, so that with a camera exposure of 1
    /// (`Exposure { ev100: -log2(1.2) }`) Bevy's lighting is in T·L's units.
    pub fn directional_light(&self, rotation: DMat3) -> (DirectionalLight, Transform) {
        let towards = (rotation * self.direction).as_vec3().normalize();
        let up = if towards.y.abs() > 0.99 {
            Vec3::X
        } else {
            Vec3::Y
        };
        let strength = self.irradiance.max_element().max(1e-9);
        let colour = (self.irradiance / strength).as_vec3();
        (
            DirectionalLight {
                color: Color::linear_rgb(colour.x, colour.y, colour.z),
                illuminance: strength as f32,
                ..default()
            },
            Transform::IDENTITY.looking_to(-towards, up),
        )
    }
}

/// The suns and directional lights of the rig in `text` (read from `path`).
pub fn suns(text: &str, path: &Path) -> Result<Vec<RigSun>, LightError> {
    let (rig, lines) = parse(text, path)?;
    let mut out = Vec::new();
    for (i, l) in rig.light.iter().enumerate() {
        if l.kind == "sun" || l.kind == "directional" {
            let direction = direction_of(l)
                .and_then(|d| d.ok_or_else(|| format!("a {} needs `direction`", l.kind)))
                .map_err(|message| LightError::Rig {
                    path: path.to_path_buf(),
                    line: lines.get(i).copied().unwrap_or(1),
                    message,
                })?;
            out.push(RigSun {
                direction: sh::z_up_to_gltf() * direction,
                irradiance: colour_of(l),
            });
        }
    }
    Ok(out)
}

/// The rig and the line of each of its [[light]] tables (for the messages).
fn parse(text: &str, path: &Path) -> Result<(RigFile, Vec<usize>), LightError> {
    let rig: RigFile = toml::from_str(text).map_err(|e| {
        let line = e
            .span()
            .map_or(1, |s| text[..s.start].lines().count().max(1));
        LightError::Rig {
            path: path.to_path_buf(),
            line,
            message: e.message().to_string(),
        }
    })?;
    let lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with("[[light]]"))
        .map(|(i, _)| i + 1)
        .collect();
    Ok((rig, lines))
}

fn colour_of(l: &RigLight) -> DVec3 {
    DVec3::from(l.color.unwrap_or([1.0; 3])) * l.intensity.unwrap_or(1.0)
}

/// A light's direction (z-up, unit), if it gives one.
fn direction_of(l: &RigLight) -> Result<Option<DVec3>, String> {
    match (l.direction, l.theta, l.phi) {
        (Some(d), None, None) => Ok(Some(DVec3::from(d).normalize())),
        (None, Some(t), Some(p)) => {
            let (t, p) = (t.to_radians(), p.to_radians());
            Ok(Some(DVec3::new(
                t.sin() * p.cos(),
                t.sin() * p.sin(),
                t.cos(),
            )))
        }
        (None, None, None) => Ok(None),
        _ => Err("give either `direction` or `theta` and `phi`".into()),
    }
}

/// The rig in `text` (read from `path`) at `order`, in the glTF frame.
pub fn project(text: &str, path: &Path, order: usize) -> Result<PrtLight, LightError> {
    let error = |line: usize, message: String| LightError::Rig {
        path: path.to_path_buf(),
        line,
        message,
    };
    let (rig, lines) = parse(text, path)?;
    if rig.window.as_deref().is_some_and(|w| w != "none") {
        return Err(error(
            1,
            "a windowed rig: project it with `prt-bake light RIG --up y` and load the JSON".into(),
        ));
    }
    let to_gltf = sh::z_up_to_gltf();
    let mut light = PrtLight::zero(order);
    for (i, l) in rig.light.iter().enumerate() {
        let line = lines.get(i).copied().unwrap_or(1);
        let colour = colour_of(l);
        let direction = direction_of(l).map_err(|m| error(line, m))?;
        let needed = || {
            direction
                .map(|d| to_gltf * d)
                .ok_or_else(|| error(line, format!("a {} needs `direction`", l.kind)))
        };
        match l.kind.as_str() {
            "constant" => light.add_constant(colour),
            "directional" => light.add_zonal(needed()?, &vec![1.0; order], colour),
            "sun" => {
                let radius = l.angular_radius.unwrap_or(0.2666).to_radians();
                light.add_zonal(needed()?, &disk_band_factors(order, radius), colour);
            }
            "hemisphere" => {
                let up = to_gltf * direction.unwrap_or(DVec3::Z);
                let ground =
                    DVec3::from(l.ground_color.unwrap_or([0.0; 3])) * l.intensity.unwrap_or(1.0);
                light.add_hemisphere(up, colour, ground);
            }
            other => {
                return Err(error(
                    line,
                    format!(
                        "kind \"{other}\": project this rig with `prt-bake light RIG --up y` and load the JSON"
                    ),
                ));
            }
        }
    }
    Ok(light)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// prt-view's default rig (viewer/src/default-rig.toml) projected here equals
    /// `prt-bake light viewer/src/default-rig.toml --order 3 --up y` (its JSON, pasted).
    #[test]
    fn the_default_rig_projects_as_prt_bake_light_does() {
        let text = include_str!("../../../viewer/src/default-rig.toml");
        let light = project(text, Path::new("default-rig.toml"), 3).expect("rig");
        let expected = [
            [
                1.200779726214066,
                -0.7729760389796273,
                -0.6642363919549258,
                -1.1504911791021664,
                1.0872060322817556,
                0.6276986954024564,
                -0.3632842379690948,
                1.1657604301239817,
                0.7168774385339749,
            ],
            [
                1.195112494513122,
                -0.7924924291430031,
                -0.6110974805985318,
                -1.0584518847739932,
                1.0002295496992153,
                0.57748279977026,
                -0.3342214989315673,
                1.0724995957140633,
                0.6595272434512569,
            ],
            [
                1.22649185860708,
                -0.8486293404716619,
                -0.5313891135639407,
                -0.9203929432817333,
                0.8697648258254047,
                0.502158956321965,
                -0.2906273903752759,
                0.9326083440991857,
                0.5735019508271799,
            ],
        ];
        for (channel, want) in light.rgb.iter().zip(expected) {
            for (a, b) in channel.iter().zip(want) {
                assert!((a - b).abs() < 1e-9, "{a} vs {b}");
            }
        }
    }

    #[test]
    fn errors_name_the_file_and_line() {
        let text = "[[light]]\nkind = \"sun\"\n\n[[light]]\nkind = \"environment\"\n";
        let e = project(text, Path::new("r.toml"), 3)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("r.toml:1: a sun needs `direction`"), "{e}");
        let text = "[[light]]\nkind = \"environment\"\n";
        let e = project(text, Path::new("r.toml"), 3)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("r.toml:1: kind \"environment\""), "{e}");
    }
}
