//! `prt-bake export --gltf`: a bake and its scene as one binary glTF 2.0 file (`.glb`) that
//! engines and DCC tools load (`docs/reference/gltf.md` is the layout's specification).
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
//! Materials keep the source's (base colour factor and texture with its sampler and texture
//! transform, alpha mode and cutoff, doubleSided, normal texture with TANGENT), metallic 0,
//! roughness 1 (material.rs).
//!
//! A lightmap (texel) bake has no per-vertex transfer: its `.glb` carries TEXCOORD_1 = the
//! atlas (vertices split at chart seams) and, with a rig, the relit lightmap as a texture the
//! materials name in `extras.prt_lightmap` ([`split_at_lightmap_seams`], docs/reference/gltf.md).

mod builder;
mod cpca;
mod glossy;
mod light;
mod material;
mod objects;
mod seams;

use std::path::Path;

use glam::{DMat3, Vec2, Vec3};
use serde_json::{Value, json};

use crate::formats::coefficient_file::CoefficientFile;
use crate::formats::header::TransferKind;
use crate::light::{LightCoefficients, Rig};
use crate::math::cpca::Cpca;
use crate::math::sh::{self, rotation::ShRotation};
use crate::scene::{Scene, Up};
use crate::support::error::Result;

pub use builder::Quantize;
use builder::*;
use cpca::{CLUSTER_ATTRIBUTE, CompressedTransfer, compressed_transfer, read_maybe_compressed};
use light::{light_in_gltf_frame, light_json};
use material::{Materials, materials};
use seams::ao_png_bytes;
pub use seams::split_at_lightmap_seams;

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
    /// Whether the bake's AO is in the file (`_AO` per vertex, or an occlusionTexture).
    pub ao: bool,
    /// A compressed bake's (clusters, components): the transfer is `_PRT_CLUSTER` and the
    /// `_PRT_Wk` weights of `prt_attributes` (docs/reference/gltf.md).
    pub cpca: Option<(usize, usize)>,
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
    export_glb_quantized(coefficients, scene, output, rig, None)
}

/// [`export_glb`] with the transfer attributes quantized (vertex bakes; a texel bake's file
/// has none, and `quantize` changes nothing there).
pub fn export_glb_quantized(
    coefficients: &Path,
    scene: &Path,
    output: &Path,
    rig: Option<&Path>,
    quantize: Option<Quantize>,
) -> Result<Written> {
    let rig = rig.map(Rig::load).transpose()?;
    let (file, cpca) = read_maybe_compressed(coefficients)?;
    if cpca.is_some() && quantize.is_some() && file.lightmap.is_none() {
        return Err(crate::support::error::Error::InvalidOption(format!(
            "--quantize: {} is CPCA-compressed, and its export carries cluster weights, \
             not transfer to quantize (export the uncompressed bake to quantize it)",
            coefficients.display()
        )));
    }
    let scene = file.load_scene(scene)?;
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
    if file.header.transfer == TransferKind::Matrix {
        glossy::check_compressed(&file, coefficients, cpca.as_ref())?;
    }
    file.check_scene_of_any_transfer(coefficients, &scene)?;
    // A bake of some objects: the others carry the unshadowed lobe.
    let file = file.spread_to_scene(coefficients, &scene)?;
    let contents = Contents {
        file: Some(&file),
        light: light.as_ref(),
        up,
    };
    let (bytes, written) = glb_bytes_with(&scene, &contents, None, quantize, cpca.as_ref())?;
    output.write(&bytes)?;
    Ok(written)
}

/// A texel bake's `.glb`: the scene with TEXCOORD_1 = the atlas's UVs (vertices split where
/// the triangle corners sharing one disagree), no transfer attributes (the transfer is per
/// texel: `export --exr` writes it as images), and with `light` the relit lightmap embedded
/// as a PNG that every material names in `extras.prt_lightmap` (docs/reference/gltf.md).
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
    let light = light.map(|l| light_in_gltf_frame(l, file.header.up));
    let ao_png = match &file.ao {
        None => None,
        Some(ao) => Some(ao_png_bytes(ao, block.width, block.height, output)?),
    };
    let lightmap = LightmapContents {
        width: block.width,
        height: block.height,
        file,
        png: image,
        ao_png,
        light,
    };
    glb_bytes_with(&split, &contents, Some(&lightmap), None, None)
}

