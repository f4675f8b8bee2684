//! OBJ and MTL through tobj, with errors that name the file and line.
//!
//! tobj parses line by line and stops at the first bad line but does not say which; the
//! reader handed to it counts the lines it consumed, which is that line. A second, cheap pass
//! over the text catches what tobj lets through: non-finite numbers and faces with fewer than
//! three vertices (tobj drops those silently).

use std::cell::{Cell, RefCell};
use std::collections::HashMap;
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::alpha::{Alpha, AlphaMode, Wrap};
use super::mesh::{DEFAULT_KD, Glossy, Material, Mesh};
use super::texture::Texture;
use crate::math::glossy;
use crate::support::error::{Error, Location, Result};
use crate::support::input_path::AssetFolder;

/// What one OBJ file contributes: its meshes and the textures they index (from 0).
pub struct Loaded {
    pub meshes: Vec<Mesh>,
    pub textures: Vec<Texture>,
    /// The OBJ and the material libraries it read.
    pub files: Vec<PathBuf>,
}

/// Loads an OBJ. `override_texture` (the scene file's texture for this object) replaces any
/// `map_Kd` of its materials; objects with no material then get Kd = 1 so the texture is the
/// albedo, as in the thesis's scenes. The material libraries and textures it names must lie
/// in `folder` (that of the file given on the command line; see [`crate::support::input_path`]).
pub fn load(
    path: &Path,
    override_texture: Option<Texture>,
    folder: &AssetFolder,
) -> Result<Loaded> {
    let bytes = crate::support::limits::read_file(path)?;
    let parsed = parse(path, &bytes, folder)?;

    let text = String::from_utf8_lossy(&bytes);
    lint(path, &text)?;

    let (material_table, no_material, textures) = resolve_materials(
        path,
        folder,
        &parsed.materials,
        &parsed.texture_refs,
        override_texture,
    )?;

    let meshes: Vec<Mesh> = parsed
        .models
        .into_iter()
        .filter(|model| !model.mesh.indices.is_empty())
        .map(|model| to_mesh(model, &material_table, &no_material))
        .collect();
    if meshes.is_empty() {
        return Err(Error::scene(
            Location::file(path),
            "no faces: the file defines no triangles",
        ));
    }
    Ok(Loaded {
        meshes,
        textures,
        files: parsed.files,
    })
}

/// What tobj read from an OBJ and its material libraries.
struct Parsed {
    models: Vec<tobj::Model>,
    materials: Vec<tobj::Material>,
    /// The OBJ and the material libraries it read.
    files: Vec<PathBuf>,
    /// Material name → (MTL file, line of its map_Kd), to resolve and report textures.
    texture_refs: HashMap<String, (PathBuf, usize)>,
}

/// Runs tobj over the OBJ, admitting each material library it names through `folder`. The
/// first error wins: a material library's own, else tobj's at the line it stopped on.
fn parse(path: &Path, bytes: &[u8], folder: &AssetFolder) -> Result<Parsed> {
    let dir = path.parent().unwrap_or(Path::new(""));
    let files = RefCell::new(vec![path.to_path_buf()]);

    let obj_lines = Cell::new(LinePosition::default());
    let mtl_error: RefCell<Option<Error>> = RefCell::new(None);
    let texture_refs: RefCell<HashMap<String, (PathBuf, usize)>> = RefCell::new(HashMap::new());

    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = LineCounter {
        inner: bytes,
        position: &obj_lines,
    };
    let loaded = tobj::load_obj_buf(&mut reader, &options, |mtl_name| {
        let at_mtllib = Location::line(path, obj_lines.get().current());
        let result = folder
            .admit(
                &at_mtllib,
                "material library",
                &mtl_name.to_string_lossy(),
                mtl_name,
                dir,
            )
            .and_then(|mtl_path| {
                files.borrow_mut().push(mtl_path.clone());
                load_mtl(&mtl_path, &at_mtllib, &mut texture_refs.borrow_mut())
            });
        result.map_err(|err| {
            mtl_error.borrow_mut().get_or_insert(err);
            tobj::LoadError::OpenFileFailed
        })
    });
    if let Some(err) = mtl_error.into_inner() {
        return Err(err);
    }
    let (models, materials) = loaded.map_err(|err| {
        Error::scene(
            Location::line(path, obj_lines.get().current()),
            describe(&err),
        )
    })?;
    let materials = materials.map_err(|err| Error::scene(Location::file(path), describe(&err)))?;
    Ok(Parsed {
        models,
        materials,
        files: files.into_inner(),
        texture_refs: texture_refs.into_inner(),
    })
}

