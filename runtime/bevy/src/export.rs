//! Reading prt-bake's `.glb` exports (docs/reference/gltf.md) into Bevy meshes: positions,
//! normals, TEXCOORD_0/1, the transfer (`_PRT_k` or `_PRT_Rk`…, float or `--quantize`d, or
//! CPCA-compressed and reconstructed here), COLOR_0, the materials' base colour and the
//! texel bakes' relit lightmap.

use std::path::{Path, PathBuf};

use bevy::asset::RenderAssetUsages;
use bevy::image::{CompressedImageFormats, ImageSampler, ImageType};
use bevy::mesh::{Indices, MeshVertexAttribute, PrimitiveTopology, VertexFormat};
use bevy::prelude::*;
use gltf::Semantic;
use gltf::accessor::{DataType, util::Iter};

use crate::light::PrtLight;

/// The most transfer attributes a mesh may carry (order 4 RGB, or order 6 grey).
pub const MAX_TRANSFER_ATTRIBUTES: usize = 12;

/// The transfer attributes: VEC4 `i` holds coefficients 4i..4i+3 of one channel, grey
/// (i < ⌈n²/4⌉) or channel-major RGB (R groups, then G, then B).
pub const PRT_TRANSFER: [MeshVertexAttribute; MAX_TRANSFER_ATTRIBUTES] = {
    let mut list = [MeshVertexAttribute::new("PRT_T0", 0x5052_5400, VertexFormat::Float32x4);
        MAX_TRANSFER_ATTRIBUTES];
    let names = [
        "PRT_T0", "PRT_T1", "PRT_T2", "PRT_T3", "PRT_T4", "PRT_T5", "PRT_T6", "PRT_T7", "PRT_T8",
        "PRT_T9", "PRT_T10", "PRT_T11",
    ];
    let mut i = 0;
    while i < MAX_TRANSFER_ATTRIBUTES {
        list[i] =
            MeshVertexAttribute::new(names[i], 0x5052_5400 + i as u64, VertexFormat::Float32x4);
        i += 1;
    }
    list
};

/// Why an export could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("{path}: {source}")]
    Gltf { path: PathBuf, source: gltf::Error },
    #[error("{path}: {message}")]
    Content { path: PathBuf, message: String },
}

/// One exported object: its mesh and what its material holds.
pub struct PrtPart {
    pub name: String,
    /// POSITION, NORMAL, UV_0, UV_1 (texel bakes) and [`PRT_TRANSFER`] (vertex bakes).
    pub mesh: Mesh,
    pub base_color: LinearRgba,
    /// Index into [`PrtExport::images`] of the base colour texture (sRGB, TEXCOORD_0).
    pub base_color_texture: Option<usize>,
    /// Index into [`PrtExport::images`] of the relit lightmap (`export --lights` of a texel bake).
    pub lightmap: Option<usize>,
    /// COLOR_0: the export's own T·L at its rig (`export --gltf --lights`).
    pub colours: Option<Vec<[f32; 4]>>,
    /// Whether the transfer is per vertex ([`PRT_TRANSFER`]); otherwise per texel.
    pub vertex_transfer: bool,
    pub double_sided: bool,
    /// A node of a two-sided surface's sheet pair (`extras.prt_sheet`): drawn front faces only.
    pub sheet: bool,
    pub alpha_mode: AlphaMode,
}

/// A whole export: an [`Asset`], loaded by `asset_server.load::<PrtExport>("x.glb")`.
#[derive(Asset, TypePath)]
pub struct PrtExport {
    pub order: usize,
    /// 1 (grey) or 3 (RGB).
    pub channels: usize,
    /// The rig the file was exported with (`asset.extras.prt.light`), in its frame.
    pub light: Option<PrtLight>,
    pub parts: Vec<PrtPart>,
    pub images: Vec<Image>,
}

impl PrtExport {
    /// Transfer VEC4s per channel: ⌈n²/4⌉.
    pub fn groups(&self) -> usize {
        (self.order * self.order).div_ceil(4)
    }
}

