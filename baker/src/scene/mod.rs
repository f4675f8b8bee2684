//! Scenes: triangle meshes with per-vertex normals and texture coordinates, and the materials
//! (Kd × texture) the renderer and the interreflection pass need.
//!
//! Three inputs are accepted, chosen by the extension (see `docs/reference/scenes.md`):
//! * the thesis's scene file (`.scene`, or any other text file): one
//!   `"object.obj" "texture.tga"` per line, quotes allow spaces, `#` starts a comment, the
//!   texture is optional; objects are already in world space;
//! * a bare `.obj` file;
//! * a glTF 2.0 file (`.gltf`, `.glb`), its node hierarchy flattened to world space.
//!
//! A vertex is a unique (position, normal, uv) combination, as OBJ faces reference them.
//! Normals come from the file, or are computed (angle-weighted, welded by position within a
//! mesh) where the file has none.
//!
//! May import: [`crate::support`], [`crate::math`].

mod alpha;
mod back_sheets;
mod format;
mod gltf;
mod instances;
mod materials;
mod mesh;
mod normal_map;
mod normals;
mod obj;
mod scene_file;
mod tangents;
mod texture;
mod up;

use std::ops::Range;
use std::path::{Path, PathBuf};

use glam::{Mat3, Vec2, Vec3, Vec4};

use crate::support::error::{Error, Location, Result};
use crate::support::input_path::AssetFolder;

pub use alpha::{Alpha, AlphaMode, Cutouts, Sampling, TextureTransform, Wrap};
pub use back_sheets::BackSheets;
pub use format::FORMATS;
use format::OTHER_FORMATS;
pub use gltf::volume::{GltfMedia, gltf_media};
pub use gltf::{AUTO_MIN_TRIANGLES, INSTANCE_BYTES, Instancing, Pose};
pub use instances::{InstanceMesh, Instances, Placement, mesh_bounds, world_normal};
pub use materials::{MaterialEntry, Materials};
pub use mesh::{DEFAULT_KD, Glossy, Hierarchy, HierarchyNode, Material, Mesh};
pub use normal_map::NormalMap;
pub use normals::angle_weighted_normals;
pub use scene_file::{SceneEntry, parse_scene_file};
pub use texture::{Texture, srgb_to_linear};
pub use up::Up;

/// A named part of a scene (one line of a scene file, or one OBJ object) and its ranges in
/// the scene's vertex and triangle arrays.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    pub name: String,
    pub vertices: Range<u32>,
    pub triangles: Range<u32>,
}

/// A static scene, every array indexed by vertex (or by triangle for `triangles`).
#[derive(Clone, Debug)]
pub struct Scene {
    /// The file the scene came from; errors and reports name it.
    pub path: PathBuf,
    pub objects: Vec<Object>,
    /// glTF scenes: the node hierarchy the objects came from.
    pub hierarchy: Option<Hierarchy>,
    pub positions: Vec<Vec3>,
    /// Unit shading normals.
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    /// Index into `materials` for every vertex (each mesh has one material).
    pub vertex_material: Vec<u32>,
    pub triangles: Vec<[u32; 3]>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    /// Files read besides `path` and the textures (OBJs, material libraries), for
    /// [`Scene::input_files`].
    pub sources: Vec<PathBuf>,
    /// The format's up axis: +y for glTF, +z otherwise. A bake's `--up` overrides it.
    pub up: Up,
    /// Second texture coordinates (glTF TEXCOORD_1, e.g. lightmap UVs), per vertex, where any
    /// mesh has them ((0, 0) for those that do not).
    pub lightmap_uvs: Option<Vec<Vec2>>,
    /// Per vertex, the tangent (xyz, w = ±1 the bitangent's sign) of objects whose material
    /// has a normal map, zero elsewhere; `None` where none has one ([`tangents`]).
    pub tangents: Option<Vec<Vec4>>,
    /// A digest of the source file's whole content where the format calls for one (glTF:
    /// JSON, buffers, images), folded into [`Scene::fingerprint`].
    pub content_digest: Option<u64>,
    /// Occluders traced through instances, outside every array above
    /// ([`Scene::load_instanced`]); empty where the scene was loaded flat.
    pub instances: Instances,
    /// The back sheets of glTF `doubleSided` objects, the last objects ([`BackSheets`]).
    pub back_sheets: BackSheets,
    /// glTF scenes with a skin: per vertex, the linear part of the matrix that posed it
    /// (the blend of its joints' J · IBM, or its node's world matrix), by which lobe axes
    /// turn with the skin; `None` otherwise.
    pub pose_linear: Option<Vec<Mat3>>,
    /// With `pose_linear`: per object, the glTF mesh and primitive it was read from (the
    /// LDPRT export writes its attributes there).
    pub gltf_primitives: Option<Vec<[u32; 2]>>,
}

