//! glTF 2.0 scenes (`.gltf` with external or data-URI buffers, `.glb`) through the `gltf`
//! crate.
//!
//! The default scene's node hierarchy is flattened to world space: every node's matrix (or
//! TRS) times its parent's; normals go through the inverse transpose; a transform of negative
//! determinant (a mirror) flips the winding so faces keep facing out. Triangle lists, strips
//! and fans are read; points and lines are skipped with a warning. A primitive without
//! NORMAL gets angle-weighted normals, as an OBJ without `vn`. Albedo is baseColorFactor ×
//! baseColorTexture (sRGB, as the specification says); a primitive without a material takes
//! [`DEFAULT_KD`], as an OBJ object without one does. `normalTexture` (with its `scale` and
//! the mesh's TANGENT, or MikkTSpace tangents) is read for texel bakes ([`normal_map`]).
//!
//! glTF's texture v runs down from the image's top; the scene keeps OBJ's convention (v up
//! from the bottom), so v is stored as 1 − v.

mod accessors;
mod alpha;
mod files;
mod flattened_size;
mod gpu_instancing;
mod instancing;
mod names;
mod normal_map;
pub mod pose;
mod skin;
pub mod volume;

use accessors::readable_accessors;
use files::{images_are_readable, read_buffers, read_images, to_texture, uris_are_readable};
use flattened_size::check_flattened_size;
use names::object_name;
use std::collections::HashMap;
use std::path::Path;

use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use gltf::mesh::Mode;

pub use instancing::{AUTO_MIN_TRIANGLES, INSTANCE_BYTES, Instancing};
pub use pose::Pose;

use crate::math::glossy;
use crate::scene::instances::Instances;
use crate::scene::mesh::{DEFAULT_KD, Glossy, Hierarchy, HierarchyNode, Material, Mesh};
use crate::scene::texture::Texture;
use crate::support::error::{Error, Location, Result};
use crate::support::input_path::AssetFolder;

/// What a glTF file contributes.
#[derive(Default)]
pub struct Loaded {
    pub meshes: Vec<Mesh>,
    pub textures: Vec<Texture>,
    /// TEXCOORD_1 of each mesh (v flipped like TEXCOORD_0), where it has one.
    pub lightmap_uvs: Vec<Option<Vec<Vec2>>>,
    /// TANGENT of each normal-mapped mesh in world space, where it has one.
    pub tangents: Vec<Option<Vec<Vec4>>>,
    /// xxh3 of the JSON, every buffer and every decoded image: the file's whole content.
    pub digest: u64,
    /// Things skipped (points, lines), one sentence each.
    pub warnings: Vec<String>,
    /// The scene's node trees, and which node each mesh came from.
    pub hierarchy: Hierarchy,
    /// Mesh nodes kept as instances ([`Instancing`]); not among `meshes`.
    pub instances: Instances,
    /// Per mesh and vertex, the linear part of the matrix that placed it in the pose: the
    /// blend of its joints' for a skinned mesh ([`skin`]), the node's world matrix's
    /// otherwise. Lobe axes and normals turn by it.
    pub pose_linear: Vec<Vec<Mat3>>,
    /// Whether a mesh node has a skin.
    pub skinned: bool,
    /// Per mesh, the glTF mesh and primitive it was read from.
    pub primitives: Vec<[u32; 2]>,
}

/// Extensions a file may *require* and still be read correctly. None yet: a required
/// extension changes how data is to be read (Draco, meshopt, quantisation, texture
/// transforms), and reading on without it would bake the wrong scene.
const SUPPORTED_REQUIRED_EXTENSIONS: &[&str] = &[];