/// Reads an export from a file, outside Bevy's asset server (which loads it with
/// [`crate::PrtExportLoader`]). Errors name the file and the problem.
pub fn load_export(path: &Path) -> Result<PrtExport, ExportError> {
    let bytes = std::fs::read(path).map_err(|e| ExportError::Content {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    parse_export(&bytes, path)
}

/// An export from its bytes; `path` names it in the errors.
pub fn parse_export(bytes: &[u8], path: &Path) -> Result<PrtExport, ExportError> {
    let content = |message: String| ExportError::Content {
        path: path.to_path_buf(),
        message,
    };
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice(bytes).map_err(|source| ExportError::Gltf {
            path: path.to_path_buf(),
            source,
        })?;
    // An export is one .glb: its one buffer is the binary chunk.
    let blob = blob.ok_or_else(|| content("no binary chunk: not a .glb export".into()))?;
    let buffers = [blob];
    let prt = document
        .as_json()
        .asset
        .extras
        .as_ref()
        .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok())
        .and_then(|extras| extras.get("prt").cloned())
        .ok_or_else(|| content("no asset.extras.prt: not a prt-bake export".into()))?;
    let order = prt["order"]
        .as_u64()
        .ok_or_else(|| content("asset.extras.prt.order missing".into()))? as usize;
    let channels = prt["channels"].as_u64().unwrap_or(1) as usize;
    let light = match prt.get("light") {
        Some(value) => {
            Some(PrtLight::from_json_value(value, path).map_err(|e| content(e.to_string()))?)
        }
        None => None,
    };
    let get = |buffer: gltf::Buffer| buffers.get(buffer.index()).map(|b| b.as_slice());
    let cpca = match prt.get("cpca") {
        Some(c) => Some(Cpca::read(c, &document, &get).map_err(content)?),
        None => None,
    };
    let scales = prt
        .get("quantization")
        .and_then(|q| q.get("scales"))
        .cloned();
    let images = read_images(&document, &buffers).map_err(content)?;
    let groups = (order * order).div_ceil(4);
    let mut parts = Vec::new();
    for node in document.nodes() {
        let Some(mesh) = node.mesh() else { continue };
        let name = node.name().unwrap_or("").to_string();
        let sheet = node
            .extras()
            .as_ref()
            .is_some_and(|raw| raw.get().contains("prt_sheet"));
        for primitive in mesh.primitives() {
            let reader = primitive.reader(&get);
            let positions: Vec<[f32; 3]> = reader
                .read_positions()
                .ok_or_else(|| content(format!("mesh '{name}': no POSITION")))?
                .collect();
            let count = positions.len();
            let normals: Vec<[f32; 3]> = reader
                .read_normals()
                .ok_or_else(|| content(format!("mesh '{name}': no NORMAL")))?
                .collect();
            let uv0: Vec<[f32; 2]> = match reader.read_tex_coords(0) {
                Some(t) => t.into_f32().collect(),
                None => vec![[0.0; 2]; count],
            };
            let indices: Vec<u32> = reader
                .read_indices()
                .ok_or_else(|| content(format!("mesh '{name}': no indices")))?
                .into_u32()
                .collect();
            let mut bevy_mesh = Mesh::new(
                PrimitiveTopology::TriangleList,
                RenderAssetUsages::default(),
            );
            bevy_mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, positions);
            bevy_mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, normals);
            bevy_mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, uv0);
            if let Some(t) = reader.read_tex_coords(1) {
                bevy_mesh.insert_attribute(Mesh::ATTRIBUTE_UV_1, t.into_f32().collect::<Vec<_>>());
            }
            bevy_mesh.insert_indices(Indices::U32(indices));
            let transfer = match &cpca {
                Some(c)
                    if primitive
                        .get(&Semantic::Extras("PRT_CLUSTER".into()))
                        .is_some() =>
                {
                    Some(
                        c.reconstruct(&primitive, &get, count)
                            .map_err(|m| content(format!("mesh '{name}': {m}")))?,
                    )
                }
                _ => read_transfer(&primitive, &get, channels, groups, scales.as_ref())
                    .map_err(|m| content(format!("mesh '{name}': {m}")))?,
            };
            let vertex_transfer = transfer.is_some();
            if let Some(t) = transfer {
                if t.len() > MAX_TRANSFER_ATTRIBUTES {
                    return Err(content(format!(
                        "mesh '{name}': {} transfer VEC4s, at most {MAX_TRANSFER_ATTRIBUTES} fit",
                        t.len()
                    )));
                }
                for (attribute, values) in PRT_TRANSFER.iter().zip(t) {
                    bevy_mesh.insert_attribute(*attribute, values);
                }
            }
            let colours = reader.read_colors(0).map(|c| c.into_rgba_f32().collect());
            let material = primitive.material();
            let pbr = material.pbr_metallic_roughness();
            let lightmap = material
                .extras()
                .as_ref()
                .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok())
                .and_then(|e| {
                    e.get("prt_lightmap")
                        .and_then(|l| l.get("index"))
                        .and_then(|i| i.as_u64())
                })
                .and_then(|i| document.textures().nth(i as usize))
                .map(|t| t.source().index());
            let alpha_mode = match material.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Mask => {
                    AlphaMode::Mask(material.alpha_cutoff().unwrap_or(0.5))
                }
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
            };
            parts.push(PrtPart {
                name: name.clone(),
                mesh: bevy_mesh,
                base_color: LinearRgba::from_f32_array(pbr.base_color_factor()),
                base_color_texture: pbr
                    .base_color_texture()
                    .map(|t| t.texture().source().index()),
                lightmap,
                colours,
                vertex_transfer,
                double_sided: material.double_sided(),
                sheet,
                alpha_mode,
            });
        }
    }
    Ok(PrtExport {
        order,
        channels,
        light,
        parts,
        images,
    })
}