impl Scene {
    /// Loads a scene file, a bare `.obj` or a glTF file, chosen by the extension. Warnings
    /// (glTF primitives that are not triangles) go to stderr.
    pub fn load(path: &Path) -> Result<Scene> {
        let (scene, warnings) = Scene::load_with_warnings(path)?;
        for warning in warnings {
            eprintln!("warning: {}: {warning}", path.display());
        }
        Ok(scene)
    }

    /// [`Scene::load`], returning the warnings instead of printing them.
    pub fn load_with_warnings(path: &Path) -> Result<(Scene, Vec<String>)> {
        Scene::load_instanced(path, None)
    }

    /// [`Scene::load_with_warnings`], keeping the glTF mesh nodes `instancing` picks as
    /// [`Scene::instances`] rather than objects (other formats load flat).
    pub fn load_instanced(
        path: &Path,
        instancing: Option<&Instancing>,
    ) -> Result<(Scene, Vec<String>)> {
        Scene::load_posed(path, instancing, &Pose::Rest)
    }

    /// [`Scene::load_instanced`] with a glTF file's skins and animations in `pose`; other
    /// formats have no poses and refuse any but the rest pose.
    pub fn load_posed(
        path: &Path,
        instancing: Option<&Instancing>,
        pose: &Pose,
    ) -> Result<(Scene, Vec<String>)> {
        let extension = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        match extension.as_str() {
            "gltf" | "glb" => {
                let loaded = gltf::load(path, instancing, pose)?;
                instances::check(&loaded.instances)
                    .map_err(|m| Error::scene(Location::file(path), m))?;
                let mut scene = Scene::from_meshes(path, loaded.meshes, loaded.textures)?;
                scene.instances = loaded.instances;
                scene.up = Up::Y;
                scene.content_digest = Some(loaded.digest);
                scene.hierarchy = Some(loaded.hierarchy);
                scene.tangents = scene.normal_map_tangents(&loaded.tangents);
                if loaded.skinned {
                    scene.pose_linear = Some(loaded.pose_linear.concat());
                    scene.gltf_primitives = Some(loaded.primitives);
                }
                if loaded.lightmap_uvs.iter().any(Option::is_some) {
                    let mut uvs = Vec::with_capacity(scene.vertex_count());
                    for (object, lightmap) in scene.objects.iter().zip(&loaded.lightmap_uvs) {
                        let count = object.vertices.len();
                        match lightmap {
                            Some(given) if given.len() == count => uvs.extend(given),
                            _ => uvs.extend(std::iter::repeat_n(Vec2::ZERO, count)),
                        }
                    }
                    scene.lightmap_uvs = Some(uvs);
                }
                scene
                    .add_back_sheets()
                    .map_err(|m| Error::scene(Location::file(path), m))?;
                Ok((scene, loaded.warnings))
            }
            other if OTHER_FORMATS.contains(&other) => Err(Error::scene(
                Location::file(path),
                format!("unknown scene format .{other}: the formats read are {FORMATS}"),
            )),
            _ if !pose.is_rest() => Err(Error::scene(
                Location::file(path),
                format!("--pose {pose}: only glTF files have skins and animations"),
            )),
            _ => Scene::load_obj_or_scene_file(path).map(|scene| (scene, Vec::new())),
        }
    }

