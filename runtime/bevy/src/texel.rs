//! A texel bake's transfer from `prt-bake export LM.prt --scene S --exr DIR`: DIR/manifest.json
//! and its `transfer_*.exr` images, as one half-float 2D array texture (layer i = VEC4 group
//! i, channel-major for RGB), sampled linearly on TEXCOORD_1.
//!
//! Rows: image row r of the EXR is v = r/H of glTF's TEXCOORD_1 (v down from the top), and
//! Bevy's textures have row 0 at v = 0 too, so the rows go up as they are read.

use std::path::{Path, PathBuf};

use bevy::asset::RenderAssetUsages;
use bevy::image::{ImageSampler, ImageSamplerDescriptor};
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use serde::Deserialize;

/// Why a texel bake's transfer could not be read.
#[derive(Debug, thiserror::Error)]
pub enum TexelError {
    #[error("{path}: {message}")]
    Read { path: PathBuf, message: String },
}

#[derive(Deserialize)]
pub(crate) struct Manifest {
    order: usize,
    channels: usize,
    width: u32,
    height: u32,
    up: String,
    transfer: Vec<Entry>,
}

#[derive(Deserialize)]
struct Entry {
    file: String,
    coefficients: Vec<usize>,
    colour_channel: String,
}

/// The transfer images of a texel bake: an [`Asset`], loaded by
/// `asset_server.load::<TexelTransfer>("DIR/manifest.json")`.
#[derive(Asset, TypePath)]
pub struct TexelTransfer {
    pub order: usize,
    pub channels: usize,
    /// The bake's up axis (`manifest.up`): the transfer is in the bake's own frame, so a z-up
    /// bake is relit by the glTF-frame light turned back to z-up.
    pub z_up: bool,
    /// Layers: ⌈n²/4⌉ per channel, channel-major.
    pub image: Image,
}

/// Reads DIR/manifest.json and its images, outside Bevy's asset server (which loads them
/// with [`crate::TexelTransferLoader`]).
pub fn load_texel_transfer(dir: &Path) -> Result<TexelTransfer, TexelError> {
    let manifest_path = dir.join("manifest.json");
    let text = std::fs::read_to_string(&manifest_path)
        .map_err(|e| error(&manifest_path, e.to_string()))?;
    let manifest = parse_manifest(&text, &manifest_path)?;
    let mut files = Vec::new();
    for file in manifest.files() {
        let path = dir.join(file);
        let bytes = std::fs::read(&path).map_err(|e| error(&path, e.to_string()))?;
        files.push((path, bytes));
    }
    assemble(&manifest, &manifest_path, &files)
}

fn error(path: &Path, message: String) -> TexelError {
    TexelError::Read {
        path: path.to_path_buf(),
        message,
    }
}

/// A texel bake's manifest, checked against the layers its order and channels need.
pub(crate) fn parse_manifest(text: &str, manifest_path: &Path) -> Result<Manifest, TexelError> {
    let manifest: Manifest = serde_json::from_str(text).map_err(|e| {
        error(
            manifest_path,
            format!("not a prt-bake lightmap manifest: {e}"),
        )
    })?;
    let groups = (manifest.order * manifest.order).div_ceil(4);
    let layers = groups * manifest.channels;
    if manifest.transfer.len() != layers || ![1, 3].contains(&manifest.channels) {
        return Err(error(
            manifest_path,
            format!(
                "{} transfer images, order {} with {} channel(s) needs {layers}",
                manifest.transfer.len(),
                manifest.order,
                manifest.channels
            ),
        ));
    }
    Ok(manifest)
}

impl Manifest {
    /// The transfer images' file names, relative to the manifest's folder, in its order.
    pub(crate) fn files(&self) -> impl Iterator<Item = &str> {
        self.transfer.iter().map(|e| e.file.as_str())
    }
}

/// The transfer array from the manifest and its images' bytes (in [`Manifest::files`]'s
/// order, each with the path that names it in the errors).
pub(crate) fn assemble(
    manifest: &Manifest,
    manifest_path: &Path,
    files: &[(PathBuf, Vec<u8>)],
) -> Result<TexelTransfer, TexelError> {
    let groups = (manifest.order * manifest.order).div_ceil(4);
    let layers = groups * manifest.channels;
    let (w, h) = (manifest.width as usize, manifest.height as usize);
    let texel_bytes = 8;
    let mut data = vec![0u8; layers * w * h * texel_bytes];
    for (entry, (path, bytes)) in manifest.transfer.iter().zip(files) {
        let channel = match entry.colour_channel.as_str() {
            "grey" | "r" | "R" | "red" => 0,
            "g" | "G" | "green" => 1,
            "b" | "B" | "blue" => 2,
            other => return Err(error(manifest_path, format!("colour_channel \"{other}\""))),
        };
        let first = *entry
            .coefficients
            .first()
            .ok_or_else(|| error(manifest_path, "an entry without coefficients".into()))?;
        let layer = channel * groups + first / 4;
        let image = read_rgba(
            bytes,
            |resolution, _| {
                (
                    resolution.width(),
                    vec![[0.0f32; 4]; resolution.width() * resolution.height()],
                )
            },
            |(width, pixels), position, (r, g, b, a): (f32, f32, f32, f32)| {
                pixels[position.y() * *width + position.x()] = [r, g, b, a];
            },
        )
        .map_err(|e| error(path, e.to_string()))?;
        let size = image.layer_data.size;
        if size.width() != w || size.height() != h {
            return Err(error(
                path,
                format!(
                    "{}×{}, the manifest says {w}×{h}",
                    size.width(),
                    size.height()
                ),
            ));
        }
        let pixels = &image.layer_data.channel_data.pixels.1;
        let out = &mut data[layer * w * h * texel_bytes..(layer + 1) * w * h * texel_bytes];
        for (i, p) in pixels.iter().enumerate() {
            for (c, x) in p.iter().enumerate() {
                let bits = half::f16::from_f32(*x).to_bits().to_le_bytes();
                out[i * texel_bytes + 2 * c..i * texel_bytes + 2 * c + 2].copy_from_slice(&bits);
            }
        }
    }
    let mut image = Image::new(
        Extent3d {
            width: manifest.width,
            height: manifest.height,
            depth_or_array_layers: layers as u32,
        },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba16Float,
        RenderAssetUsages::RENDER_WORLD,
    );
    image.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor::linear());
    // A one-layer array stays an array to the shader.
    image.texture_view_descriptor = Some(bevy::render::render_resource::TextureViewDescriptor {
        dimension: Some(bevy::render::render_resource::TextureViewDimension::D2Array),
        ..default()
    });
    Ok(TexelTransfer {
        order: manifest.order,
        channels: manifest.channels,
        z_up: manifest.up == "z",
        image,
    })
}

/// exr's `read_first_rgba_layer_from_file`, from bytes.
fn read_rgba<Set, Create, Pixels: 'static>(
    bytes: &[u8],
    create: Create,
    set_pixel: Set,
) -> exr::error::Result<exr::prelude::PixelImage<Pixels, exr::prelude::RgbaChannels>>
where
    Create: Fn(exr::math::Vec2<usize>, &exr::prelude::RgbaChannels) -> Pixels + 'static,
    Set: Fn(&mut Pixels, exr::math::Vec2<usize>, (f32, f32, f32, f32)) + 'static,
{
    use exr::prelude::*;
    exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(create, set_pixel)
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
}