/// Loads the file in `pose`, flattening every mesh node but those `instancing` picks (never
/// a skinned one).
pub fn load(path: &Path, instancing: Option<&Instancing>, pose: &Pose) -> Result<Loaded> {
    let fail = |message: String| Error::scene(Location::file(path), message);
    let bytes = crate::support::limits::read_file(path)?;
    let (document, blob, json_bytes) = parse(path, &bytes)?;
    let folder = AssetFolder::of(path);
    uris_are_readable(document.as_json()).map_err(fail)?;
    let buffers = read_buffers(path, &folder, &document, blob)?;

    let mut digest = xxhash_rust::xxh3::Xxh3::new();
    digest.update(&json_bytes);
    for buffer in &buffers {
        digest.update(&(buffer.len() as u64).to_le_bytes());
        digest.update(buffer);
    }

    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| fail("the file has no scene".into()))?;
    let locals = skin::node_locals(&document, &buffers, pose).map_err(fail)?;
    let (placed, visited, parent, worlds) = flatten(&document, &scene, &locals).map_err(fail)?;
    let placed = gpu_instancing::expand(&document, &json_bytes, &buffers, placed).map_err(fail)?;
    // Nodes in visiting order (parents first), by their index in the file.
    let mut at = vec![u32::MAX; document.nodes().len()];
    let mut hierarchy = Hierarchy::default();
    for &n in &visited {
        let node = document.nodes().nth(n).expect("a visited node exists");
        at[n] = hierarchy.nodes.len() as u32;
        hierarchy.nodes.push(HierarchyNode {
            name: node
                .name()
                .map_or_else(|| format!("node {n}"), str::to_owned),
            parent: parent[n].map(|p| at[p]),
            receive: prt_receive(node.extras()),
        });
    }

    let mut reader = PrimitiveReader {
        path,
        folder: &folder,
        document: &document,
        buffers: &buffers,
        digest,
        textures: Vec::new(),
        texture_of_image: HashMap::new(),
        decoded: None,
    };
    let mut loaded = Loaded {
        hierarchy,
        ..Loaded::default()
    };
    let mut instanced = instancing::choose(&placed, &loaded.hierarchy, &at, instancing);
    for ((node, _, _), instance) in placed.iter().zip(&mut instanced) {
        *instance &= node.skin().is_none();
    }
    check_flattened_size(path, &placed, &instanced)?;
    let mut seen = HashMap::new();
    for ((node, mesh, world), instance) in placed.into_iter().zip(instanced) {
        if instance {
            let mut read = |primitive: &gltf::Primitive, name: String| {
                let mut scratch = Loaded::default();
                reader.read(primitive, name, Mat4::IDENTITY, None, &mut scratch)?;
                Ok(scratch.meshes.pop())
            };
            let instances = &mut loaded.instances;
            instancing::place(&node, &mesh, world, &mut read, &mut seen, instances)?;
            continue;
        }
        let primitive_count = mesh.primitives().len();
        let joints = match node.skin() {
            None => None,
            Some(s) => Some(skin::joint_matrices(&document, &buffers, &s, &worlds).map_err(fail)?),
        };
        loaded.skinned |= joints.is_some();
        for primitive in mesh.primitives() {
            let name = object_name(&node, &mesh, primitive.index(), primitive_count);
            let before = loaded.meshes.len();
            reader.read(&primitive, name, world, joints.as_deref(), &mut loaded)?;
            for _ in before..loaded.meshes.len() {
                loaded.hierarchy.object_node.push(at[node.index()]);
                let source = [mesh.index() as u32, primitive.index() as u32];
                loaded.primitives.push(source);
            }
        }
    }
    if loaded.meshes.is_empty() {
        return Err(fail(
            "no triangles: the default scene has no triangle primitives".into(),
        ));
    }
    loaded.textures = reader.textures;
    loaded.digest = reader.digest.digest();
    Ok(loaded)
}