    fn load_obj_or_scene_file(path: &Path) -> Result<Scene> {
        let is_obj = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
        if is_obj {
            let loaded = obj::load(path, None, &AssetFolder::of(path))?;
            let mut scene = Scene::from_meshes(path, loaded.meshes, loaded.textures)?;
            scene.sources = loaded.files;
            return Ok(scene);
        }
        let entries = parse_scene_file(path)?;
        // Everything the scene names, the OBJs' material libraries and textures too, must lie
        // in the scene file's folder.
        let folder = AssetFolder::of(path);
        let mut meshes = Vec::new();
        let mut textures: Vec<Texture> = Vec::new();
        let mut sources = Vec::new();
        for entry in &entries {
            let override_texture = match &entry.texture {
                Some(texture_path) => {
                    let at = Location::line(path, entry.line);
                    Some(Texture::load(texture_path, &at)?)
                }
                None => None,
            };
            // An object that cannot be read is reported at the scene-file line that names it, as a
            // missing texture or material library is.
            let loaded =
                obj::load(&entry.obj, override_texture, &folder).map_err(|err| match err {
                    Error::Io { path: obj, source } if obj == entry.obj => Error::scene(
                        Location::line(path, entry.line),
                        format!("cannot read object {}: {source}", obj.display()),
                    ),
                    other => other,
                })?;
            let offset = textures.len();
            sources.extend(loaded.files);
            textures.extend(loaded.textures);
            meshes.extend(loaded.meshes.into_iter().map(|mut mesh| {
                mesh.material.texture = mesh.material.texture.map(|t| t + offset);
                mesh
            }));
        }
        let mut scene = Scene::from_meshes(path, meshes, textures)?;
        scene.sources = sources;
        Ok(scene)
    }

    /// Per vertex, its tangent (xyz unit, w = ±1) where its object's material has a normal
    /// map, zero elsewhere; `None` where no material has one. `given` holds, per object, the
    /// tangents its file gave (glTF TANGENT, in world space), used where their count fits;
    /// MikkTSpace's otherwise, as the glTF specification asks of a client.
    fn normal_map_tangents(&self, given: &[Option<Vec<Vec4>>]) -> Option<Vec<Vec4>> {
        if self.materials.iter().all(|m| m.normal_map.is_none()) {
            return None;
        }
        let mut out = vec![Vec4::ZERO; self.positions.len()];
        for (k, object) in self.objects.iter().enumerate() {
            let vertices = object.vertices.start as usize..object.vertices.end as usize;
            let material = self.vertex_material.get(vertices.start).copied();
            if material.is_none_or(|m| self.materials[m as usize].normal_map.is_none()) {
                continue;
            }
            let tangents = match given.get(k).and_then(Option::as_ref) {
                Some(file) if file.len() == vertices.len() => file.clone(),
                _ => tangents::mikktspace_tangents(
                    &self.positions,
                    &self.normals,
                    &self.uvs,
                    &self.triangles[object.triangles.start as usize..object.triangles.end as usize],
                    vertices.clone(),
                ),
            };
            out[vertices].copy_from_slice(&tangents);
        }
        Some(out)
    }

    /// Every file the scene was read from: the scene file, OBJs, material libraries,
    /// textures. An output must not replace any of them ([`crate::support::output::Output`]).
    pub fn input_files(&self) -> Vec<PathBuf> {
        let mut files = vec![self.path.clone()];
        files.extend(self.sources.iter().cloned());
        files.extend(self.textures.iter().map(|t| t.path.clone()));
        files.dedup();
        files
    }

    /// A scene with no objects, read from `path`, +z up: what loaders and sub-scenes fill.
    pub fn empty(path: &Path) -> Scene {
        Scene {
            path: path.to_path_buf(),
            objects: Vec::new(),
            hierarchy: None,
            positions: Vec::new(),
            normals: Vec::new(),
            uvs: Vec::new(),
            vertex_material: Vec::new(),
            triangles: Vec::new(),
            materials: Vec::new(),
            textures: Vec::new(),
            sources: Vec::new(),
            up: Up::Z,
            lightmap_uvs: None,
            tangents: None,
            content_digest: None,
            instances: Instances::default(),
            back_sheets: BackSheets::default(),
            pose_linear: None,
            gltf_primitives: None,
        }
    }