/// The file's images, decoded (sRGB: base colours and relit lightmaps are sRGB-encoded),
/// sampled linearly with mipmaps' absence (repeat where the file's sampler repeats).
fn read_images(document: &gltf::Document, buffers: &[Vec<u8>]) -> Result<Vec<Image>, String> {
    let mut repeat = vec![false; document.images().count()];
    for texture in document.textures() {
        let s = texture.sampler();
        repeat[texture.source().index()] |= s.wrap_s() == gltf::texture::WrappingMode::Repeat;
    }
    document
        .images()
        .map(|image| {
            let gltf::image::Source::View { view, mime_type } = image.source() else {
                return Err("an image outside the .glb's buffer".to_string());
            };
            let data =
                &buffers[view.buffer().index()][view.offset()..view.offset() + view.length()];
            let mut sampler = bevy::image::ImageSamplerDescriptor::linear();
            if repeat[image.index()] {
                sampler.set_address_mode(bevy::image::ImageAddressMode::Repeat);
            }
            Image::from_buffer(
                data,
                ImageType::MimeType(mime_type),
                CompressedImageFormats::NONE,
                true,
                ImageSampler::Descriptor(sampler),
                RenderAssetUsages::default(),
            )
            .map_err(|e| format!("image {}: {e}", image.index()))
        })
        .collect()
}

type GetBuffer<'a> = dyn Fn(gltf::Buffer<'a>) -> Option<&'a [u8]> + 'a;

/// A VEC4 attribute as floats: float, or normalized SHORT/BYTE (`--quantize`) times its scale.
fn read_vec4<'a>(
    accessor: gltf::Accessor<'a>,
    get: &'a GetBuffer<'a>,
    scale: f32,
) -> Result<Vec<[f32; 4]>, String> {
    let missing = || "an attribute without data".to_string();
    Ok(match accessor.data_type() {
        DataType::F32 => Iter::<[f32; 4]>::new(accessor, get)
            .ok_or_else(missing)?
            .collect(),
        DataType::I16 => Iter::<[i16; 4]>::new(accessor, get)
            .ok_or_else(missing)?
            .map(|v| v.map(|x| (x as f32 / 32767.0).max(-1.0) * scale))
            .collect(),
        DataType::I8 => Iter::<[i8; 4]>::new(accessor, get)
            .ok_or_else(missing)?
            .map(|v| v.map(|x| (x as f32 / 127.0).max(-1.0) * scale))
            .collect(),
        other => return Err(format!("transfer of component type {other:?}")),
    })
}

/// The `_PRT_k` (grey) or `_PRT_Rk`, `_PRT_Gk`, `_PRT_Bk` (RGB) attributes, channel-major;
/// None for a mesh without them (a texel bake's).
fn read_transfer<'a>(
    primitive: &gltf::Primitive<'a>,
    get: &'a GetBuffer<'a>,
    channels: usize,
    groups: usize,
    scales: Option<&serde_json::Value>,
) -> Result<Option<Vec<Vec<[f32; 4]>>>, String> {
    let names: Vec<String> = if channels == 1 {
        (0..groups).map(|k| format!("PRT_{k}")).collect()
    } else {
        ["R", "G", "B"]
            .iter()
            .flat_map(|c| (0..groups).map(move |k| format!("PRT_{c}{k}")))
            .collect()
    };
    if primitive.get(&Semantic::Extras(names[0].clone())).is_none() {
        return Ok(None);
    }
    let mut out = Vec::with_capacity(names.len());
    for name in &names {
        let accessor = primitive
            .get(&Semantic::Extras(name.clone()))
            .ok_or_else(|| format!("no _{name} attribute"))?;
        let scale = match (accessor.normalized(), scales) {
            (false, _) => 1.0,
            (true, Some(s)) => s
                .get(format!("_{name}"))
                .and_then(|x| x.as_f64())
                .ok_or_else(|| format!("no quantization scale for _{name}"))?
                as f32,
            (true, None) => {
                return Err(format!(
                    "_{name} is quantized, but the file has no asset.extras.prt.quantization"
                ));
            }
        };
        out.push(read_vec4(accessor, get, scale)?);
    }
    Ok(Some(out))
}