/// A texel bake's part of a `.glb`: its size and header for `asset.extras.prt`, and the relit
/// lightmap to embed.
struct LightmapContents<'a> {
    width: u32,
    height: u32,
    file: &'a CoefficientFile,
    /// The relit lightmap (sRGB PNG), with a light.
    png: Option<Vec<u8>>,
    /// The AO (linear grey PNG), where the bake has it.
    ao_png: Option<Vec<u8>>,
    /// The rig's light in glTF's frame, for `asset.extras.prt.light`.
    light: Option<LightCoefficients>,
}

/// The `.glb` bytes of `scene` and what they hold.
pub fn glb_bytes(scene: &Scene, contents: &Contents<'_>) -> Result<(Vec<u8>, Written)> {
    glb_bytes_with(scene, contents, None, None, None)
}

/// The scene's per-vertex arrays in glTF's frame and conventions, flattened.
struct VertexArrays {
    /// Scene coordinates → glTF's y-up frame.
    turn: DMat3,
    turned: bool,
    positions: Vec<f32>,
    normals: Vec<f32>,
    texcoords: Vec<f32>,
    lightmap: Option<Vec<f32>>,
    /// TANGENT (xyz turned, w the bitangent's sign) where the scene has normal-mapped
    /// objects; zero at vertices of objects without a normal map.
    tangents: Option<Vec<f32>>,
}

/// Step 1: positions, normals and UVs turned to +y up, UVs with v flipped to glTF's.
fn vertex_arrays(scene: &Scene, up: Up) -> VertexArrays {
    // Scene coordinates → the rig's z-up frame → glTF's y-up frame.
    let turn: DMat3 = Up::Y.from_z_up() * up.from_z_up().transpose();
    let turn_f32 = turn.as_mat3();
    let uvs =
        |values: &[Vec2]| -> Vec<f32> { values.iter().flat_map(|uv| [uv.x, 1.0 - uv.y]).collect() };
    VertexArrays {
        turn,
        turned: up != Up::Y,
        positions: scene
            .positions
            .iter()
            .flat_map(|v| (turn_f32 * *v).to_array())
            .collect(),
        normals: scene
            .normals
            .iter()
            .flat_map(|n| (turn_f32 * *n).normalize().to_array())
            .collect(),
        texcoords: uvs(&scene.uvs),
        lightmap: scene.lightmap_uvs.as_deref().map(uvs),
        tangents: scene.tangents.as_ref().map(|tangents| {
            tangents
                .iter()
                .flat_map(|t| {
                    let xyz = (turn_f32 * t.truncate()).normalize_or_zero();
                    xyz.extend(if t.w < 0.0 { -1.0 } else { 1.0 }).to_array()
                })
                .collect()
        }),
    }
}

/// A vertex bake's own attributes: the transfer, COLOR_0 and `_AO`.
#[derive(Default)]
struct VertexTransfer {
    names: Vec<String>,
    /// Per attribute, VEC4s over all vertices.
    arrays: Vec<Vec<f32>>,
    colour: Option<Vec<f32>>,
    ao: Option<Vec<f32>>,
    /// A compressed bake: its cluster index per vertex and per-cluster arrays (`names` and
    /// `arrays` are then its weights).
    cpca: Option<CompressedTransfer>,
    /// With `export --quantize`: the bits and per attribute its scale (largest magnitude).
    quantized: Option<(Quantize, Vec<f32>)>,
}