    /// Assembles and validates a scene from meshes; `path` names it in errors and reports.
    pub fn from_meshes(path: &Path, meshes: Vec<Mesh>, textures: Vec<Texture>) -> Result<Scene> {
        let at = || Location::file(path);
        let mut scene = Scene {
            textures,
            ..Scene::empty(path)
        };
        for mut mesh in meshes {
            check_mesh(&mesh, scene.textures.len()).map_err(|m| Error::scene(at(), m))?;
            let (normals, uvs) =
                shading_attributes(&mut mesh).map_err(|m| Error::scene(at(), m))?;
            scene.append(mesh, normals, uvs);
        }
        if scene.triangles.is_empty() {
            return Err(Error::scene(at(), "the scene has no triangles"));
        }
        if u32::try_from(scene.positions.len()).is_err() {
            return Err(Error::scene(at(), "more than 2^32 vertices"));
        }
        Ok(scene)
    }

    /// Appends a checked mesh as one object, its vertices and triangles after those already
    /// there (indices offset by the vertex count so far) and its material as a new one.
    fn append(&mut self, mesh: Mesh, normals: Vec<Vec3>, uvs: Vec<Vec2>) {
        let vertex_count = mesh.positions.len();
        let base = self.positions.len() as u32;
        let first_triangle = self.triangles.len() as u32;
        let material = self.materials.len() as u32;
        self.materials.push(mesh.material);
        self.positions.extend(&mesh.positions);
        self.normals.extend(normals);
        self.uvs.extend(uvs);
        self.vertex_material
            .extend(std::iter::repeat_n(material, vertex_count));
        self.triangles
            .extend(mesh.triangles.iter().map(|t| t.map(|i| i + base)));
        self.objects.push(Object {
            name: mesh.name,
            vertices: base..self.positions.len() as u32,
            triangles: first_triangle..self.triangles.len() as u32,
        });
    }

    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Axis-aligned bounds `(min, max)` of all vertices.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.positions
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            })
    }

    /// The material of triangle `t` (the material of its first vertex: meshes have one).
    pub fn triangle_material(&self, t: usize) -> &Material {
        &self.materials[self.vertex_material[self.triangles[t][0] as usize] as usize]
    }

    /// Linear diffuse albedo of a material at a texture coordinate.
    pub fn albedo(&self, material: &Material, uv: Vec2) -> Vec3 {
        match material.texture {
            Some(t) => material.kd * self.textures[t].sample(uv),
            None => material.kd,
        }
    }

    /// The cut-out triangles the tracers test alpha on, or `None` when every material is
    /// opaque.
    pub fn cutouts(&self) -> Option<Cutouts> {
        let alphas: Vec<Option<&Alpha>> = self.materials.iter().map(|m| m.alpha.as_ref()).collect();
        Cutouts::new(
            &alphas,
            &self.vertex_material,
            &self.triangles,
            &self.uvs,
            &self.textures,
        )
    }

    /// Linear diffuse albedo at every vertex (Kd × texture at the vertex's uv).
    pub fn vertex_albedo(&self) -> Vec<Vec3> {
        (0..self.vertex_count())
            .map(|v| {
                self.albedo(
                    &self.materials[self.vertex_material[v] as usize],
                    self.uvs[v],
                )
            })
            .collect()
    }

    /// A 64-bit fingerprint of the geometry in vertex order (xxh3 over the little-endian bytes
    /// of the counts, positions, normals, uvs and triangle indices, then, for glTF, the
    /// digest of the file's content). Coefficient files carry it so a file baked for another
    /// scene, or another version of this one, is refused.
    ///
    /// Hashed as it goes ([`Digest`](crate::support::digest::Digest)), not from a copy of the
    /// geometry: every process of a staged bake fingerprints the scene, and the copy was 20 MB
    /// of fresh memory at 720,000 triangles.
    pub fn fingerprint(&self) -> u64 {
        let mut digest = crate::support::digest::Digest::default();
        digest.bytes(&(self.positions.len() as u64).to_le_bytes());
        digest.bytes(&(self.triangles.len() as u64).to_le_bytes());
        for v in self.positions.iter().chain(&self.normals) {
            digest.floats(&v.to_array());
        }
        for uv in &self.uvs {
            digest.floats(&uv.to_array());
        }
        for t in self.triangles.iter().flatten() {
            digest.bytes(&t.to_le_bytes());
        }
        // Absent for OBJ and scene files, whose fingerprints stay what they were.
        if let Some(d) = self.content_digest {
            digest.bytes(&d.to_le_bytes());
        }
        // Absent for flat scenes, whose fingerprints stay what they were: a scene with
        // instances is another scene than its flat load.
        if !self.instances.is_empty() {
            digest.bytes(&(self.instances.placements.len() as u64).to_le_bytes());
        }
        digest.finish()
    }
}

