//! `prt-bake export`: a coefficient file and its scene as NumPy arrays, for analysis and for
//! checking a bake against an independent reference.

use std::path::Path;

use serde_json::json;

use crate::formats::coefficient_file::{CoefficientFile, LightmapBlock};
use crate::formats::npz::{self, Array};
use crate::formats::openexr::{PixelType, encode, image_rows};
use crate::math::sh;
use crate::scene::Scene;
use crate::support::error::Result;

/// Writes `positions` (V,3), `normals` (V,3), `albedo` (V,3, linear Kd × texture),
/// `transfer` (V, channels, n²) (a matrix bake: `transfer_matrix` (V, channels, n², n²)), `uv` (V,2, v up from the image's bottom, as OBJ) where the
/// scene has texture coordinates, and, where the file has them, `ao` (V,) and `bent_normal`
/// (V,3), and for adaptive bakes `rays` (V,; per-vertex rays cast, exact below 2^24) and
/// `error_estimate` (V,), all float32 in the file's vertex order; and `triangles` (F,3)
/// uint32 vertex indices. The coefficient file must have been baked for this scene. A bake
/// of some objects (`bake --receivers`) adds `receives` (V,; 1 baked, 0 not) and holds the
/// unshadowed transfer at the other vertices ([`CoefficientFile::spread_to_scene`]); a
/// matrix bake of some objects is refused.
///
/// A lightmap (texel) bake is written as [`export_lightmap_npz`] describes.
pub fn export_npz(coefficients: &Path, scene: &Path, output: &Path) -> Result<()> {
    let file = CoefficientFile::read(coefficients)?;
    let scene = file.load_scene(scene)?;
    if file.lightmap.is_some() {
        return export_lightmap_npz(coefficients, &file, &scene, output);
    }
    if file.probes.is_some() {
        return crate::export::probe_npz::export(coefficients, &file, &scene, output);
    }
    file.check_scene_of_any_transfer(coefficients, &scene)?;
    let mut inputs = scene.input_files();
    inputs.push(coefficients.to_path_buf());
    let output = crate::support::output::Output::new(output, &inputs)?;
    let v = scene.vertex_count();
    // A bake of some objects: every vertex, the others unshadowed, and which were baked.
    let receives = receives_mask(&file, &scene);
    let spread = file.spread_to_scene(coefficients, &scene)?;
    let file = &*spread;
    let receivers = Receivers::new(&scene.positions, &scene.normals, file);
    let (geometry, aux) = receivers.arrays(&[v], ["positions", "normals"]);
    let albedo = flat3(&scene.vertex_albedo());
    let header = &file.header;
    let mut arrays = geometry;
    arrays.extend([
        npz::Array {
            name: "albedo",
            shape: vec![v, 3],
            data: &albedo,
        },
        transfer_array(header, v, &file.coefficients),
    ]);
    arrays.extend(aux);
    let rays = rays_f32(file);
    arrays.extend(adaptive_arrays(file, rays.as_deref(), &[v]));
    if let Some(receives) = &receives {
        arrays.push(npz::Array {
            name: "receives",
            shape: vec![v],
            data: receives,
        });
    }
    // A scene whose every uv is (0, 0) has none (OBJ without `vt`, glTF without TEXCOORD_0).
    let uv: Vec<f32> = scene.uvs.iter().flat_map(|uv| uv.to_array()).collect();
    if uv.iter().any(|&x| x != 0.0) {
        arrays.push(npz::Array {
            name: "uv",
            shape: vec![v, 2],
            data: &uv,
        });
    }
    let triangles: Vec<u32> = scene.triangles.iter().flatten().copied().collect();
    let indices = [npz::IndexArray {
        name: "triangles",
        shape: vec![scene.triangles.len(), 3],
        data: &triangles,
    }];
    output.write(&npz::to_bytes(&arrays, &indices, &[])?)
}

