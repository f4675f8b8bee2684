//! `prt-bake export --gltf`: a bake and its scene as one binary glTF 2.0 file (`.glb`) that
//! engines and DCC tools load (`docs/gltf.md` is the layout's specification).
//!
//! One glTF mesh per scene object, one node each, all in world space. glTF is +y up, so a
//! z-up scene is turned by [`Up::from_z_up`] on the way out: positions, normals and the
//! transfer (its SH coefficients rotated as a light would be). Per vertex:
//! * POSITION, NORMAL, TEXCOORD_0 (v flipped back to glTF's top-down convention), and
//!   TEXCOORD_1 where the scene has second texture coordinates;
//! * the transfer as custom attributes `_PRT_0`, `_PRT_1`, … of VEC4 float: coefficients
//!   4k..4k+3 of a grey bake in `_PRT_k`; an RGB bake names them per channel, `_PRT_R0`…,
//!   `_PRT_G0`…, `_PRT_B0`…; the last VEC4 of an order whose n² is not a multiple of 4 is
//!   padded with zeros;
//! * with a rig, COLOR_0: the rig's light through the transfer, Σ_j T_j·L_j per channel,
//!   clamped to [0, 1]. glTF multiplies COLOR_0 by the base colour, which is the albedo, so
//!   the product is the relit radiance; the materials are then marked
//!   `KHR_materials_unlit` so viewers show it without adding their own lights.
//!
//! Materials are metallic 0, roughness 1, base colour = Kd (× the texture, embedded as PNG).
//!
//! A lightmap (texel) bake has no per-vertex transfer: its `.glb` carries TEXCOORD_1 = the
//! atlas (vertices split at chart seams) and, with a rig, the relit lightmap as a texture the
//! materials name in `extras.prt_lightmap` ([`split_at_lightmap_seams`], docs/gltf.md).

use std::path::Path;

use glam::{DMat3, Vec2, Vec3};
use serde_json::{Value, json};

use crate::formats::coefficient_file::CoefficientFile;
use crate::light::{LightCoefficients, Rig};
use crate::math::sh::{self, rotation::ShRotation};
use crate::scene::{Scene, Texture, Up};
use crate::support::error::{Error, Result};

/// What to put beside the geometry.
pub struct Contents<'a> {
    /// The bake (checked against the scene by the caller), or none for the bare scene.
    pub file: Option<&'a CoefficientFile>,
    /// The light for COLOR_0, in the scene's own frame, of the file's order.
    pub light: Option<&'a LightCoefficients>,
    /// The scene's up axis (a bake's header says it; a bare scene's format does).
    pub up: Up,
}

/// What [`export_glb`] wrote, for the CLI's summary line.
#[derive(Clone, Debug)]
pub struct Written {
    pub vertex_count: usize,
    pub triangle_count: usize,
    pub materials: usize,
    pub textures: usize,
    /// Names of the transfer attributes, in order.
    pub prt_attributes: Vec<String>,
    pub colour: bool,
    pub bytes: usize,
    /// Whether the scene was turned from z-up to glTF's y-up.
    pub turned_to_y_up: bool,
    /// A texel bake's lightmap size (W, H): TEXCOORD_1 holds its UVs.
    pub lightmap: Option<[u32; 2]>,
    /// Whether the relit lightmap is embedded (texel bakes with a rig).
    pub lightmap_texture: bool,
}

/// Names of the VEC4 transfer attributes of a bake of `order` with `channels` (1 or 3).
pub fn prt_attribute_names(order: usize, channels: usize) -> Vec<String> {
    let per_channel = sh::coeff_count(order).div_ceil(4);
    match channels {
        1 => (0..per_channel).map(|k| format!("_PRT_{k}")).collect(),
        _ => ["R", "G", "B"]
            .iter()
            .flat_map(|c| (0..per_channel).map(move |k| format!("_PRT_{c}{k}")))
            .collect(),
    }
}