/// Back sheets of glTF `doubleSided` objects ([`back_sheets`]).
impl Scene {
    /// Appends a back sheet for every open object whose material is `doubleSided` (none for
    /// OBJ and scene files, which have no such flag). A closed object gets none: its inside
    /// is never seen. The glTF loader calls it; a scene that already has them is left as it
    /// is. Refuses to pass 2^32 vertices.
    pub fn add_back_sheets(&mut self) -> std::result::Result<(), String> {
        if !self.back_sheets.fronts.is_empty() {
            return Ok(());
        }
        let fronts: Vec<u32> = (0..self.objects.len() as u32)
            .filter(|&o| {
                let object = &self.objects[o as usize];
                let first = object.vertices.start as usize;
                !object.triangles.is_empty()
                    && self
                        .vertex_material
                        .get(first)
                        .is_some_and(|&m| self.materials[m as usize].double_sided)
                    && !back_sheets::is_closed(
                        &self.positions,
                        &self.triangles
                            [object.triangles.start as usize..object.triangles.end as usize],
                    )
            })
            .collect();
        let added: usize = fronts
            .iter()
            .map(|&o| self.objects[o as usize].vertices.len())
            .sum();
        if u32::try_from(self.positions.len() + added).is_err() {
            return Err(format!(
                "more than 2^32 vertices with the back sheets of its doubleSided materials ({added} vertices); bake with --double-sided off"
            ));
        }
        for &front in &fronts {
            let object = self.objects[front as usize].clone();
            let vertices = object.vertices.start as usize..object.vertices.end as usize;
            let base = self.positions.len() as u32;
            let first_triangle = self.triangles.len() as u32;
            self.positions.extend_from_within(vertices.clone());
            self.normals.extend(
                self.normals[vertices.clone()]
                    .iter()
                    .map(|n| -*n)
                    .collect::<Vec<_>>(),
            );
            self.uvs.extend_from_within(vertices.clone());
            self.vertex_material.extend_from_within(vertices.clone());
            if let Some(uvs) = &mut self.lightmap_uvs {
                uvs.extend_from_within(vertices.clone());
            }
            if let Some(linear) = &mut self.pose_linear {
                linear.extend_from_within(vertices.clone());
            }
            // The whole tangent frame turned over, so a normal-mapped back shades with the
            // front's perturbed normal negated, as engines draw a back face.
            if let Some(tangents) = &mut self.tangents {
                let flipped: Vec<Vec4> = tangents[vertices.clone()]
                    .iter()
                    .map(|t| Vec4::new(-t.x, -t.y, -t.z, -t.w))
                    .collect();
                tangents.extend(flipped);
            }
            let shift = base - object.vertices.start;
            let triangles = object.triangles.start as usize..object.triangles.end as usize;
            let reversed: Vec<[u32; 3]> = self.triangles[triangles]
                .iter()
                .map(|&[a, b, c]| [a + shift, c + shift, b + shift])
                .collect();
            self.triangles.extend(reversed);
            if let Some(h) = &mut self.hierarchy
                && let Some(&node) = h.object_node.get(front as usize)
            {
                h.object_node.push(node);
            }
            self.objects.push(Object {
                name: format!("{} (back)", object.name),
                vertices: base..self.positions.len() as u32,
                triangles: first_triangle..self.triangles.len() as u32,
            });
        }
        self.back_sheets = BackSheets { fronts };
        Ok(())
    }

