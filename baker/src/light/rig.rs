//! Light rigs: a TOML file of `[[light]]` tables (`docs/reference/lights.md` documents every key).
//!
//! ```toml
//! [[light]]
//! kind = "directional"            # constant | directional | sun | sphere | hemisphere | environment
//! direction = [0.3, 0.4, 0.866]   # world-space vector pointing toward the light
//! color = [1.0, 0.5, 0.25]        # linear RGB
//! intensity = 2.0                 # directional/sun: irradiance E; the others: radiance L
//! ```
//!
//! The file is read into toml's spanned document tree and checked by hand rather than through
//! serde, so every error can name the file, the line *and* the key
//! (``rig.toml:4: light 1, key `intensity`: expected a number, found a string``; serde's
//! messages know the line but not the key), unknown and misplaced keys are refused (a typo
//! must not silently fall back to a default), and angles are given in degrees.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{DMat3, DVec3};
use toml::de::DeValue;

use super::coefficients::LightCoefficients;
use super::environment::EnvironmentMap;
use super::projection::{Light, project_sum};
use super::window::Window;
use crate::support::error::{Error, Location, Result};
use crate::support::input_path::AssetFolder;
use crate::support::toml_file::{self, Source, to_number};

/// The Sun's mean angular radius (16′), the default of `angular_radius` for a sun.
pub const SUN_ANGULAR_RADIUS_DEGREES: f64 = 0.2666;

/// A parsed rig: its lights and the ringing window applied to their sum.
#[derive(Clone, Debug)]
pub struct Rig {
    /// The file the rig came from.
    pub path: PathBuf,
    pub lights: Vec<Light>,
    pub window: Window,
}

impl Rig {
    /// Reads and checks a rig file; environment maps are loaded relative to its folder.
    pub fn load(path: &Path) -> Result<Rig> {
        let bytes = crate::support::limits::read_file(path)?;
        let text = String::from_utf8(bytes)
            .map_err(|_| Error::light(Location::file(path), "not a text file (invalid UTF-8)"))?;
        Rig::parse(&text, path)
    }

    /// Parses rig text; `path` names it in errors and anchors relative map paths.
    pub fn parse(text: &str, path: &Path) -> Result<Rig> {
        let source = Source::new(text, path, |location, message| {
            Error::light(location, message)
        });
        let document = source.parse()?;
        let mut rig = Rig {
            path: path.to_path_buf(),
            lights: Vec::new(),
            window: Window::None,
        };
        let top = Table(toml_file::Table {
            source: &source,
            table: document.get_ref(),
            line: 1,
            what: String::new(),
        });
        top.check_keys(&["light", "window", "window_width"], &[])?;
        if let Some((value, line)) = top.get("light") {
            let DeValue::Array(tables) = value.get_ref() else {
                return Err(source.error(
                    line,
                    format!(
                        "key `light`: expected [[light]] tables, found a {}",
                        value.get_ref().type_str()
                    ),
                ));
            };
            for (i, table) in tables.iter().enumerate() {
                let DeValue::Table(t) = table.get_ref() else {
                    return Err(source.error(
                        source.line(table.span().start),
                        format!(
                            "key `light`: expected [[light]] tables, found a {}",
                            table.get_ref().type_str()
                        ),
                    ));
                };
                let light = Table(toml_file::Table {
                    source: &source,
                    table: t,
                    line: source.line(table.span().start),
                    what: format!("light {}, ", i + 1),
                });
                rig.lights.push(light.to_light()?);
            }
        }
        if rig.lights.is_empty() {
            return Err(source.error(1, "no [[light]] tables: the rig has no lights"));
        }
        let width = top.positive("window_width")?;
        rig.window = match top.string("window")? {
            None | Some("none") if width.is_some() => {
                return Err(top.key_error(
                    "window_width",
                    "needs `window = \"hanning\"` or `\"lanczos\"`",
                ));
            }
            None | Some("none") => Window::None,
            Some("hanning") => Window::Hanning { width },
            Some("lanczos") => Window::Lanczos { width },
            Some(other) => {
                return Err(top.key_error(
                    "window",
                    format!("unknown window \"{other}\" (none, hanning or lanczos)"),
                ));
            }
        };
        Ok(rig)
    }

    /// The rig file and the environment maps it read: an output must not replace them.
    pub fn input_files(&self) -> Vec<PathBuf> {
        let maps = self.lights.iter().filter_map(|light| match light {
            Light::Environment { map, .. } => map.source().map(Path::to_path_buf),
            _ => None,
        });
        std::iter::once(self.path.clone()).chain(maps).collect()
    }

    /// The sum of the rig's lights at `order`, windowed.
    pub fn project(&self, order: usize) -> LightCoefficients {
        let mut sum = project_sum(&self.lights, order);
        sum.scale_bands(&self.window.factors(order));
        sum
    }
}

