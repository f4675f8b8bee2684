//! The materials file of `bake --materials`: per material name (OBJ `usemtl`, glTF material
//! name), what the scene's own files cannot say. Today that is a subsurface medium:
//!
//! ```toml
//! [material.skin.subsurface]
//! scattering = [0.99, 0.9, 0.5]   # reduced scattering coefficient σs′ per scene unit, R G B
//! absorption = [0.01, 0.1, 0.5]   # absorption coefficient σa per scene unit
//! ior = 1.3                        # relative index of refraction of the boundary (default 1)
//! ```
//!
//! Read through toml's spanned document tree, as light rigs are, so that every error names the
//! file, the line and the key; unknown keys, negative or non-finite numbers and names the scene
//! does not have are refused rather than ignored.

use std::path::{Path, PathBuf};

use glam::Vec3;
use toml::de::DeValue;

use super::mesh::Material;
use crate::math::medium::Medium;
use crate::support::error::{Error, Location, Result};
use crate::support::toml_file::{self, Source, to_number as number};

/// One `[material.NAME]` table.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialEntry {
    pub name: String,
    /// The line of its header, for errors found later (a name the scene lacks).
    pub line: usize,
    pub subsurface: Option<Medium>,
}

/// A parsed materials file.
#[derive(Clone, Debug, PartialEq)]
pub struct Materials {
    pub path: PathBuf,
    pub entries: Vec<MaterialEntry>,
}

impl Materials {
    pub fn load(path: &Path) -> Result<Materials> {
        let bytes = crate::support::limits::read_file(path)?;
        let text = String::from_utf8(bytes)
            .map_err(|_| Error::scene(Location::file(path), "not a text file (invalid UTF-8)"))?;
        Materials::parse(&text, path)
    }

    /// Parses materials text; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Materials> {
        let source = Source::new(text, path, |location, message| {
            Error::scene(location, message)
        });
        let document = source.parse()?;
        let top = Table(toml_file::Table {
            source: &source,
            table: document.get_ref(),
            line: 1,
            what: String::new(),
        });
        top.check_keys(&["material"])?;
        let mut entries = Vec::new();
        if let Some((value, line)) = top.get("material") {
            let DeValue::Table(materials) = value.get_ref() else {
                return Err(source.error(line, "key `material`: expected [material.NAME] tables"));
            };
            for (name, value) in materials.iter() {
                let line = source.line(name.span().start);
                let name: &str = name.get_ref();
                let DeValue::Table(table) = value.get_ref() else {
                    return Err(source.error(
                        line,
                        format!(
                            "material `{name}`: expected a table, found a {}",
                            value.get_ref().type_str()
                        ),
                    ));
                };
                let material = Table(toml_file::Table {
                    source: &source,
                    table,
                    line,
                    what: format!("material `{name}`, "),
                });
                entries.push(material.to_entry(name)?);
            }
        }
        Ok(Materials {
            path: path.to_path_buf(),
            entries,
        })
    }

    /// The medium of each of a scene's `materials` (the scene read from `scene_path`), `None`
    /// for opaque ones. A name the scene does not have is an error at its line: a typo must
    /// not leave an object opaque without a word.
    pub fn media_for(
        &self,
        scene_path: &Path,
        materials: &[Material],
    ) -> Result<Vec<Option<Medium>>> {
        for entry in &self.entries {
            if !materials.iter().any(|m| m.name == entry.name) {
                let mut names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
                names.sort_unstable();
                names.dedup();
                return Err(Error::scene(
                    Location::line(&self.path, entry.line),
                    format!(
                        "material `{}` is not in {} (its materials: {})",
                        entry.name,
                        scene_path.display(),
                        names.join(", ")
                    ),
                ));
            }
        }
        Ok(materials
            .iter()
            .map(|m| {
                self.entries
                    .iter()
                    .find(|e| e.name == m.name)
                    .and_then(|e| e.subsurface)
            })
            .collect())
    }
}

/// One table of the file, with the materials' keys.
struct Table<'a>(toml_file::Table<'a>);

impl<'a> std::ops::Deref for Table<'a> {
    type Target = toml_file::Table<'a>;
    fn deref(&self) -> &toml_file::Table<'a> {
        &self.0
    }
}