/// Step 2: the transfer turned like the geometry (its SH coefficients rotated), as
/// per-attribute VEC4 arrays; COLOR_0 with a light; the AO where the file has it.
fn vertex_transfer(
    scene: &Scene,
    contents: &Contents<'_>,
    arrays: &VertexArrays,
    quantize: Option<Quantize>,
    cpca: Option<&Cpca>,
) -> VertexTransfer {
    let Some(file) = contents.file else {
        return VertexTransfer::default();
    };
    let order = file.header.order as usize;
    let channels = file.header.channels as usize;
    let per_channel = sh::coeff_count(order).div_ceil(4);
    let rotation = ShRotation::from_matrix(order, arrays.turn);
    let matrix = file.header.transfer == TransferKind::Matrix;
    let colour = contents.light.map(|light| {
        if matrix {
            return glossy::diffuse_colour(file, cpca, scene, light);
        }
        let ones = vec![Vec3::ONE; scene.vertex_count()];
        crate::export::relight::vertex_radiance(file, &ones, light)
            .iter()
            .flat_map(|rgb| rgb.map(|x| x.clamp(0.0, 1.0)))
            .collect()
    });
    if let Some(cpca) = cpca {
        let mut compressed = compressed_transfer(
            cpca,
            order,
            channels,
            arrays.turned.then_some(&rotation),
            matrix,
        );
        return VertexTransfer {
            names: compressed.names.clone(),
            arrays: std::mem::take(&mut compressed.weights),
            colour,
            ao: file.ao.clone(),
            cpca: Some(compressed),
            quantized: None,
        };
    }
    let names = prt_attribute_names(order, channels);
    let mut prt = vec![vec![0.0; scene.vertex_count() * 4]; names.len()];
    for v in 0..scene.vertex_count() {
        for c in 0..channels {
            let original: Vec<f64> = file.vertex(v, c).iter().map(|&t| f64::from(t)).collect();
            let rotated = if arrays.turned {
                rotation.rotate(&original)
            } else {
                original
            };
            for (j, t) in rotated.iter().enumerate() {
                prt[c * per_channel + j / 4][v * 4 + j % 4] = *t as f32;
            }
        }
    }
    let quantized = quantize.map(|q| {
        let scales = prt
            .iter()
            .map(|a| a.iter().fold(0.0f32, |m, x| m.max(x.abs())))
            .map(|m| if m > 0.0 { m } else { 1.0 })
            .collect();
        (q, scales)
    });
    VertexTransfer {
        names,
        arrays: prt,
        colour,
        ao: file.ao.clone(),
        cpca: None,
        quantized,
    }
}

/// Step 4: one mesh of one triangle-list primitive per scene object, its attributes sliced
/// from the arrays.
fn meshes(
    b: &mut Builder,
    scene: &Scene,
    arrays: &VertexArrays,
    transfer: &VertexTransfer,
) -> Vec<Value> {
    let mut meshes = Vec::new();
    for object in &scene.objects {
        let (v0, v1) = (object.vertices.start as usize, object.vertices.end as usize);
        let mut attributes = serde_json::Map::new();
        let slice = |values: &[f32], n: usize| values[n * v0..n * v1].to_vec();
        let mut add = |name: &str, accessor: usize| {
            attributes.insert(name.into(), json!(accessor));
        };
        add("POSITION", b.floats(&slice(&arrays.positions, 3), 3, true));
        add("NORMAL", b.floats(&slice(&arrays.normals, 3), 3, false));
        add(
            "TEXCOORD_0",
            b.floats(&slice(&arrays.texcoords, 2), 2, false),
        );
        if let Some(lightmap) = &arrays.lightmap {
            add("TEXCOORD_1", b.floats(&slice(lightmap, 2), 2, false));
        }
        // The normal texture's tangent frame, where every vertex has one (else engines
        // generate MikkTSpace tangents, as the glTF specification asks).
        let normal_mapped = scene.materials[scene.vertex_material[v0] as usize]
            .normal_map
            .is_some();
        if let Some(tangents) = arrays.tangents.as_ref().filter(|_| normal_mapped) {
            let values = slice(tangents, 4);
            if values
                .chunks_exact(4)
                .all(|t| t[0] != 0.0 || t[1] != 0.0 || t[2] != 0.0)
            {
                add("TANGENT", b.floats(&values, 4, false));
            }
        }
        if let Some(colour) = &transfer.colour {
            add("COLOR_0", b.floats(&slice(colour, 3), 3, false));
        }
        for (i, (name, array)) in transfer.names.iter().zip(&transfer.arrays).enumerate() {
            let values = slice(array, 4);
            add(
                name,
                match &transfer.quantized {
                    None => b.floats(&values, 4, false),
                    Some((q, scales)) => b.quantized(&values, scales[i], *q),
                },
            );
        }
        if let Some(cpca) = &transfer.cpca {
            add(
                CLUSTER_ATTRIBUTE,
                b.floats(&slice(&cpca.cluster, 1), 1, false),
            );
        }
        if let Some(ao) = &transfer.ao {
            add("_AO", b.floats(&slice(ao, 1), 1, false));
        }
        let local: Vec<u32> = scene.triangles
            [object.triangles.start as usize..object.triangles.end as usize]
            .iter()
            .flatten()
            .map(|i| i - object.vertices.start)
            .collect();
        let indices = b.indices(&local);
        meshes.push(json!({
            "name": object.name,
            "primitives": [{
                "attributes": attributes,
                "indices": indices,
                "material": scene.vertex_material[v0],
                "mode": TRIANGLES,
            }],
        }));
    }
    meshes
}