/// Parses the file and refuses required extensions this reader does not know, before any
/// buffer is read. Returns the document, the GLB binary chunk if any, and the JSON's bytes
/// (which the digest starts with).
fn parse(path: &Path, bytes: &[u8]) -> Result<(gltf::Document, Option<Vec<u8>>, Vec<u8>)> {
    let fail = |message: String| Error::scene(Location::file(path), message);
    let gltf = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|err| fail(format!("not a readable glTF file: {err}")))?;
    let unsupported: Vec<&str> = gltf
        .extensions_required()
        .filter(|e| !SUPPORTED_REQUIRED_EXTENSIONS.contains(e))
        .collect();
    if !unsupported.is_empty() {
        return Err(fail(format!(
            "requires glTF extension{} {} which this reader does not support (re-export without {})",
            if unsupported.len() > 1 { "s" } else { "" },
            unsupported.join(", "),
            if unsupported.len() > 1 { "them" } else { "it" }
        )));
    }
    let gltf::Gltf { document, blob } = gltf;
    let json = document.into_json();
    positions_exist(&json).map_err(fail)?;
    let document =
        gltf::Document::from_json(json).map_err(|err| fail(format!("invalid glTF: {err}")))?;
    let json_bytes = match blob {
        Some(_) => gltf::Glb::from_slice(bytes)
            .map(|glb| glb.json.into_owned())
            .unwrap_or_default(),
        None => bytes.to_vec(),
    };
    Ok((document, blob, json_bytes))
}

/// A node's `extras.prt.receive` (`{"prt": {"receive": false}}`), where it is a boolean;
/// extras are the application's own, so anything else there is ignored.
fn prt_receive(extras: &gltf::json::Extras) -> Option<bool> {
    let value: serde_json::Value = serde_json::from_str(extras.as_ref()?.get()).ok()?;
    value.get("prt")?.get("receive")?.as_bool()
}

/// Turns primitives into meshes, carrying what is shared between them: the digest, and the
/// base-colour textures, decoded lazily (images are decoded only when a material uses one)
/// and once per image.
struct PrimitiveReader<'a> {
    path: &'a Path,
    folder: &'a AssetFolder,
    document: &'a gltf::Document,
    buffers: &'a [gltf::buffer::Data],
    digest: xxhash_rust::xxh3::Xxh3,
    textures: Vec<Texture>,
    texture_of_image: HashMap<usize, usize>,
    decoded: Option<Vec<gltf::image::Data>>,
}