/// One table of the rig (the top level or a `[[light]]`), with the rig's keys.
struct Table<'a>(toml_file::Table<'a>);

impl<'a> std::ops::Deref for Table<'a> {
    type Target = toml_file::Table<'a>;
    fn deref(&self) -> &toml_file::Table<'a> {
        &self.0
    }
}

const KINDS: &str = "constant, directional, sun, sphere, hemisphere or environment";

impl Table<'_> {
    /// Refuses keys outside `allowed`; a key that belongs to other kinds is named as such.
    fn check_keys(&self, allowed: &[&str], other_kinds: &[&str]) -> Result<()> {
        for (key, _) in self.table.iter() {
            let name: &str = key.get_ref();
            if allowed.contains(&name) {
                continue;
            }
            let message = if other_kinds.contains(&name) {
                "does not apply to this kind of light".to_string()
            } else {
                format!("unknown key (known here: {})", allowed.join(", "))
            };
            return Err(self.key_error(name, message));
        }
        Ok(())
    }

    fn string(&self, key: &str) -> Result<Option<&str>> {
        match self.get(key) {
            None => Ok(None),
            Some((value, _)) => match value.get_ref() {
                DeValue::String(s) => Ok(Some(s)),
                other => Err(self.type_error(key, "a string", other)),
            },
        }
    }

    fn number(&self, key: &str) -> Result<Option<f64>> {
        match self.get(key) {
            None => Ok(None),
            Some((value, _)) => {
                let x = to_number(value.get_ref())
                    .ok_or_else(|| self.type_error(key, "a number", value.get_ref()))?;
                if !x.is_finite() {
                    return Err(self.key_error(key, format!("{x} is not finite")));
                }
                Ok(Some(x))
            }
        }
    }

    fn positive(&self, key: &str) -> Result<Option<f64>> {
        let x = self.number(key)?;
        if let Some(x) = x.filter(|x| *x <= 0.0) {
            return Err(self.key_error(key, format!("must be positive, not {x}")));
        }
        Ok(x)
    }

    fn vector3(&self, key: &str) -> Result<Option<DVec3>> {
        let Some((value, _)) = self.get(key) else {
            return Ok(None);
        };
        let expected = "an array of 3 numbers";
        let DeValue::Array(items) = value.get_ref() else {
            return Err(self.type_error(key, expected, value.get_ref()));
        };
        let numbers: Option<Vec<f64>> = items.iter().map(|v| to_number(v.get_ref())).collect();
        match numbers {
            Some(n) if n.len() == 3 => {
                if n.iter().any(|x| !x.is_finite()) {
                    return Err(self.key_error(key, "has a non-finite number"));
                }
                Ok(Some(DVec3::new(n[0], n[1], n[2])))
            }
            _ => Err(self.key_error(key, format!("expected {expected}"))),
        }
    }

    fn colour(&self, key: &str, default: DVec3) -> Result<DVec3> {
        let c = self.vector3(key)?.unwrap_or(default);
        if c.min_element() < 0.0 {
            return Err(self.key_error(key, "colour components must not be negative"));
        }
        Ok(c)
    }

    /// `direction = [x, y, z]` or `theta = …, phi = …` (degrees), as a unit vector.
    fn direction(&self) -> Result<Option<DVec3>> {
        let vector = self.vector3("direction")?;
        let (theta, phi) = (self.number("theta")?, self.number("phi")?);
        match (vector, theta, phi) {
            (Some(_), Some(_), _) | (Some(_), _, Some(_)) => Err(self.key_error(
                "direction",
                "give either `direction` or `theta` and `phi`, not both",
            )),
            (Some(v), None, None) => match v.try_normalize() {
                Some(d) => Ok(Some(d)),
                None => Err(self.key_error("direction", "must not be the zero vector")),
            },
            (None, Some(theta), Some(phi)) => {
                let (t, p) = (theta.to_radians(), phi.to_radians());
                Ok(Some(DVec3::new(
                    t.sin() * p.cos(),
                    t.sin() * p.sin(),
                    t.cos(),
                )))
            }
            (None, Some(_), None) => Err(self.key_error("theta", "needs `phi` as well")),
            (None, None, Some(_)) => Err(self.key_error("phi", "needs `theta` as well")),
            (None, None, None) => Ok(None),
        }
    }

    /// An angle in degrees, within [lo, hi).
    fn angle(&self, key: &str, lo: f64, hi: f64) -> Result<Option<f64>> {
        let x = self.number(key)?;
        if let Some(x) = x.filter(|x| !(lo..hi).contains(x)) {
            return Err(self.key_error(key, format!("{x}° is outside [{lo}°, {hi}°)")));
        }
        Ok(x.map(f64::to_radians))
    }

    fn to_light(&self) -> Result<Light> {
        let Some(kind) = self.string("kind")? else {
            return Err(self.missing("kind", KINDS));
        };
        const COMMON: [&str; 3] = ["kind", "color", "intensity"];
        const DIRECTION: [&str; 3] = ["direction", "theta", "phi"];
        let specific: &[&str] = match kind {
            "constant" => &[],
            "directional" => &DIRECTION,
            "sun" => &["direction", "theta", "phi", "angular_radius"],
            "sphere" => &[
                "direction",
                "theta",
                "phi",
                "angular_radius",
                "radius",
                "distance",
            ],
            "hemisphere" => &["direction", "theta", "phi", "ground_color"],
            "environment" => &["path", "rotation"],
            other => {
                return Err(self.key_error("kind", format!("unknown kind \"{other}\" ({KINDS})")));
            }
        };
        let all_keys = [
            "direction",
            "theta",
            "phi",
            "angular_radius",
            "radius",
            "distance",
            "ground_color",
            "path",
            "rotation",
        ];
        let allowed: Vec<&str> = COMMON.iter().chain(specific).copied().collect();
        self.check_keys(&allowed, &all_keys)?;

        let intensity = self.number("intensity")?.unwrap_or(1.0);
        if intensity < 0.0 {
            return Err(self.key_error("intensity", "must not be negative"));
        }
        let colour = self.colour("color", DVec3::ONE)? * intensity;
        let direction = || {
            self.direction()?
                .ok_or_else(|| self.missing("direction", "or `theta` and `phi`"))
        };
        Ok(match kind {
            "constant" => Light::Constant { radiance: colour },
            "directional" => Light::Directional {
                direction: direction()?,
                irradiance: colour,
            },
            "sun" => Light::Sun {
                direction: direction()?,
                irradiance: colour,
                angular_radius: self
                    .angle("angular_radius", 0.0, 90.0)?
                    .unwrap_or(SUN_ANGULAR_RADIUS_DEGREES.to_radians()),
            },
            "sphere" => Light::Sphere {
                direction: direction()?,
                radiance: colour,
                angular_radius: self.sphere_radius()?,
            },
            "hemisphere" => Light::Hemisphere {
                up: self.direction()?.unwrap_or(DVec3::Z),
                sky: colour,
                ground: self.colour("ground_color", DVec3::ZERO)? * intensity,
            },
            _ => self.environment(colour)?,
        })
    }

    /// A sphere's angular radius: `angular_radius`, or `radius` and `distance`.
    fn sphere_radius(&self) -> Result<f64> {
        let angular = self.angle("angular_radius", 0.0, 90.0)?;
        let (radius, distance) = (self.positive("radius")?, self.positive("distance")?);
        match (angular, radius, distance) {
            (Some(_), Some(_), _) | (Some(_), _, Some(_)) => Err(self.key_error(
                "angular_radius",
                "give either `angular_radius` or `radius` and `distance`, not both",
            )),
            (Some(a), None, None) if a > 0.0 => Ok(a),
            (Some(_), None, None) => {
                Err(self.key_error("angular_radius", "a sphere light needs a size"))
            }
            (None, Some(r), Some(d)) if r < d => Ok((r / d).asin()),
            (None, Some(r), Some(d)) => Err(self.key_error(
                "radius",
                format!(
                    "{r} is not smaller than the distance {d}: the sphere would enclose the scene"
                ),
            )),
            (None, None, _) => Err(self.missing("radius", "or `angular_radius`")),
            (None, _, None) => Err(self.missing("distance", "`radius` needs it")),
        }
    }

    fn environment(&self, scale: DVec3) -> Result<Light> {
        let Some(file) = self.string("path")? else {
            return Err(self.missing("path", "the .hdr or .exr map"));
        };
        // The map must lie in the rig's folder, and be a regular file (crate::support::input_path).
        let folder = self.source.path.parent().unwrap_or(Path::new(""));
        let at = Location::file(self.source.path);
        let map_path = AssetFolder::of(self.source.path)
            .admit(&at, "environment map", file, Path::new(file), folder)
            .map_err(|err| match err {
                Error::InputPath { message, .. } => self.key_error("path", message),
                other => other,
            })?;
        let map = EnvironmentMap::load(&map_path)
            .map_err(|err| self.key_error("path", format!("cannot use {file}: {err}")))?;
        let rotation = match self.vector3("rotation")? {
            None => DMat3::IDENTITY,
            Some(degrees) => {
                let r = degrees * (PI / 180.0);
                DMat3::from_rotation_z(r.z)
                    * DMat3::from_rotation_y(r.y)
                    * DMat3::from_rotation_z(r.x)
            }
        };
        Ok(Light::Environment {
            map: Arc::new(map),
            scale,
            rotation,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Rig> {
        Rig::parse(text, Path::new("rig.toml"))
    }

    fn error(text: &str) -> String {
        parse(text)
            .expect_err("the rig should be refused")
            .to_string()
    }

    #[test]
    fn the_issue_example_parses_as_written() {
        let rig = parse(
            r#"
[[light]]
kind = "directional"            # constant | directional | sun | sphere | hemisphere | environment
direction = [0.3, 0.4, 0.866]   # world-space vector pointing toward the light
color = [1.0, 0.5, 0.25]        # linear RGB
intensity = 2.0                 # directional/sun: irradiance E on a surface facing the light;
                                # constant/hemisphere: radiance L
"#,
        )
        .unwrap();
        assert_eq!(rig.lights.len(), 1);
        let Light::Directional {
            direction,
            irradiance,
        } = &rig.lights[0]
        else {
            panic!("{:?}", rig.lights[0]);
        };
        assert!((*direction - DVec3::new(0.3, 0.4, 0.866).normalize()).length() < 1e-15);
        assert_eq!(*irradiance, DVec3::new(2.0, 1.0, 0.5));
    }

    #[test]
    fn angles_in_degrees_and_integers_are_accepted() {
        let rig = parse(
            "window = \"hanning\"\n[[light]]\nkind = \"sun\"\ntheta = 90\nphi = 90.0\nintensity = 3\n",
        )
        .unwrap();
        let Light::Sun {
            direction,
            angular_radius,
            ..
        } = &rig.lights[0]
        else {
            panic!();
        };
        assert!((*direction - DVec3::Y).length() < 1e-15);
        assert_eq!(*angular_radius, SUN_ANGULAR_RADIUS_DEGREES.to_radians());
        assert_eq!(rig.window, Window::Hanning { width: None });
    }

    #[test]
    fn errors_name_the_file_line_and_key() {
        for (text, needles) in [
            (
                "[[light]]\nkind = \"directional\"\ndirection = [0, 0, 1]\nintensity = \"lots\"\n",
                &[
                    "rig.toml:4: ",
                    "light 1, key `intensity`",
                    "expected a number, found a string",
                ][..],
            ),
            (
                "[[light]]\nkind = \"constant\"\n\n[[light]]\nkind = \"sun\"\ncolour = [1, 1, 1]\n",
                &["rig.toml:6: ", "light 2, key `colour`", "unknown key"],
            ),
            (
                "[[light]]\nkind = \"constant\"\ndirection = [0, 0, 1]\n",
                &["rig.toml:3: ", "key `direction`", "does not apply"],
            ),
            (
                "# a rig\n[[light]]\nkind = \"sun\"\n",
                &["rig.toml:2: ", "light 1: missing key `direction`"],
            ),
            (
                "[[light]]\nkind = \"laser\"\n",
                &["rig.toml:2: ", "key `kind`", "unknown kind \"laser\""],
            ),
            (
                "[[light]]\nkind = \"directional\"\ndirection = [0, 0]\n",
                &["rig.toml:3: ", "key `direction`", "3 numbers"],
            ),
            (
                "[[light]]\nkind = \"sun\"\ndirection = [0, 0, 1]\nangular_radius = 95\n",
                &["rig.toml:4: ", "key `angular_radius`", "outside"],
            ),
            (
                "[[light]]\nkind = \"sphere\"\ndirection = [0, 0, 1]\nradius = 2\ndistance = 1\n",
                &[
                    "rig.toml:4: ",
                    "key `radius`",
                    "not smaller than the distance",
                ],
            ),
            (
                "[[light]]\nkind = \"constant\"\ncolor = [1, -1, 1]\n",
                &["rig.toml:3: ", "key `color`", "negative"],
            ),
            (
                "[[light]]\nkind = \"constant\"\nintensity = 1.0\nintensity = 2.0\n",
                &["rig.toml:4: ", "invalid TOML"],
            ),
            (
                "lights = 3\n",
                &["rig.toml:1: ", "key `lights`", "unknown key"],
            ),
            ("", &["rig.toml:1: ", "no [[light]] tables"]),
            (
                "window = \"gauss\"\n[[light]]\nkind = \"constant\"\n",
                &["rig.toml:1: ", "key `window`", "unknown window"],
            ),
            (
                "[[light]]\nkind = \"environment\"\npath = \"nothere.hdr\"\n",
                &["rig.toml:3: ", "key `path`", "nothere.hdr"],
            ),
        ] {
            let message = error(text);
            for needle in needles {
                assert!(
                    message.contains(needle),
                    "{message:?} lacks {needle:?} (rig {text:?})"
                );
            }
        }
    }
}