/// The scene's materials for tobj's, plus the one for faces without a material, and the
/// textures they index: the override (index 0) where given, else each `map_Kd`, admitted
/// through `folder` and loaded with its MTL line as the place to report.
fn resolve_materials(
    path: &Path,
    folder: &AssetFolder,
    materials: &[tobj::Material],
    texture_refs: &HashMap<String, (PathBuf, usize)>,
    override_texture: Option<Texture>,
) -> Result<(Vec<Material>, Material, Vec<Texture>)> {
    let mut textures = Vec::new();
    let override_index = override_texture.map(|t| {
        textures.push(t);
        0
    });
    let mut material_table = Vec::with_capacity(materials.len());
    for m in materials {
        let texture = match (override_index, &m.diffuse_texture) {
            (Some(index), _) => Some(index),
            (None, Some(name)) => {
                let (mtl_path, line) = texture_refs
                    .get(&m.name)
                    .cloned()
                    .unwrap_or_else(|| (path.to_path_buf(), 0));
                let at = if line > 0 {
                    Location::line(&mtl_path, line)
                } else {
                    Location::file(&mtl_path)
                };
                let texture_path = folder.admit(
                    &at,
                    "texture",
                    name.trim(),
                    Path::new(name.trim()),
                    mtl_path.parent().unwrap_or(Path::new("")),
                )?;
                textures.push(Texture::load(&texture_path, &at)?);
                Some(textures.len() - 1)
            }
            (None, None) => None,
        };
        let alpha = match &m.dissolve_texture {
            Some(name) => {
                let at = texture_refs
                    .get(&format!("{}\0map_d", m.name))
                    .map_or_else(|| Location::file(path), |(f, l)| Location::line(f, *l));
                let alpha_path = folder.admit(
                    &at,
                    "texture",
                    name.trim(),
                    Path::new(name.trim()),
                    at.path.parent().unwrap_or(Path::new("")),
                )?;
                textures.push(Texture::load(&alpha_path, &at)?);
                Some(map_d_alpha(
                    textures.len() - 1,
                    textures.last().expect("pushed"),
                ))
            }
            None => None,
        };
        material_table.push(Material {
            name: m.name.clone(),
            kd: m.diffuse.map(Vec3::from_array).unwrap_or(DEFAULT_KD),
            texture,
            sampling: Default::default(),
            glossy: mtl_glossy(m),
            alpha,
            normal_map: None,
            double_sided: false,
        });
    }
    let no_material = Material {
        name: String::from("default"),
        kd: if override_index.is_some() {
            Vec3::ONE
        } else {
            DEFAULT_KD
        },
        texture: override_index,
        sampling: Default::default(),
        glossy: None,
        alpha: None,
        normal_map: None,
        double_sided: false,
    };
    Ok((material_table, no_material, textures))
}

/// `map_d`'s coverage: the image's alpha channel where it has one that is not all opaque,
/// else its first channel (a grey map), as a probability ([`AlphaMode::Blend`]): MTL's
/// dissolve says no more.
fn map_d_alpha(index: usize, texture: &Texture) -> Alpha {
    let has_alpha = texture.srgb8.iter().any(|p| p[3] != 255);
    Alpha {
        mode: AlphaMode::Blend,
        factor: 1.0,
        texture: Some(index),
        channel: if has_alpha { 3 } else { 0 },
        wrap: [Wrap::Repeat; 2],
        transform: Alpha::IDENTITY,
    }
}