impl Table<'_> {
    fn check_keys(&self, allowed: &[&str]) -> Result<()> {
        for (key, _) in self.table.iter() {
            let name: &str = key.get_ref();
            if !allowed.contains(&name) {
                return Err(self.key_error(
                    name,
                    format!("unknown key (known here: {})", allowed.join(", ")),
                ));
            }
        }
        Ok(())
    }

    fn to_entry(&self, name: &str) -> Result<MaterialEntry> {
        self.check_keys(&["subsurface"])?;
        let subsurface = match self.get("subsurface") {
            None => None,
            Some((value, line)) => {
                let DeValue::Table(table) = value.get_ref() else {
                    return Err(self.key_error(
                        "subsurface",
                        format!("expected a table, found a {}", value.get_ref().type_str()),
                    ));
                };
                let subsurface = Table(toml_file::Table {
                    source: self.source,
                    table,
                    line,
                    what: format!("{}subsurface, ", self.what),
                });
                Some(subsurface.to_medium()?)
            }
        };
        Ok(MaterialEntry {
            name: name.to_string(),
            line: self.line,
            subsurface,
        })
    }

    fn to_medium(&self) -> Result<Medium> {
        self.check_keys(&["scattering", "absorption", "ior"])?;
        let scattering = self.colour("scattering")?;
        let absorption = self.colour("absorption")?;
        if (scattering + absorption).min_element() <= 0.0 {
            return Err(self.key_error(
                "scattering",
                "scattering + absorption must be positive in every channel (a medium that \
                 neither scatters nor absorbs is not a subsurface medium)",
            ));
        }
        let ior = match self.get("ior") {
            None => 1.0,
            Some((value, _)) => {
                let x = number(value.get_ref())
                    .ok_or_else(|| self.key_error("ior", "expected a number"))?;
                if !(x.is_finite() && x > 0.0) {
                    return Err(
                        self.key_error("ior", format!("must be a positive number, not {x}"))
                    );
                }
                x as f32
            }
        };
        Ok(Medium {
            scattering,
            absorption,
            ior,
        })
    }

    /// `key = [r, g, b]` (or one number for all three): finite and not negative; required.
    fn colour(&self, key: &str) -> Result<Vec3> {
        let Some((value, _)) = self.get(key) else {
            return Err(self.missing(key, "per scene unit, R G B"));
        };
        let expected = "an array of 3 numbers, or one number";
        let numbers: Vec<f64> = match value.get_ref() {
            DeValue::Array(items) => items
                .iter()
                .map(|v| number(v.get_ref()))
                .collect::<Option<Vec<f64>>>()
                .filter(|n| n.len() == 3)
                .ok_or_else(|| self.key_error(key, format!("expected {expected}")))?,
            other => vec![
                number(other)
                    .ok_or_else(|| self.key_error(key, format!("expected {expected}")))?;
                3
            ],
        };
        if let Some(x) = numbers.iter().find(|x| !x.is_finite()) {
            return Err(self.key_error(key, format!("{x} is not finite")));
        }
        if let Some(x) = numbers.iter().find(|x| **x < 0.0) {
            return Err(self.key_error(key, format!("{x} is negative")));
        }
        Ok(Vec3::new(
            numbers[0] as f32,
            numbers[1] as f32,
            numbers[2] as f32,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Materials> {
        Materials::parse(text, Path::new("mats.toml"))
    }

    fn message(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    #[test]
    fn reads_a_subsurface_medium() {
        let m = parse(
            "[material.skin.subsurface]\nscattering = [0.99, 0.9, 0.5]\n\
             absorption = [0.01, 0.1, 0.5]\nior = 1.3\n\n[material.floor]\n",
        )
        .unwrap();
        assert_eq!(m.entries.len(), 2);
        let skin = m.entries.iter().find(|e| e.name == "skin").unwrap();
        let medium = skin.subsurface.unwrap();
        assert_eq!(medium.scattering, Vec3::new(0.99, 0.9, 0.5));
        assert_eq!(medium.absorption, Vec3::new(0.01, 0.1, 0.5));
        assert_eq!(medium.ior, 1.3);
        let floor = m.entries.iter().find(|e| e.name == "floor").unwrap();
        assert!(floor.subsurface.is_none());
        let grey = parse("[material.wax.subsurface]\nscattering = 2\nabsorption = 0\n").unwrap();
        assert_eq!(grey.entries[0].subsurface.unwrap().ior, 1.0);
    }

    #[test]
    fn names_the_scene_lacks_are_errors_at_their_line() {
        let m = parse("# media\n\n[material.wax.subsurface]\nscattering = 1\nabsorption = 0\n")
            .unwrap();
        let named = |name: &str| Material {
            name: name.into(),
            ..Material::default()
        };
        let media = m
            .media_for(Path::new("s.obj"), &[named("floor"), named("wax")])
            .unwrap();
        assert!(media[0].is_none() && media[1].is_some());
        let err = m
            .media_for(Path::new("s.obj"), &[named("floor"), named("wac")])
            .unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains("mats.toml:3")
                && text.contains("`wax` is not in s.obj")
                && text.contains("floor, wac"),
            "{text}"
        );
    }

    #[test]
    fn errors_name_the_file_line_and_key() {
        let text =
            "[material.skin.subsurface]\nscattering = [1, 1, 1]\nabsorption = [0.1, -0.2, 0]\n";
        let m = message(text);
        assert!(
            m.contains("mats.toml:3") && m.contains("absorption") && m.contains("negative"),
            "{m}"
        );
        let m = message(
            "[material.skin.subsurface]\nscattering = [1, 1, 1]\nabsorption = 0\nior = nan\n",
        );
        assert!(m.contains("mats.toml:4") && m.contains("ior"), "{m}");
        let m = message("[material.skin.subsurface]\nscattering = [1, inf, 1]\nabsorption = 0\n");
        assert!(m.contains("mats.toml:2") && m.contains("not finite"), "{m}");
        let m = message("[material.skin.subsurface]\nscattering = 1\nabsorption = 0\nsigma = 3\n");
        assert!(
            m.contains("mats.toml:4") && m.contains("unknown key `sigma`")
                || m.contains("key `sigma`: unknown"),
            "{m}"
        );
        let m = message("[material.skin]\nsubsurf = 1\n");
        assert!(m.contains("mats.toml:2") && m.contains("subsurf"), "{m}");
        let m = message("[material.skin.subsurface]\nscattering = [1, 1]\nabsorption = 0\n");
        assert!(m.contains("mats.toml:2") && m.contains("3 numbers"), "{m}");
        let m = message("[material.skin.subsurface]\nabsorption = 0\n");
        assert!(
            m.contains("mats.toml:1") && m.contains("missing key `scattering`"),
            "{m}"
        );
        let m = message("[materials.skin]\n");
        assert!(m.contains("mats.toml:1") && m.contains("materials"), "{m}");
        let m = message("[material.skin.subsurface\n");
        assert!(
            m.contains("mats.toml:1") && m.contains("invalid TOML"),
            "{m}"
        );
    }
}