/// A bake of some objects (`bake --receivers`): 1 at the baked vertices, 0 at the others
/// (whose exported transfer is the unshadowed lobe); `None` for a bake of every object.
fn receives_mask(file: &CoefficientFile, scene: &Scene) -> Option<Vec<f32>> {
    let receivers = file.header.receivers.as_ref()?;
    let mut mask = vec![0.0; scene.vertex_count()];
    for v in receivers.vertices(scene) {
        mask[v as usize] = 1.0;
    }
    Some(mask)
}

/// The coefficients as `transfer` (V, channels, n²), or for a matrix bake as
/// `transfer_matrix` (V, channels, n², n²), row i of a matrix mapping light coefficients to
/// incident-radiance coefficient i.
fn transfer_array<'a>(
    header: &crate::formats::header::Header,
    v: usize,
    data: &'a [f32],
) -> Array<'a> {
    let n = sh::coeff_count(header.order as usize);
    let channels = header.channels as usize;
    match header.transfer {
        crate::formats::header::TransferKind::Vector => Array {
            name: "transfer",
            shape: vec![v, channels, n],
            data,
        },
        crate::formats::header::TransferKind::Matrix => Array {
            name: "transfer_matrix",
            shape: vec![v, channels, n, n],
            data,
        },
    }
}

/// A texel bake of a W×H lightmap: `texel_positions` (H,W,3), `texel_normals` (H,W,3) (the
/// points the texels were baked at, recomputed from the stored UVs exactly as the bake did),
/// `texel_valid` (H,W, bool: baked), `texel_dilated` (H,W, bool: padding filled from baked
/// neighbours), `transfer` (H,W,channels,n²), `uv1` (triangles,3,2: each
/// triangle corner's lightmap UV in [0, 1]) and, where stored, `ao` (H,W) and
/// `bent_normal` (H,W,3), and for adaptive bakes `rays` and `error_estimate` (H,W; 0 where a
/// texel was not baked). Row y of the arrays is v ∈ [y/H, (y+1)/H].
fn export_lightmap_npz(
    path: &Path,
    file: &CoefficientFile,
    scene: &Scene,
    output: &Path,
) -> Result<()> {
    let block = file.check_lightmap_scene(path, scene)?;
    let mut inputs = scene.input_files();
    inputs.push(path.to_path_buf());
    let output = crate::support::output::Output::new(output, &inputs)?;
    let (w, h) = (block.width as usize, block.height as usize);
    let atlas = crate::bake::lightmap::Atlas::of_block(block);
    let texels = crate::bake::lightmap::Texels::rasterise(scene, &atlas);
    let receivers = Receivers::new(&texels.positions, &texels.normals, file);
    let (geometry, aux) = receivers.arrays(&[h, w], ["texel_positions", "texel_normals"]);
    let uv1: Vec<f32> = block
        .uv1
        .iter()
        .flatten()
        .flat_map(|p| p.to_array())
        .collect();
    let header = &file.header;
    let mut arrays = geometry;
    arrays.extend([
        npz::Array {
            name: "transfer",
            shape: vec![
                h,
                w,
                header.channels as usize,
                sh::coeff_count(header.order as usize),
            ],
            data: &file.coefficients,
        },
        npz::Array {
            name: "uv1",
            shape: vec![block.uv1.len(), 3, 2],
            data: &uv1,
        },
    ]);
    arrays.extend(aux);
    let rays = rays_f32(file);
    arrays.extend(adaptive_arrays(file, rays.as_deref(), &[h, w]));
    let masks = [
        npz::BoolArray {
            name: "texel_valid",
            shape: vec![h, w],
            data: &block.valid,
        },
        npz::BoolArray {
            name: "texel_dilated",
            shape: vec![h, w],
            data: &block.dilated,
        },
    ];
    output.write(&npz::to_bytes(&arrays, &[], &masks)?)
}

/// Vectors as a flat float32 array (x, y, z of each in turn).
/// Adaptive bakes' rays as float32 (exact below 2^24).
fn rays_f32(file: &CoefficientFile) -> Option<Vec<f32>> {
    file.rays
        .as_ref()
        .map(|r| r.iter().map(|&r| r as f32).collect())
}