/// Exports `coefficients` (baked from `scene`) as a `.glb`, with COLOR_0 lit by `rig` if
/// given. The file is written atomically.
pub fn export_glb(
    coefficients: &Path,
    scene: &Path,
    output: &Path,
    rig: Option<&Path>,
) -> Result<Written> {
    let rig = rig.map(Rig::load).transpose()?;
    let file = CoefficientFile::read(coefficients)?;
    let scene = Scene::load(scene)?;
    let mut inputs = scene.input_files();
    inputs.push(coefficients.to_path_buf());
    inputs.extend(rig.iter().flat_map(Rig::input_files));
    let output = crate::support::output::Output::new(output, &inputs)?;
    let up = file.header.up;
    let light = rig.map(|rig| rig.project(file.header.order as usize).in_scene_frame(up));
    if file.lightmap.is_some() {
        let (bytes, written) =
            lightmap_glb_bytes(&file, coefficients, &scene, light.as_ref(), output.path())?;
        output.write(&bytes)?;
        return Ok(written);
    }
    file.check_scene(coefficients, &scene)?;
    let contents = Contents {
        file: Some(&file),
        light: light.as_ref(),
        up,
    };
    let (bytes, written) = glb_bytes(&scene, &contents)?;
    output.write(&bytes)?;
    Ok(written)
}

/// A texel bake's `.glb`: the scene with TEXCOORD_1 = the atlas's UVs (vertices split where
/// the triangle corners sharing one disagree), no transfer attributes (the transfer is per
/// texel: `export --exr` writes it as images), and with `light` the relit lightmap embedded
/// as a PNG that every material names in `extras.prt_lightmap` (docs/gltf.md).
fn lightmap_glb_bytes(
    file: &CoefficientFile,
    coefficients: &Path,
    scene: &Scene,
    light: Option<&LightCoefficients>,
    output: &Path,
) -> Result<(Vec<u8>, Written)> {
    let block = file.check_lightmap_scene(coefficients, scene)?;
    let split = split_at_lightmap_seams(scene, &block.uv1);
    let image = match light {
        None => None,
        Some(light) => {
            let radiance = crate::export::relight::lightmap_radiance(file, light);
            let (w, h) = (block.width as usize, block.height as usize);
            let rows = crate::formats::openexr::image_rows(&radiance, w, h);
            Some(crate::export::relight::png_bytes(
                &rows,
                block.width,
                block.height,
                0.0,
                output,
            )?)
        }
    };
    let contents = Contents {
        file: None,
        light: None,
        up: file.header.up,
    };
    let lightmap = LightmapContents {
        width: block.width,
        height: block.height,
        file,
        png: image,
    };
    glb_bytes_with(&split, &contents, Some(&lightmap))
}

/// The scene with one vertex per distinct (vertex, lightmap UV) pair of its triangle corners
/// and `lightmap_uvs` set to those UVs; triangles keep their order, each object's new
/// vertices are contiguous and in order of first use. Vertices no triangle uses are dropped.
pub fn split_at_lightmap_seams(scene: &Scene, uv1: &[[Vec2; 3]]) -> Scene {
    let mut split = Scene {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: Vec::new(),
        vertex_material: Vec::new(),
        triangles: Vec::with_capacity(scene.triangles.len()),
        objects: Vec::with_capacity(scene.objects.len()),
        lightmap_uvs: None,
        ..scene.clone()
    };
    let mut lightmap = Vec::new();
    for object in &scene.objects {
        let first = split.positions.len() as u32;
        let mut index = std::collections::HashMap::new();
        let range = object.triangles.start as usize..object.triangles.end as usize;
        for (vertices, uvs) in scene.triangles[range.clone()].iter().zip(&uv1[range]) {
            let triangle = std::array::from_fn(|corner| {
                let v = vertices[corner];
                let uv = uvs[corner];
                *index
                    .entry((v, uv.x.to_bits(), uv.y.to_bits()))
                    .or_insert_with(|| {
                        let v = v as usize;
                        split.positions.push(scene.positions[v]);
                        split.normals.push(scene.normals[v]);
                        split.uvs.push(scene.uvs[v]);
                        split.vertex_material.push(scene.vertex_material[v]);
                        lightmap.push(uv);
                        split.positions.len() as u32 - 1
                    })
            });
            split.triangles.push(triangle);
        }
        split.objects.push(crate::scene::Object {
            name: object.name.clone(),
            vertices: first..split.positions.len() as u32,
            triangles: object.triangles.clone(),
        });
    }
    split.lightmap_uvs = Some(lightmap);
    split
}

/// A texel bake's part of a `.glb`: its size and header for `asset.extras.prt`, and the relit
/// lightmap to embed.
struct LightmapContents<'a> {
    width: u32,
    height: u32,
    file: &'a CoefficientFile,
    png: Option<Vec<u8>>,
}

/// A growing binary chunk and the JSON objects that index it.
struct Builder {
    bin: Vec<u8>,
    buffer_views: Vec<Value>,
    accessors: Vec<Value>,
}