/// Step 5: `asset.extras.prt`, the conventions and what the file holds.
fn asset_extras(
    contents: &Contents<'_>,
    transfer: &VertexTransfer,
    lightmap: Option<&LightmapContents<'_>>,
    materials: &Materials,
    cpca: Option<Value>,
) -> Option<Value> {
    if let Some(file) = contents.file {
        let h = &file.header;
        let mut prt = json!({
            "order": h.order,
            "channels": h.channels,
            "attributes": transfer.names,
            "coefficients_per_channel": sh::coeff_count(h.order as usize),
            "convention": "real orthonormal SH, index l(l+1)+m, Condon-Shortley phase, of \
                directions in this file's coordinates (theta from +z, phi from +x towards +y); \
                transfer excludes the albedo (the base colour)",
            "mode": h.mode.name(),
            "transfer": h.transfer.name(),
            "colour_0": match (transfer.colour.is_some(), h.transfer) {
                (false, _) => "absent",
                (true, TransferKind::Vector) => "transfer . light per channel, clamped to [0, 1]; times the base colour it is the relit radiance",
                (true, TransferKind::Matrix) => "the diffuse render (the glossy layers left out) per channel with albedo 1, clamped to [0, 1]; times the base colour it is the diffuse radiance",
            },
        });
        if transfer.ao.is_some() {
            prt["ao"] = json!("_AO: SCALAR float, the ambient accessibility per vertex");
        }
        if let Some(light) = contents.light {
            prt["light"] = light_json(&light_in_gltf_frame(light, contents.up));
        }
        if let Some(cpca) = cpca {
            prt["cpca"] = cpca;
        }
        if let Some((q, scales)) = &transfer.quantized {
            let scales: serde_json::Map<String, Value> = transfer
                .names
                .iter()
                .zip(scales)
                .map(|(name, scale)| (name.clone(), json!(scale)))
                .collect();
            prt["quantization"] = json!({
                "bits": q.bits(),
                "scales": scales,
                "decode": "transfer = attribute (normalized signed integer, in [-1, 1]) x its scale",
            });
        }
        return Some(json!({ "prt": prt }));
    }
    let l = lightmap?;
    let h = &l.file.header;
    let mut lightmap_json = json!({
        "width": l.width,
        "height": l.height,
        "texCoord": 1,
        "uv_convention": "glTF's: v down from the image's top; row 0 of the \
            lightmap images prt-bake writes (export --exr, relight) is v = 0",
        "transfer": "per texel, not in this file: prt-bake export --exr writes it \
            as images (manifest.json)",
        "texture": materials.lightmap_texture,
        "texture_holds": if materials.lightmap_texture.is_some() { "transfer . light per channel (albedo 1), clamped to [0, 1], sRGB-encoded; times the base colour it is the relit radiance" } else { "absent" },
    });
    if let Some(t) = materials.lightmap_texture {
        lightmap_json["material_slot"] = json!(format!(
            "every material's extras.prt_lightmap (texCoord 1), beside its own base colour: \
             texture {t}; radiance = base colour x this texture's decoded value"
        ));
    }
    if let Some(t) = materials.occlusion_texture {
        lightmap_json["ao_texture"] = json!(t);
    }
    let mut prt = json!({
        "order": h.order,
        "channels": h.channels,
        "mode": h.mode.name(),
        "lightmap": lightmap_json,
    });
    if let Some(light) = &l.light {
        prt["light"] = light_json(light);
    }
    Some(json!({ "prt": prt }))
}