/// Adaptive bakes: `rays` (from [`rays_f32`]) and `error_estimate`, of leading shape `lead`
/// ((V,) for vertices, (H, W) for texels, 0 rays where a texel was not baked).
fn adaptive_arrays<'a>(
    file: &'a CoefficientFile,
    rays: Option<&'a [f32]>,
    lead: &[usize],
) -> Vec<Array<'a>> {
    let named = [
        ("rays", rays),
        ("error_estimate", file.error_estimate.as_deref()),
    ];
    named
        .into_iter()
        .filter_map(|(name, data)| {
            data.map(|data| Array {
                name,
                shape: lead.to_vec(),
                data,
            })
        })
        .collect()
}

fn flat3(values: &[glam::Vec3]) -> Vec<f32> {
    values.iter().flat_map(|x| x.to_array()).collect()
}

/// What vertex and texel exports both write per receiver, flattened.
struct Receivers<'a> {
    positions: Vec<f32>,
    normals: Vec<f32>,
    ao: Option<&'a [f32]>,
    bent_normal: Option<Vec<f32>>,
}

impl<'a> Receivers<'a> {
    fn new(positions: &[glam::Vec3], normals: &[glam::Vec3], file: &'a CoefficientFile) -> Self {
        Receivers {
            positions: flat3(positions),
            normals: flat3(normals),
            ao: file.ao.as_deref(),
            bent_normal: file.bent_normal.as_deref().map(flat3),
        }
    }