/// An MTL material is glossy when it gives a non-zero `Ks`; its `Ns` is the Phong exponent
/// (absent: 0, a lobe as wide as the hemisphere).
fn mtl_glossy(m: &tobj::Material) -> Option<Glossy> {
    let ks = Vec3::from_array(m.specular?);
    if !ks.is_finite() || ks.max_element() <= 0.0 {
        return None;
    }
    Some(Glossy {
        ks: ks.clamp(Vec3::ZERO, Vec3::ONE),
        exponent: glossy::exponent_from_ns(m.shininess.unwrap_or(0.0)),
        diffuse_weight: 1.0,
    })
}

fn to_mesh(model: tobj::Model, materials: &[Material], no_material: &Material) -> Mesh {
    let m = model.mesh;
    let vec3s = |flat: &[f32]| {
        flat.chunks_exact(3)
            .map(Vec3::from_slice)
            .collect::<Vec<_>>()
    };
    let positions = vec3s(&m.positions);
    let normals = (m.normals.len() == m.positions.len()).then(|| vec3s(&m.normals));
    let uvs = (m.texcoords.len() / 2 == positions.len())
        .then(|| m.texcoords.chunks_exact(2).map(Vec2::from_slice).collect());
    let triangles = m
        .indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    let material = m
        .material_id
        .and_then(|id| materials.get(id))
        .cloned()
        .unwrap_or_else(|| no_material.clone());
    Mesh {
        name: model.name,
        positions,
        normals,
        uvs,
        triangles,
        material,
    }
}

fn load_mtl(
    mtl_path: &Path,
    at_mtllib: &Location,
    texture_refs: &mut HashMap<String, (PathBuf, usize)>,
) -> Result<(Vec<tobj::Material>, HashMap<String, usize>)> {
    let bytes = crate::support::input_path::read(mtl_path).map_err(|err| match err {
        Error::Io { source, .. } => Error::scene(
            at_mtllib.clone(),
            format!(
                "cannot read material library {}: {source}",
                mtl_path.display()
            ),
        ),
        other => other,
    })?;
    // tobj 4.0.5 panics on a colour with fewer than three numbers (`Kd 1 1`); refuse it first.
    for (index, line) in String::from_utf8_lossy(&bytes).lines().enumerate() {
        let mut words = line.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next() {
            let count = words.count();
            if count < 3 {
                return Err(Error::scene(
                    Location::line(mtl_path, index + 1),
                    format!("`{key}` needs three numbers (r g b), found {count}"),
                ));
            }
        }
    }
    let lines = Cell::new(LinePosition::default());
    let mut reader = LineCounter {
        inner: &bytes[..],
        position: &lines,
    };
    let result = tobj::load_mtl_buf(&mut reader).map_err(|err| {
        Error::scene(
            Location::line(mtl_path, lines.get().current()),
            describe(&err),
        )
    })?;
    let mut current = None;
    for (index, line) in String::from_utf8_lossy(&bytes).lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("newmtl") => current = Some(words.collect::<Vec<_>>().join(" ")),
            Some("map_Kd") => {
                if let Some(name) = &current {
                    texture_refs.insert(name.clone(), (mtl_path.to_path_buf(), index + 1));
                }
            }
            // Keyed apart from map_Kd's, by a name no material can have.
            Some("map_d") => {
                if let Some(name) = &current {
                    let key = format!("{name}\0map_d");
                    texture_refs.insert(key, (mtl_path.to_path_buf(), index + 1));
                }
            }
            _ => {}
        }
    }
    Ok(result)
}