/// Step 6: the glTF JSON document.
fn document(
    scene: &Scene,
    b: Builder,
    meshes: Vec<Value>,
    materials: Materials,
    extras: Option<Value>,
) -> (Value, Vec<u8>) {
    let Builder {
        mut bin,
        buffer_views,
        accessors,
    } = b;
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let mut nodes: Vec<Value> = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| json!({"name": o.name, "mesh": i}))
        .collect();
    // The two sheets of a doubleSided surface (the bake's back sheet and its front): each
    // shows the transfer of the side its normals face, so a PRT renderer culls back faces.
    for back in 0..scene.objects.len() {
        if let Some(front) = scene.front_of(back) {
            nodes[back]["extras"] = json!({"prt_sheet": "back", "prt_twin": front});
            nodes[front]["extras"] = json!({"prt_sheet": "front", "prt_twin": back});
        }
    }
    let roots = objects::hierarchy_roots(scene.hierarchy.as_ref(), &mut nodes);
    let mut root = json!({
        "asset": {"version": "2.0", "generator": concat!("prt-bake ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": roots}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials.materials,
        "accessors": accessors,
        "bufferViews": buffer_views,
        "buffers": [{"byteLength": bin.len()}],
    });
    if !materials.images.is_empty() {
        root["images"] = json!(materials.images);
        root["textures"] = json!(materials.textures);
        root["samplers"] = json!(materials.samplers);
    }
    let mut used = Vec::new();
    if materials.unlit {
        used.push("KHR_materials_unlit");
    }
    if materials.texture_transform {
        used.push("KHR_texture_transform");
    }
    if !used.is_empty() {
        root["extensionsUsed"] = json!(used);
    }
    if let Some(extras) = extras {
        root["asset"]["extras"] = extras;
    }
    (root, bin)
}

fn glb_bytes_with(
    scene: &Scene,
    contents: &Contents<'_>,
    lightmap: Option<&LightmapContents<'_>>,
    quantize: Option<Quantize>,
    cpca: Option<&Cpca>,
) -> Result<(Vec<u8>, Written)> {
    let arrays = vertex_arrays(scene, contents.up);
    let transfer = vertex_transfer(scene, contents, &arrays, quantize, cpca);
    let mut b = Builder {
        bin: Vec::new(),
        buffer_views: Vec::new(),
        accessors: Vec::new(),
    };
    let pngs = (
        lightmap.and_then(|l| l.png.as_deref()),
        lightmap.and_then(|l| l.ao_png.as_deref()),
    );
    let mut materials = materials(&mut b, scene, transfer.colour.is_some(), pngs)?;
    if let Some(file) = contents.file {
        glossy::add_material_extras(&mut materials.materials, scene, &file.header);
    }
    let meshes = meshes(&mut b, scene, &arrays, &transfer);
    let clusters = transfer.cpca.as_ref().map(|c| c.write_clusters(&mut b));
    let extras = asset_extras(contents, &transfer, lightmap, &materials, clusters);
    let textures = materials.textures.len();
    let lightmap_texture = materials.lightmap_texture.is_some();
    let ao = transfer.ao.is_some() || materials.occlusion_texture.is_some();
    let (mut root, bin) = document(scene, b, meshes, materials, extras);
    if let Some(l) = lightmap {
        objects::add_placements(&mut root, l.file);
    }
    let bytes = glb_container(&root, &bin)?;
    let written = Written {
        vertex_count: scene.vertex_count(),
        triangle_count: scene.triangles.len(),
        materials: scene.materials.len(),
        textures,
        prt_attributes: transfer.names,
        colour: transfer.colour.is_some(),
        bytes: bytes.len(),
        turned_to_y_up: arrays.turned,
        lightmap: lightmap.map(|l| [l.width, l.height]),
        lightmap_texture,
        ao,
        cpca: cpca.map(|c| (c.clusters(), c.pcs)),
    };
    Ok((bytes, written))
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