    /// The arrays of leading shape `lead` ((V,) for vertices, (H, W) for texels): the
    /// geometry, `names` (…, 3), and the stored aux arrays `ao` (…) and `bent_normal` (…, 3).
    fn arrays(&self, lead: &[usize], names: [&'static str; 2]) -> (Vec<Array<'_>>, Vec<Array<'_>>) {
        let shape = |inner: &[usize]| [lead, inner].concat();
        let geometry = vec![
            Array {
                name: names[0],
                shape: shape(&[3]),
                data: &self.positions,
            },
            Array {
                name: names[1],
                shape: shape(&[3]),
                data: &self.normals,
            },
        ];
        let mut aux = Vec::new();
        if let Some(ao) = self.ao {
            aux.push(Array {
                name: "ao",
                shape: shape(&[]),
                data: ao,
            });
        }
        if let Some(bent_normal) = &self.bent_normal {
            aux.push(Array {
                name: "bent_normal",
                shape: shape(&[3]),
                data: bent_normal,
            });
        }
        (geometry, aux)
    }
}

/// What [`export_exr`] wrote, for the CLI's summary line.
#[derive(Clone, Debug)]
pub struct ExrWritten {
    pub width: u32,
    pub height: u32,
    /// The image files, in the manifest's order (the manifest is written last).
    pub files: Vec<std::path::PathBuf>,
    pub manifest: std::path::PathBuf,
}

/// The transfer image names of a bake: coefficients 4k..4k+3 of channel c (`""` grey, or
/// `"r"`, `"g"`, `"b"`) in `transfer_[c_]AA-BB.exr`, AA = 4k, BB = 4k+3.
pub fn exr_transfer_names(order: usize, channels: usize) -> Vec<(usize, usize, String)> {
    let groups = sh::coeff_count(order).div_ceil(4);
    let prefixes: &[&str] = match channels {
        1 => &[""],
        _ => &["r_", "g_", "b_"],
    };
    prefixes
        .iter()
        .enumerate()
        .flat_map(|(c, prefix)| {
            (0..groups).map(move |k| {
                (
                    c,
                    k,
                    format!("transfer_{prefix}{:02}-{:02}.exr", 4 * k, 4 * k + 3),
                )
            })
        })
        .collect()
}

/// A texel bake's coefficients as OpenEXR images in `dir` (created if missing), W×H each,
/// rows as [`crate::formats::openexr`] states (row 0 at the top: texel row H−1): per colour channel
/// c and k, coefficients 4k..4k+3 in R, G, B, A of `transfer_[c_]AA-BB.exr` (the last
/// zero-padded); `texel_state.exr` (Y: 1 baked, 0.5 dilated, 0 empty); where stored `ao.exr`
/// (Y) and `bent_normal.exr` (RGB = x, y, z in the bake's frame); and `manifest.json` saying
/// all that. Every file goes through the output policy; the manifest is written last, so a
/// directory with a manifest is complete. A vertex bake is refused (`InvalidOption`).
pub fn export_exr(
    coefficients: &Path,
    scene: &Path,
    dir: &Path,
    pixel_type: crate::formats::openexr::PixelType,
) -> Result<ExrWritten> {
    let file = CoefficientFile::read(coefficients)?;
    if file.lightmap.is_none() {
        return Err(crate::Error::InvalidOption(format!(
            "{}: a per-vertex bake; --exr writes lightmap (texel) bakes only (bake with \
             --lightmap RES, or export this one with --npz or --gltf)",
            coefficients.display()
        )));
    }
    let scene = file.load_scene(scene)?;
    let block = file.check_lightmap_scene(coefficients, &scene)?;
    let mut inputs = scene.input_files();
    inputs.push(coefficients.to_path_buf());
    if dir.exists() && !dir.is_dir() {
        return Err(crate::Error::Output {
            path: dir.to_path_buf(),
            message: "is not a directory; --exr names a directory for the images".into(),
        });
    }
    std::fs::create_dir_all(dir).map_err(|err| crate::Error::io(dir, err))?;

    let (w, h) = (block.width as usize, block.height as usize);
    let (mut images, transfer_entries) = exr_transfer_images(&file, w, h, dir, pixel_type)?;
    images.extend(exr_aux_images(&file, block, dir, pixel_type)?);
    let manifest = exr_manifest(coefficients, &file, pixel_type, transfer_entries);
    let mut manifest_bytes = serde_json::to_vec_pretty(&manifest).expect("plain JSON serialises");
    manifest_bytes.push(b'\n');
    images.push(("manifest.json".into(), manifest_bytes));

    // Every path checked before any is written: a refusal leaves the directory as it was.
    let outputs = images
        .iter()
        .map(|(name, _)| crate::support::output::Output::new(&dir.join(name), &inputs))
        .collect::<Result<Vec<_>>>()?;
    for (output, (_, bytes)) in outputs.iter().zip(&images) {
        output.write(bytes)?;
    }
    let mut files: Vec<std::path::PathBuf> =
        outputs.iter().map(|o| o.path().to_path_buf()).collect();
    let manifest = files.pop().expect("the manifest");
    Ok(ExrWritten {
        width: block.width,
        height: block.height,
        files,
        manifest,
    })
}

/// A file of the export: its name in the directory and its bytes.
type NamedFile = (String, Vec<u8>);

/// (file name, EXR bytes) of every transfer image, four coefficients each, and their
/// manifest entries.
fn exr_transfer_images(
    file: &CoefficientFile,
    w: usize,
    h: usize,
    dir: &Path,
    pixel_type: PixelType,
) -> Result<(Vec<NamedFile>, Vec<serde_json::Value>)> {
    let (order, channels) = (file.header.order as usize, file.header.channels as usize);
    let n = sh::coeff_count(order);
    let rows = |texels: Vec<f32>| image_rows(&texels, w, h);
    let mut images: Vec<NamedFile> = Vec::new();
    let mut transfer_entries = Vec::new();
    for (c, k, name) in exr_transfer_names(order, channels) {
        let rgba: Vec<(&str, Vec<f32>)> = ["R", "G", "B", "A"]
            .iter()
            .enumerate()
            .map(|(i, &channel)| {
                let j = 4 * k + i;
                let texels = (0..w * h)
                    .map(|t| if j < n { file.vertex(t, c)[j] } else { 0.0 })
                    .collect();
                (channel, rows(texels))
            })
            .collect();
        let held: Vec<usize> = (4 * k..(4 * k + 4).min(n)).collect();
        // The coefficient in R, G, B and A (null: padding).
        let rgba_held: Vec<Option<usize>> =
            (4 * k..4 * k + 4).map(|j| (j < n).then_some(j)).collect();
        transfer_entries.push(json!({
            "file": name,
            "colour_channel": match channels { 1 => "grey", _ => ["r", "g", "b"][c] },
            "coefficients": held,
            "rgba": rgba_held,
            "zero_padded_channels": 4 - held.len(),
        }));
        images.push((
            name.clone(),
            encode(&dir.join(&name), w, h, rgba, pixel_type)?,
        ));
    }
    Ok((images, transfer_entries))
}

/// The texel states, and the AO and bent normals where the bake stored them.
fn exr_aux_images(
    file: &CoefficientFile,
    block: &LightmapBlock,
    dir: &Path,
    pixel_type: PixelType,
) -> Result<Vec<NamedFile>> {
    let (w, h) = (block.width as usize, block.height as usize);
    let rows = |texels: Vec<f32>| image_rows(&texels, w, h);
    let mut images = Vec::new();
    let state: Vec<f32> = (0..w * h)
        .map(|t| match (block.valid[t], block.dilated[t]) {
            (true, _) => 1.0,
            (false, true) => 0.5,
            _ => 0.0,
        })
        .collect();
    images.push((
        "texel_state.exr".into(),
        encode(
            &dir.join("texel_state.exr"),
            w,
            h,
            vec![("Y", rows(state))],
            pixel_type,
        )?,
    ));
    if let Some(ao) = &file.ao {
        images.push((
            "ao.exr".into(),
            encode(
                &dir.join("ao.exr"),
                w,
                h,
                vec![("Y", rows(ao.clone()))],
                pixel_type,
            )?,
        ));
    }
    if let Some(bent) = &file.bent_normal {
        let axis = |i: usize| rows(bent.iter().map(|b| b[i]).collect());
        images.push((
            "bent_normal.exr".into(),
            encode(
                &dir.join("bent_normal.exr"),
                w,
                h,
                vec![("R", axis(0)), ("G", axis(1)), ("B", axis(2))],
                pixel_type,
            )?,
        ));
    }
    Ok(images)
}

/// `manifest.json`: what every image holds, and the conventions to read it by.
fn exr_manifest(
    coefficients: &Path,
    file: &CoefficientFile,
    pixel_type: PixelType,
    transfer_entries: Vec<serde_json::Value>,
) -> serde_json::Value {
    let header = &file.header;
    let block = file.lightmap.as_ref().expect("a texel bake");
    let (w, h) = (block.width as usize, block.height as usize);
    let (order, channels) = (header.order as usize, header.channels as usize);
    let n = sh::coeff_count(order);
    json!({
        "generator": concat!("prt-bake ", env!("CARGO_PKG_VERSION")),
        "source": coefficients.display().to_string(),
        "width": w,
        "height": h,
        "pixel_type": pixel_type.name(),
        "order": order,
        "channels": channels,
        "coefficients_per_channel": n,
        "convention": "real orthonormal SH, index l(l+1)+m, Condon-Shortley phase, of directions \
            in the bake's own coordinates (theta from +z); transfer excludes the albedo",
        "up": header.up.name(),
        "mode": header.mode.name(),
        "rows": "image row r holds texel row H-1-r: the top row is v = 1 of the .prt's UVs \
            (v up, as OBJ) and v = 0 of glTF's TEXCOORD_1 (v down), as for any texture",
        "transfer": transfer_entries,
        "texel_state": {
            "file": "texel_state.exr",
            "channel": "Y",
            "values": {"1": "baked", "0.5": "dilated (padding filled from baked neighbours)", "0": "empty (zero transfer)"},
        },
        "ao": file.ao.as_ref().map(|_| json!({"file": "ao.exr", "channel": "Y"})),
        "bent_normal": file.bent_normal.as_ref().map(|_| json!({
            "file": "bent_normal.exr",
            "channels": {"R": "x", "G": "y", "B": "z"},
        })),
    })
}