    /// Removes the back sheets (`bake --double-sided off`, or a reader of a file baked
    /// without them): the scene is then the one bakes before them saw, fingerprint and all.
    pub fn drop_back_sheets(&mut self) {
        let Some(first) = self.first_back_sheet() else {
            return;
        };
        let object = &self.objects[first];
        let (vertices, triangles) = (
            object.vertices.start as usize,
            object.triangles.start as usize,
        );
        self.positions.truncate(vertices);
        self.normals.truncate(vertices);
        self.uvs.truncate(vertices);
        self.vertex_material.truncate(vertices);
        if let Some(uvs) = &mut self.lightmap_uvs {
            uvs.truncate(vertices);
        }
        if let Some(tangents) = &mut self.tangents {
            tangents.truncate(vertices);
        }
        self.triangles.truncate(triangles);
        if let Some(h) = &mut self.hierarchy {
            h.object_node.truncate(first);
        }
        self.objects.truncate(first);
        self.back_sheets = BackSheets::default();
    }

    /// The index of the first back-sheet object, if there are any.
    pub fn first_back_sheet(&self) -> Option<usize> {
        let count = self.back_sheets.fronts.len();
        (count > 0).then(|| self.objects.len() - count)
    }

    /// The object whose back sheet object `o` is, or `None` for a front (or single) sheet.
    pub fn front_of(&self, o: usize) -> Option<usize> {
        let first = self.first_back_sheet()?;
        o.checked_sub(first)
            .map(|k| self.back_sheets.fronts[k] as usize)
    }

    /// The triangles the tracers occlude with: every triangle but the back sheets', which
    /// lie after them (their fronts stop rays from both sides).
    pub fn traced_triangles(&self) -> &[[u32; 3]] {
        match self.first_back_sheet() {
            Some(first) => &self.triangles[..self.objects[first].triangles.start as usize],
            None => &self.triangles,
        }
    }
}

/// Refuses a mesh whose positions are not finite or whose triangle or texture indices point
/// past what exists: everything after indexes with them unchecked.
fn check_mesh(mesh: &Mesh, texture_count: usize) -> std::result::Result<(), String> {
    let vertex_count = mesh.positions.len();
    if let Some((i, p)) = mesh
        .positions
        .iter()
        .enumerate()
        .find(|(_, p)| !p.is_finite())
    {
        return Err(format!(
            "mesh '{}': vertex {i} has a non-finite position {p}",
            mesh.name
        ));
    }
    if let Some((t, tri)) = mesh
        .triangles
        .iter()
        .enumerate()
        .find(|(_, tri)| tri.iter().any(|&i| i as usize >= vertex_count))
    {
        return Err(format!(
            "mesh '{}': triangle {t} uses vertex {tri:?} but the mesh has {vertex_count} vertices",
            mesh.name
        ));
    }
    let alpha_texture = mesh.material.alpha.as_ref().and_then(|a| a.texture);
    if mesh.material.texture.is_some_and(|t| t >= texture_count)
        || alpha_texture.is_some_and(|t| t >= texture_count)
    {
        return Err(format!("mesh '{}': texture index out of range", mesh.name));
    }
    Ok(())
}

/// The mesh's normals and texture coordinates, one per vertex: given ones where there are
/// as many as vertices, else computed normals and zero coordinates. Takes them out of the
/// mesh; refuses non-finite ones.
fn shading_attributes(mesh: &mut Mesh) -> std::result::Result<(Vec<Vec3>, Vec<Vec2>), String> {
    let vertex_count = mesh.positions.len();
    let computed = angle_weighted_normals(&mesh.positions, &mesh.triangles, true);
    let normals = match mesh.normals.take() {
        Some(given) if given.len() == vertex_count => {
            if given.iter().any(|n| !n.is_finite()) {
                return Err(format!("mesh '{}': non-finite normal", mesh.name));
            }
            // A zero normal (exporters write them for degenerate faces) takes the
            // computed one.
            given
                .iter()
                .zip(&computed)
                .map(|(n, c)| n.try_normalize().unwrap_or(*c))
                .collect()
        }
        _ => computed,
    };
    let uvs = match mesh.uvs.take() {
        Some(uvs) if uvs.len() == vertex_count => uvs,
        _ => vec![Vec2::ZERO; vertex_count],
    };
    if uvs.iter().any(|uv| !uv.is_finite()) {
        return Err(format!(
            "mesh '{}': non-finite texture coordinate",
            mesh.name
        ));
    }
    Ok((normals, uvs))
}