const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

impl Builder {
    /// Appends bytes as a buffer view (4-byte aligned) and returns its index.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let mut view = json!({
            "buffer": 0,
            "byteOffset": self.bin.len(),
            "byteLength": bytes.len(),
        });
        if let Some(target) = target {
            view["target"] = json!(target);
        }
        self.bin.extend_from_slice(bytes);
        self.buffer_views.push(view);
        self.buffer_views.len() - 1
    }

    /// A float accessor of `kind` ("VEC2", "VEC3", "VEC4") over `floats`; `bounds` adds the
    /// min and max the specification requires for POSITION.
    fn floats(&mut self, floats: &[f32], components: usize, bounds: bool) -> usize {
        let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ARRAY_BUFFER));
        let kind = match components {
            2 => "VEC2",
            3 => "VEC3",
            _ => "VEC4",
        };
        let mut accessor = json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": floats.len() / components,
            "type": kind,
        });
        if bounds {
            let mut lo = vec![f32::INFINITY; components];
            let mut hi = vec![f32::NEG_INFINITY; components];
            for chunk in floats.chunks_exact(components) {
                for (i, x) in chunk.iter().enumerate() {
                    lo[i] = lo[i].min(*x);
                    hi[i] = hi[i].max(*x);
                }
            }
            accessor["min"] = json!(lo);
            accessor["max"] = json!(hi);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    fn indices(&mut self, indices: &[u32]) -> usize {
        let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": UNSIGNED_INT,
            "count": indices.len(),
            "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }
}

/// The `.glb` bytes of `scene` and what they hold.
pub fn glb_bytes(scene: &Scene, contents: &Contents<'_>) -> Result<(Vec<u8>, Written)> {
    glb_bytes_with(scene, contents, None)
}

fn glb_bytes_with(
    scene: &Scene,
    contents: &Contents<'_>,
    lightmap_contents: Option<&LightmapContents<'_>>,
) -> Result<(Vec<u8>, Written)> {
    // Scene coordinates → the rig's z-up frame → glTF's y-up frame.
    let turn: DMat3 = Up::Y.from_z_up() * contents.up.from_z_up().transpose();
    let turned = contents.up != Up::Y;
    let turn_f32 = turn.as_mat3();
    let vec3s = |values: &[Vec3]| -> Vec<f32> {
        values
            .iter()
            .flat_map(|v| (turn_f32 * *v).to_array())
            .collect()
    };
    let uvs =
        |values: &[Vec2]| -> Vec<f32> { values.iter().flat_map(|uv| [uv.x, 1.0 - uv.y]).collect() };
    let positions = vec3s(&scene.positions);
    let normals: Vec<f32> = scene
        .normals
        .iter()
        .flat_map(|n| (turn_f32 * *n).normalize().to_array())
        .collect();
    let texcoords = uvs(&scene.uvs);
    let lightmap = scene.lightmap_uvs.as_deref().map(uvs);

    // Transfer, turned like the geometry, as per-attribute VEC4 arrays over all vertices.
    let mut prt_names = Vec::new();
    let mut prt_arrays: Vec<Vec<f32>> = Vec::new();
    let mut colour: Option<Vec<f32>> = None;
    if let Some(file) = contents.file {
        let order = file.header.order as usize;
        let channels = file.header.channels as usize;
        let n = sh::coeff_count(order);
        let per_channel = n.div_ceil(4);
        let rotation = ShRotation::from_matrix(order, turn);
        prt_names = prt_attribute_names(order, channels);
        prt_arrays = vec![vec![0.0; scene.vertex_count() * 4]; prt_names.len()];
        for v in 0..scene.vertex_count() {
            for c in 0..channels {
                let original: Vec<f64> = file.vertex(v, c).iter().map(|&t| f64::from(t)).collect();
                let rotated = if turned {
                    rotation.rotate(&original)
                } else {
                    original
                };
                for (j, t) in rotated.iter().enumerate() {
                    prt_arrays[c * per_channel + j / 4][v * 4 + j % 4] = *t as f32;
                }
            }
        }
        if let Some(light) = contents.light {
            let ones = vec![Vec3::ONE; scene.vertex_count()];
            let shading = crate::export::relight::vertex_radiance(file, &ones, light);
            colour = Some(
                shading
                    .iter()
                    .flat_map(|rgb| rgb.map(|x| x.clamp(0.0, 1.0)))
                    .collect(),
            );
        }
    }

    let mut b = Builder {
        bin: Vec::new(),
        buffer_views: Vec::new(),
        accessors: Vec::new(),
    };

    // Textures as PNG, then materials (one per scene material).
    let mut images = Vec::new();
    for texture in &scene.textures {
        let png = png_bytes(texture)?;
        let view = b.view(&png, None);
        images.push(json!({"bufferView": view, "mimeType": "image/png"}));
    }
    let mut textures: Vec<Value> = (0..scene.textures.len())
        .map(|i| json!({"source": i, "sampler": 0}))
        .collect();
    // The relit lightmap: clamped to its edge, linear filtering without mipmaps (sampler 1).
    let lightmap_texture = match lightmap_contents.and_then(|l| l.png.as_deref()) {
        None => None,
        Some(png) => {
            let view = b.view(png, None);
            images
                .push(json!({"bufferView": view, "mimeType": "image/png", "name": "prt_lightmap"}));
            textures
                .push(json!({"source": images.len() - 1, "sampler": 1, "name": "prt_lightmap"}));
            Some(textures.len() - 1)
        }
    };
    let unlit = colour.is_some();
    let materials: Vec<Value> = scene
        .materials
        .iter()
        .map(|m| {
            // glTF's factor is at most 1 (a reflectance); an OBJ's Kd may exceed it.
            let kd = m.kd.clamp(Vec3::ZERO, Vec3::ONE);
            let mut pbr = json!({
                "baseColorFactor": [kd.x, kd.y, kd.z, 1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            });
            if let Some(t) = m.texture {
                pbr["baseColorTexture"] = json!({"index": t});
            }
            let mut material = json!({"name": m.name, "pbrMetallicRoughness": pbr});
            if unlit {
                material["extensions"] = json!({"KHR_materials_unlit": {}});
            }
            if let Some(t) = lightmap_texture {
                material["extras"] = json!({"prt_lightmap": {"index": t, "texCoord": 1}});
            }
            material
        })
        .collect();

    let mut meshes = Vec::new();
    for object in &scene.objects {
        let (v0, v1) = (object.vertices.start as usize, object.vertices.end as usize);
        let mut attributes = serde_json::Map::new();
        attributes.insert(
            "POSITION".into(),
            json!(b.floats(&positions[3 * v0..3 * v1], 3, true)),
        );
        attributes.insert(
            "NORMAL".into(),
            json!(b.floats(&normals[3 * v0..3 * v1], 3, false)),
        );
        attributes.insert(
            "TEXCOORD_0".into(),
            json!(b.floats(&texcoords[2 * v0..2 * v1], 2, false)),
        );
        if let Some(lightmap) = &lightmap {
            attributes.insert(
                "TEXCOORD_1".into(),
                json!(b.floats(&lightmap[2 * v0..2 * v1], 2, false)),
            );
        }
        if let Some(colour) = &colour {
            attributes.insert(
                "COLOR_0".into(),
                json!(b.floats(&colour[3 * v0..3 * v1], 3, false)),
            );
        }
        for (name, array) in prt_names.iter().zip(&prt_arrays) {
            attributes.insert(
                name.clone(),
                json!(b.floats(&array[4 * v0..4 * v1], 4, false)),
            );
        }
        let local: Vec<u32> = scene.triangles
            [object.triangles.start as usize..object.triangles.end as usize]
            .iter()
            .flatten()
            .map(|i| i - object.vertices.start)
            .collect();
        let indices = b.indices(&local);
        let material = scene.vertex_material[v0];
        meshes.push(json!({
            "name": object.name,
            "primitives": [{
                "attributes": attributes,
                "indices": indices,
                "material": material,
                "mode": 4,
            }],
        }));
    }

    let nodes: Vec<Value> = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| json!({"name": o.name, "mesh": i}))
        .collect();
    while b.bin.len() % 4 != 0 {
        b.bin.push(0);
    }
    let mut root = json!({
        "asset": {"version": "2.0", "generator": concat!("prt-bake ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "accessors": b.accessors,
        "bufferViews": b.buffer_views,
        "buffers": [{"byteLength": b.bin.len()}],
    });
    if !images.is_empty() {
        root["images"] = json!(images);
        root["textures"] = json!(textures);
        // Repeat wrapping, as the baker samples textures; linear filtering with mipmaps.
        root["samplers"] =
            json!([{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}]);
        if lightmap_texture.is_some() {
            root["samplers"].as_array_mut().expect("an array").push(
                json!({"magFilter": 9729, "minFilter": 9729, "wrapS": 33071, "wrapT": 33071}),
            );
        }
    }
    if unlit {
        root["extensionsUsed"] = json!(["KHR_materials_unlit"]);
    }
    if let Some(file) = contents.file {
        let h = &file.header;
        root["asset"]["extras"] = json!({
            "prt": {
                "order": h.order,
                "channels": h.channels,
                "attributes": prt_names,
                "coefficients_per_channel": sh::coeff_count(h.order as usize),
                "convention": "real orthonormal SH, index l(l+1)+m, Condon-Shortley phase, of \
                    directions in this file's coordinates (theta from +z, phi from +x towards +y); \
                    transfer excludes the albedo (the base colour)",
                "mode": h.mode.name(),
                "colour_0": if colour.is_some() { "transfer . light per channel, clamped to [0, 1]; times the base colour it is the relit radiance" } else { "absent" },
            }
        });
    }

    if let Some(l) = lightmap_contents {
        let h = &l.file.header;
        root["asset"]["extras"] = json!({
            "prt": {
                "order": h.order,
                "channels": h.channels,
                "mode": h.mode.name(),
                "lightmap": {
                    "width": l.width,
                    "height": l.height,
                    "texCoord": 1,
                    "uv_convention": "glTF's: v down from the image's top; row 0 of the \
                        lightmap images prt-bake writes (export --exr, relight) is v = 0",
                    "transfer": "per texel, not in this file: prt-bake export --exr writes it \
                        as images (manifest.json)",
                    "texture": lightmap_texture,
                    "texture_holds": if lightmap_texture.is_some() { "transfer . light per channel (albedo 1), clamped to [0, 1], sRGB-encoded; times the base colour it is the relit radiance" } else { "absent" },
                },
            }
        });
    }
    let mut json_bytes = serde_json::to_vec(&root).expect("plain JSON serialises");
    while json_bytes.len() % 4 != 0 {
        json_bytes.push(b' ');
    }
    let total = 12 + 8 + json_bytes.len() + 8 + b.bin.len();
    let total_u32 = u32::try_from(total).map_err(|_| {
        Error::InvalidOption(format!(
            "the glTF would be {total} bytes, over the 4 GiB a .glb can hold"
        ))
    })?;
    let mut bytes = Vec::with_capacity(total);
    bytes.extend(b"glTF");
    bytes.extend(2u32.to_le_bytes());
    bytes.extend(total_u32.to_le_bytes());
    bytes.extend((json_bytes.len() as u32).to_le_bytes());
    bytes.extend(b"JSON");
    bytes.extend(&json_bytes);
    bytes.extend((b.bin.len() as u32).to_le_bytes());
    bytes.extend(b"BIN\0");
    bytes.extend(&b.bin);

    let written = Written {
        vertex_count: scene.vertex_count(),
        triangle_count: scene.triangles.len(),
        materials: scene.materials.len(),
        textures: scene.textures.len(),
        prt_attributes: prt_names,
        colour: colour.is_some(),
        bytes: bytes.len(),
        turned_to_y_up: turned,
        lightmap: lightmap_contents.map(|l| [l.width, l.height]),
        lightmap_texture: lightmap_texture.is_some(),
    };
    Ok((bytes, written))
}

/// A texture's sRGB pixels as PNG.
fn png_bytes(texture: &Texture) -> Result<Vec<u8>> {
    let mut png = Vec::new();
    let pixels: Vec<u8> = texture.srgb8.iter().flatten().copied().collect();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut png),
        &pixels,
        texture.width,
        texture.height,
        image::ExtendedColorType::Rgba8,
    )
    .map_err(|err| {
        Error::io(
            &texture.path,
            std::io::Error::other(format!("cannot encode as PNG: {err}")),
        )
    })?;
    Ok(png)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attribute_names_per_order_and_channel() {
        assert_eq!(prt_attribute_names(1, 1), ["_PRT_0"]);
        assert_eq!(prt_attribute_names(3, 1), ["_PRT_0", "_PRT_1", "_PRT_2"]);
        assert_eq!(prt_attribute_names(4, 1).len(), 4);
        assert_eq!(prt_attribute_names(2, 3), ["_PRT_R0", "_PRT_G0", "_PRT_B0"]);
        assert_eq!(prt_attribute_names(5, 3).len(), 21);
    }
}