impl PrimitiveReader<'_> {
    fn fail(&self, message: String) -> Error {
        Error::scene(Location::file(self.path), message)
    }

    /// Reads one primitive placed by `world`, or skinned by `joints` (each joint's J · IBM,
    /// `world` then ignored), into `loaded`; a primitive of points or lines adds a warning
    /// instead.
    fn read(
        &mut self,
        primitive: &gltf::Primitive,
        name: String,
        world: Mat4,
        joints: Option<&[Mat4]>,
        loaded: &mut Loaded,
    ) -> Result<()> {
        let mode = primitive.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            loaded.warnings.push(format!(
                "mesh '{name}': skipped a primitive of {mode:?} (only triangles are baked)"
            ));
            return Ok(());
        }
        let pbr = primitive.material().pbr_metallic_roughness();
        let base_colour = pbr.base_color_texture();
        let normal_texture = primitive.material().normal_texture();
        let uv_set = normal_map::uv_set(base_colour.as_ref(), normal_texture.as_ref())
            .map_err(|problem| self.fail(format!("mesh '{name}': {problem}")))?;
        readable_accessors(self.document, primitive, uv_set, normal_texture.is_some())
            .map_err(|problem| self.fail(format!("mesh '{name}': {problem}")))?;
        let buffers = self.buffers;
        let reader = primitive.reader(|b| Some(&buffers[b.index()]));
        let Some(positions) = reader.read_positions() else {
            return Err(self.fail(format!("mesh '{name}': a primitive has no POSITION")));
        };
        let mut positions: Vec<Vec3> = positions.map(Vec3::from_array).collect();
        let mut normals: Option<Vec<Vec3>> = reader
            .read_normals()
            .map(|n| n.map(Vec3::from_array).collect());
        let (world, linear) = match joints {
            None => (world, vec![Mat3::from_mat4(world); positions.len()]),
            Some(joints) => {
                let matrices = skin::vertex_matrices(primitive, buffers, joints, positions.len())
                    .map_err(|problem| self.fail(format!("mesh '{name}': {problem}")))?;
                skin::skin(&matrices, &mut positions, normals.as_mut());
                let linear = matrices.iter().map(|m| Mat3::from_mat4(*m)).collect();
                (Mat4::IDENTITY, linear)
            }
        };
        let read_uvs = |set: u32| {
            reader.read_tex_coords(set).map(|uv| {
                uv.into_f32()
                    .map(|[u, v]| Vec2::new(u, 1.0 - v))
                    .collect::<Vec<Vec2>>()
            })
        };
        let indices: Vec<u32> = match reader.read_indices() {
            Some(indices) => indices.into_u32().collect(),
            None => (0..positions.len() as u32).collect(),
        };
        let triangles = assemble(mode, &indices);
        let (positions, normals, triangles) = to_world(world, positions, normals, triangles);

        let texture = match &base_colour {
            None => None,
            Some(info) => Some(self.texture(info.texture().source().index())?),
        };
        let material = match primitive.material().index() {
            None => Material {
                name: String::from("default"),
                kd: DEFAULT_KD,
                ..Material::default()
            },
            Some(index) => {
                let [r, g, b, _] = pbr.base_color_factor();
                let name = primitive
                    .material()
                    .name()
                    .map(str::to_string)
                    .unwrap_or_else(|| format!("material {index}"));
                let alpha = alpha::material_alpha(&primitive.material(), texture)
                    .map_err(|problem| self.fail(format!("material '{name}': {problem}")))?;
                let sampling = alpha::base_colour_sampling(&primitive.material())
                    .map_err(|problem| self.fail(format!("material '{name}': {problem}")))?;
                let normal_map = match &normal_texture {
                    None => None,
                    Some(info) => Some(normal_map::read(
                        info,
                        self.texture(info.texture().source().index())?,
                    )),
                };
                Material {
                    name,
                    kd: Vec3::new(r, g, b),
                    texture,
                    sampling,
                    glossy: gltf_glossy(&pbr),
                    alpha,
                    normal_map,
                    double_sided: primitive.material().double_sided(),
                }
            }
        };
        loaded.lightmap_uvs.push(read_uvs(1));
        let tangents = reader
            .read_tangents()
            .filter(|_| material.normal_map.is_some());
        let tangents = tangents.map(|t| normal_map::tangents_to_world(Mat3::from_mat4(world), t));
        loaded.tangents.push(tangents);
        loaded.pose_linear.push(linear);
        loaded.meshes.push(Mesh {
            name,
            positions,
            normals,
            uvs: read_uvs(uv_set),
            triangles,
            material,
        });
        Ok(())
    }

    /// The texture of `image`: decodes every image on first use (adding their pixels to the
    /// digest), and makes one texture per image however many materials share it.
    fn texture(&mut self, image: usize) -> Result<usize> {
        if let Some(&t) = self.texture_of_image.get(&image) {
            return Ok(t);
        }
        if self.decoded.is_none() {
            images_are_readable(self.document, self.buffers).map_err(|m| self.fail(m))?;
            let images = read_images(self.path, self.folder, self.document, self.buffers)?;
            for image in &images {
                self.digest.update(&image.pixels);
            }
            self.decoded = Some(images);
        }
        let data = &self.decoded.as_ref().expect("decoded above")[image];
        let texture = to_texture(self.path, image, data).ok_or_else(|| {
            self.fail(format!(
                "image {image}: {:?} pixels cannot be a base colour or normal texture (8-bit RGB or RGBA needed)",
                data.format
            ))
        })?;
        self.textures.push(texture);
        self.texture_of_image.insert(image, self.textures.len() - 1);
        Ok(self.textures.len() - 1)
    }
}

