//! OpenEXR encoding of lightmap images (texel bakes' coefficients, relit lightmaps), with the
//! `exr` crate: pure Rust, and already the one `image` reads `.exr` environment maps with.
//!
//! Row convention of every lightmap image the baker writes (EXR and PNG): **image row r holds
//! texel row H−1−r**. Texel row y covers v ∈ [y/H, (y+1)/H] of the file's UVs, whose v runs
//! up from the image's bottom (OBJ's convention, and what the scene loader makes of glTF's
//! TEXCOORD_1 by v ↦ 1−v). So the image's top row is v = 1 in the `.prt` and v = 0 in glTF,
//! exactly as for the scene's albedo textures: an engine samples the lightmap with the asset's
//! own TEXCOORD_1 (or with the one `export --gltf` writes) like any other texture.

use std::path::Path;

use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, SmallVec,
    WritableImage, f16,
};

use crate::support::error::{Error, Result};

/// How samples are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelType {
    /// Half floats: 11 significant bits, range ±65504.
    F16,
    /// Single floats: the `.prt`'s own values, exactly.
    F32,
}

impl PixelType {
    pub fn name(self) -> &'static str {
        match self {
            PixelType::F16 => "f16",
            PixelType::F32 => "f32",
        }
    }
}

/// The texel (index into a texel file's W×H arrays) shown at pixel (x, image row r).
pub fn texel_at(x: usize, row: usize, width: usize, height: usize) -> usize {
    (height - 1 - row) * width + x
}

/// Per-texel values (texel order: row 0 is v = 0) rearranged into image rows (top first).
pub fn image_rows<T: Copy>(texels: &[T], width: usize, height: usize) -> Vec<T> {
    assert_eq!(texels.len(), width * height, "texel count");
    (0..height)
        .flat_map(|row| (0..width).map(move |x| texels[texel_at(x, row, width, height)]))
        .collect()
}

/// A single-part scan-line EXR (ZIP compression, rows in increasing order so the bytes are
/// deterministic) of `width`×`height` pixels with the named channels, each given in image
/// rows, top first. `path` names the file in errors.
pub fn encode(
    path: &Path,
    width: usize,
    height: usize,
    channels: Vec<(&str, Vec<f32>)>,
    pixel_type: PixelType,
) -> Result<Vec<u8>> {
    let list: Vec<AnyChannel<FlatSamples>> = channels
        .into_iter()
        .map(|(name, samples)| {
            assert_eq!(samples.len(), width * height, "channel {name} size");
            let samples = match pixel_type {
                PixelType::F32 => FlatSamples::F32(samples),
                PixelType::F16 => {
                    FlatSamples::F16(samples.into_iter().map(f16::from_f32).collect())
                }
            };
            AnyChannel::new(name, samples)
        })
        .collect();
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(list)),
    );
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .map_err(|err| Error::io(path, std::io::Error::other(format!("EXR encoding: {err}"))))?;
    Ok(bytes.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_row_zero_is_the_top_texel_row() {
        // 2×3 texels numbered in texel order; the image shows row 2 first.
        let texels = [0, 1, 2, 3, 4, 5];
        assert_eq!(image_rows(&texels, 2, 3), [4, 5, 2, 3, 0, 1]);
        assert_eq!(texel_at(1, 0, 2, 3), 5);
    }

    #[test]
    fn encoded_images_read_back() {
        use exr::prelude::{ReadChannels, ReadLayers};
        let values: Vec<f32> = (0..6).map(|i| i as f32 * 0.25 - 0.5).collect();
        for pixel_type in [PixelType::F32, PixelType::F16] {
            let bytes = encode(
                Path::new("t.exr"),
                3,
                2,
                vec![("Y", values.clone())],
                pixel_type,
            )
            .unwrap();
            let image = exr::prelude::read()
                .no_deep_data()
                .largest_resolution_level()
                .all_channels()
                .first_valid_layer()
                .all_attributes()
                .from_buffered(std::io::Cursor::new(bytes))
                .unwrap();
            let channel = &image.layer_data.channel_data.list[0];
            let read: Vec<f32> = channel.sample_data.values_as_f32().collect();
            assert_eq!(
                read, values,
                "{pixel_type:?} (these values are exact in f16)"
            );
        }
    }
}