/// Checks what tobj accepts but a bake cannot use.
fn lint(path: &Path, text: &str) -> Result<()> {
    for (index, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let keyword = words.next();
        let problem = match keyword {
            Some(kind @ ("v" | "vn" | "vt")) => words
                .filter_map(|w| w.parse::<f32>().ok())
                .any(|x| !x.is_finite())
                .then(|| format!("non-finite number in `{kind}` line: {}", line.trim())),
            Some("f") => {
                let count = words.count();
                (count < 3).then(|| format!("face with {count} vertices (a face needs at least 3)"))
            }
            _ => None,
        };
        if let Some(message) = problem {
            return Err(Error::scene(Location::line(path, index + 1), message));
        }
    }
    Ok(())
}

fn describe(err: &tobj::LoadError) -> String {
    use tobj::LoadError as E;
    match err {
        E::PositionParseError => "malformed vertex position (expected `v x y z`)".into(),
        E::NormalParseError => "malformed normal (expected `vn x y z`)".into(),
        E::TexcoordParseError => "malformed texture coordinate (expected `vt u [v]`)".into(),
        E::FaceParseError => {
            "malformed face (expected `f v[/vt][/vn] ...` with integer indices)".into()
        }
        E::FaceVertexOutOfBounds => {
            "face index out of range: no such vertex position (`v`) before this line".into()
        }
        E::FaceTexCoordOutOfBounds => {
            "face index out of range: no such texture coordinate (`vt`) before this line".into()
        }
        E::FaceNormalOutOfBounds => {
            "face index out of range: no such normal (`vn`) before this line".into()
        }
        E::ReadError => "unreadable line (not valid UTF-8?)".into(),
        other => other.to_string(),
    }
}

/// How far a [`LineCounter`] has read: the number of newlines consumed, and whether anything
/// follows the last one.
#[derive(Clone, Copy, Default)]
struct LinePosition {
    newlines: usize,
    mid_line: bool,
}

impl LinePosition {
    /// The 1-based number of the line consumed last.
    fn current(self) -> usize {
        self.newlines + usize::from(self.mid_line)
    }
}

/// A `BufRead` that counts the lines its consumer has taken.
struct LineCounter<'a> {
    inner: &'a [u8],
    position: &'a Cell<LinePosition>,
}

impl Read for LineCounter<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.len().min(buf.len());
        buf[..n].copy_from_slice(&self.inner[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl BufRead for LineCounter<'_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        Ok(self.inner)
    }

    fn consume(&mut self, amount: usize) {
        let (taken, rest) = self.inner.split_at(amount);
        if let Some(&last) = taken.last() {
            let mut position = self.position.get();
            position.newlines += taken.iter().filter(|&&b| b == b'\n').count();
            position.mid_line = last != b'\n';
            self.position.set(position);
        }
        self.inner = rest;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    /// `Ks` and `Ns` make a glossy layer; a material without `Ks` (or with a black one)
    /// stays diffuse.
    #[test]
    fn mtl_ks_and_ns_make_a_glossy_layer() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("m.mtl"),
            "newmtl shiny\nKd 0.2 0.3 0.4\nKs 0.5 0.5 0.25\nNs 96\n\
             newmtl matte\nKd 0.5 0.5 0.5\nKs 0 0 0\nNs 10\n",
        )
        .unwrap();
        std::fs::write(
            dir.path().join("s.obj"),
            "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
             usemtl shiny\nf 1 2 3\nusemtl matte\nf 2 4 3\n",
        )
        .unwrap();
        let scene = Scene::load(&dir.path().join("s.obj")).unwrap();
        let shiny = scene.triangle_material(0);
        assert_eq!(
            shiny.glossy,
            Some(Glossy {
                ks: Vec3::new(0.5, 0.5, 0.25),
                exponent: 96.0,
                diffuse_weight: 1.0,
            })
        );
        assert_eq!(scene.triangle_material(1).glossy, None);
    }
}