/// A CPCA-compressed bake's clusters (`asset.extras.prt.cpca`).
struct Cpca {
    pcs: usize,
    dim: usize,
    order: usize,
    channels: usize,
    means: Vec<f32>,
    bases: Vec<f32>,
}

impl Cpca {
    fn read<'a>(
        value: &serde_json::Value,
        document: &'a gltf::Document,
        get: &'a GetBuffer<'a>,
    ) -> Result<Cpca, String> {
        let int = |key: &str| {
            value
                .get(key)
                .and_then(|x| x.as_u64())
                .map(|x| x as usize)
                .ok_or_else(|| format!("asset.extras.prt.cpca.{key} missing"))
        };
        if value.get("transfer").and_then(|t| t.as_str()) == Some("matrix") {
            return Err(
                "a glossy transfer-matrix bake: bevy_prt relights diffuse transfer only".into(),
            );
        }
        let (clusters, pcs, dim, order, channels) = (
            int("clusters")?,
            int("pcs")?,
            int("dim")?,
            int("order")?,
            int("channels")?,
        );
        let floats = |key: &str| -> Result<Vec<f32>, String> {
            let accessor = document
                .accessors()
                .nth(int(key)?)
                .ok_or_else(|| format!("cpca.{key}: no such accessor"))?;
            Ok(Iter::<f32>::new(accessor, get)
                .ok_or("cpca accessor without data")?
                .collect())
        };
        let (means, bases) = (floats("means")?, floats("bases")?);
        if dim != channels * order * order
            || means.len() != clusters * dim
            || bases.len() != clusters * pcs * dim
        {
            return Err("asset.extras.prt.cpca: clusters, pcs, dim, order and channels do not fit the accessors".into());
        }
        Ok(Cpca {
            pcs,
            dim,
            order,
            channels,
            means,
            bases,
        })
    }

    /// Per vertex, means[k] + Σ_i w_i·bases[k, i], packed as [`PRT_TRANSFER`].
    fn reconstruct<'a>(
        &self,
        primitive: &gltf::Primitive<'a>,
        get: &'a GetBuffer<'a>,
        count: usize,
    ) -> Result<Vec<Vec<[f32; 4]>>, String> {
        let cluster_accessor = primitive
            .get(&Semantic::Extras("PRT_CLUSTER".into()))
            .ok_or("no _PRT_CLUSTER")?;
        let clusters: Vec<f32> = Iter::<f32>::new(cluster_accessor, get)
            .ok_or("no cluster data")?
            .collect();
        let mut weights = Vec::new();
        for k in 0..self.pcs.div_ceil(4) {
            let accessor = primitive
                .get(&Semantic::Extras(format!("PRT_W{k}")))
                .ok_or_else(|| format!("no _PRT_W{k}"))?;
            weights.push(read_vec4(accessor, get, 1.0)?);
        }
        let n = self.order * self.order;
        let groups = n.div_ceil(4);
        let mut out = vec![vec![[0.0f32; 4]; count]; self.channels * groups];
        let mut t = vec![0.0f32; self.dim];
        for v in 0..count {
            let k = clusters[v].round() as usize;
            t.copy_from_slice(
                self.means
                    .get(k * self.dim..(k + 1) * self.dim)
                    .ok_or("a cluster index out of range")?,
            );
            for i in 0..self.pcs {
                let w = weights[i / 4][v][i % 4];
                let base =
                    &self.bases[(k * self.pcs + i) * self.dim..(k * self.pcs + i + 1) * self.dim];
                t.iter_mut().zip(base).for_each(|(a, b)| *a += w * b);
            }
            for c in 0..self.channels {
                for j in 0..n {
                    out[c * groups + j / 4][v][j % 4] = t[c * n + j];
                }
            }
        }
        Ok(out)
    }
}