/// World space: positions by the matrix, normals by its inverse transpose; a mirror
/// reverses the winding so faces keep facing out.
#[allow(clippy::type_complexity)]
fn to_world(
    world: Mat4,
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    mut triangles: Vec<[u32; 3]>,
) -> (Vec<Vec3>, Option<Vec<Vec3>>, Vec<[u32; 3]>) {
    let linear = Mat3::from_mat4(world);
    let normal_matrix = linear.inverse().transpose();
    let positions: Vec<Vec3> = positions
        .iter()
        .map(|p| world.transform_point3(*p))
        .collect();
    let normals = normals.map(|normals| {
        normals
            .iter()
            .map(|n| (normal_matrix * *n).normalize_or_zero())
            .collect()
    });
    if linear.determinant() < 0.0 {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    (positions, normals, triangles)
}

/// Guards a panic of `gltf-json` 1.4: its validation of a primitive indexes the accessor list
/// with the POSITION index before checking it (found by `baker/tests/fuzz.rs`).
fn positions_exist(json: &gltf::json::Root) -> std::result::Result<(), String> {
    use gltf::json::validation::Checked;
    let position = Checked::Valid(gltf::Semantic::Positions);
    for (m, mesh) in json.meshes.iter().enumerate() {
        for primitive in &mesh.primitives {
            let index = primitive.attributes.get(&position).map(|i| i.value());
            if let Some(index) = index.filter(|&i| i >= json.accessors.len()) {
                return Err(format!(
                    "invalid glTF: mesh {m}: POSITION names accessor {index}, but there are {}",
                    json.accessors.len()
                ));
            }
        }
    }
    Ok(())
}

/// The deepest node hierarchy read: far beyond any real asset (tens of levels), and reached
/// only by a file made to be hostile; the walk is iterative, so this bounds its memory, not
/// the stack.
pub const MAX_NODE_DEPTH: usize = 100_000;

/// Every node of `scene` with a mesh, its mesh and its node-to-world matrix, walked without
/// recursion.
/// glTF requires the nodes to form disjoint trees (§3.5.3: no cycles, one parent at most, the
/// scene's nodes roots); a file that breaks this is refused, naming the node: a node that is
/// its own child or ancestor would loop forever (it overflowed the stack of a recursive
/// walk), and a node with two parents repeated below each would make shared subtrees grow
/// exponentially.
fn flatten<'a>(
    document: &'a gltf::Document,
    scene: &gltf::Scene<'a>,
    locals: &[Mat4],
) -> std::result::Result<Flattened<'a>, String> {
    let json = document.as_json();
    // Indices were validated by `Document::from_json`.
    let mut parent: Vec<Option<usize>> = vec![None; json.nodes.len()];
    for (p, node) in json.nodes.iter().enumerate() {
        for child in node.children.iter().flatten().map(|c| c.value()) {
            if child == p {
                return Err(format!("invalid glTF: node {p} is its own child (a cycle)"));
            }
            if let Some(first) = parent[child] {
                return Err(format!(
                    "invalid glTF: node {child} is a child of both node {first} and node {p} (a node has one parent at most)"
                ));
            }
            parent[child] = Some(p);
        }
    }
    let mut listed = vec![false; json.nodes.len()];
    let mut stack: Vec<(gltf::Node<'a>, Mat4, usize)> = Vec::new();
    for root in scene.nodes() {
        let r = root.index();
        if let Some(p) = parent[r] {
            return Err(match cycle_through(&parent, r) {
                Some(cycle) => {
                    format!("invalid glTF: node {r} is its own ancestor (a cycle: {cycle})")
                }
                None => format!(
                    "invalid glTF: scene {} lists node {r} as a root, but it is a child of node {p}",
                    scene.index()
                ),
            });
        }
        if std::mem::replace(&mut listed[r], true) {
            return Err(format!(
                "invalid glTF: scene {} lists node {r} twice",
                scene.index()
            ));
        }
        stack.push((root, Mat4::IDENTITY, 1));
    }
    // Popped last first: reversed, the meshes come out in the order a recursive walk visits
    // them (which orders the scene's vertices and textures).
    stack.reverse();
    // Every node below a root has exactly one parent and the roots have none, so the walk
    // meets each node once: no cycle is reachable.
    let mut out = Vec::new();
    let mut visited = Vec::new();
    let mut worlds = vec![None; json.nodes.len()];
    while let Some((node, parent_world, depth)) = stack.pop() {
        visited.push(node.index());
        if depth > MAX_NODE_DEPTH {
            return Err(format!(
                "node {} is nested {depth} levels deep, deeper than the {MAX_NODE_DEPTH} this reader follows",
                node.index()
            ));
        }
        let world = parent_world * locals[node.index()];
        worlds[node.index()] = Some(world);
        if let Some(mesh) = node.mesh() {
            out.push((node.clone(), mesh, world));
        }
        // Reversed, for the same order.
        let children: Vec<_> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, world, depth + 1));
        }
    }
    Ok((out, visited, parent, worlds))
}

/// What [`flatten`] returns: the mesh nodes with their world transforms, every node visited
/// (parents first), each node's parent and each node's world matrix where it is in the
/// scene (by index in the file).
type Flattened<'a> = (
    Vec<(gltf::Node<'a>, gltf::Mesh<'a>, Mat4)>,
    Vec<usize>,
    Vec<Option<usize>>,
    Vec<Option<Mat4>>,
);

/// The cycle `node` lies on, following parents (`0 → 1 → 0`), if it does.
fn cycle_through(parent: &[Option<usize>], node: usize) -> Option<String> {
    let mut path = vec![node];
    let mut at = node;
    // A cycle through `node` has at most as many nodes as the file.
    for _ in 0..parent.len() {
        at = parent[at]?;
        path.push(at);
        if at == node {
            path.reverse();
            let names: Vec<String> = path.iter().map(usize::to_string).collect();
            return Some(names.join(" → "));
        }
    }
    None
}

/// Triangles of a list, strip or fan (glTF 2.0 §3.7.2.1); degenerate ones (repeated indices,
/// as strips use to restart) are dropped.
fn assemble(mode: Mode, indices: &[u32]) -> Vec<[u32; 3]> {
    let triangles: Vec<[u32; 3]> = match mode {
        Mode::Triangles => indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
        Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
            .map(|i| {
                let [a, b, c] = [indices[i], indices[i + 1], indices[i + 2]];
                if i % 2 == 0 { [a, b, c] } else { [b, a, c] }
            })
            .collect(),
        Mode::TriangleFan => (1..indices.len().saturating_sub(1))
            .map(|i| [indices[i], indices[i + 1], indices[0]])
            .collect(),
        _ => Vec::new(),
    };
    triangles
        .into_iter()
        .filter(|[a, b, c]| a != b && b != c && a != c)
        .collect()
}

/// A glTF material is glossy when it sets a roughness below 1: the lobe's exponent follows
/// from the roughness ([`glossy::exponent_from_roughness`]), its reflectance is the
/// metallic-roughness model's F0 = mix(0.04, base colour, metallic), and the diffuse term is
/// scaled by 1 − metallic. Roughness and metallic textures are not read: the factors apply
/// to the whole material.
fn gltf_glossy(pbr: &gltf::material::PbrMetallicRoughness) -> Option<Glossy> {
    let roughness = pbr.roughness_factor();
    if roughness.is_nan() || roughness >= 1.0 {
        return None;
    }
    let metallic = pbr.metallic_factor().clamp(0.0, 1.0);
    let [r, g, b, _] = pbr.base_color_factor();
    let base = Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE);
    Some(Glossy {
        ks: Vec3::splat(0.04).lerp(base, metallic),
        exponent: glossy::exponent_from_roughness(roughness),
        diffuse_weight: 1.0 - metallic,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_become_triangles_of_one_orientation() {
        // A strip over a quad 0-1-2-3 (zig-zag) and a fan over the same quad.
        assert_eq!(
            assemble(Mode::TriangleStrip, &[0, 1, 2, 3]),
            [[0, 1, 2], [2, 1, 3]]
        );
        assert_eq!(
            assemble(Mode::TriangleFan, &[0, 1, 2, 3]),
            [[1, 2, 0], [2, 3, 0]]
        );
        assert_eq!(assemble(Mode::Triangles, &[0, 1, 2, 2, 2, 3]), [[0, 1, 2]]);
    }
}
