//! A lightmap (texel) bake's transfer on the device, read once per texel and frame by the
//! pass that fills the radiance map ([`crate::texel_radiance`]).
//!
//! **A storage buffer, texel-major**, where it fits the device's largest storage buffer:
//! texel p's channel c as ⌈n²/4⌉ vec4s from vec4 (p·C + c)·⌈n²/4⌉ (an odd order pads each
//! channel with zeros). A texel's coefficients are then contiguous, and on lavapipe, which
//! runs shaders on the CPU, a pass reading them as vec4s from a buffer ran 1.7 × faster than
//! one reading the texture array below (docs/explanation/performance.md).
//!
//! **A 2D texture array** otherwise (or when asked for, [`TexelStorage::Array`]): the same vec4s packed four coefficients per RGBA texel, vec4 l of channel c
//! at layer c·⌈n²/4⌉ + l, texel (x, y), so C·⌈n²/4⌉ layers; row y of every layer is the
//! file's texel row y (row 0 is v = 0, no flip). The device's texture limits bound it (the
//! viewer asks for the adapter's own; wgpu's defaults allow 8,192² texels and 256 layers).
//!
//! In both, one vec4 holds one channel's four coefficients, so the shader dots it with four
//! coefficients of the light without indexing a vector by a variable, which CPU rasterisers
//! run as scalar code (packing the channels on across vec4s made the RGB pass 3 × slower than
//! the grey one). Both are f32, so the pass reads the file's coefficients exactly.

use wgpu::util::DeviceExt;

use crate::error::{Error, Result};

/// The format of the coefficient texture array.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// Where a texel bake's transfer goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TexelStorage {
    /// The storage buffer where it fits the device's limits (faster), else the texture array.
    Fit,
    /// The texture array (tests compare the two).
    Array,
}

/// How many RGBA layers (or vec4s per texel) hold `channels` channels of `n2` coefficients.
pub fn layer_count(channels: usize, n2: usize) -> usize {
    channels * n2.div_ceil(4)
}

/// The file's texel-major coefficients (`channels`·`n2` per texel, `texels` texels) as the
/// buffer holds them: coefficient (c, j) of texel p at `((p·C + c)·⌈n2/4⌉ + j / 4)·4 + j mod 4`,
/// zero in each channel's padding.
pub fn pack_texel_major(
    coefficients: &[f32],
    texels: usize,
    channels: usize,
    n2: usize,
) -> Vec<f32> {
    assert_eq!(
        coefficients.len(),
        texels * channels * n2,
        "the payload's size"
    );
    let padded = n2.div_ceil(4) * 4;
    let mut packed = vec![0.0f32; texels * channels * padded];
    for (k, channel) in coefficients.chunks_exact(n2).enumerate() {
        packed[k * padded..k * padded + n2].copy_from_slice(channel);
    }
    packed
}

/// The same coefficients as the texture array holds them, layer by layer: coefficient (c, j)
/// of texel p at `((c·⌈n2/4⌉ + j / 4)·texels + p)·4 + j mod 4`.
pub fn pack_layers(coefficients: &[f32], texels: usize, channels: usize, n2: usize) -> Vec<f32> {
    let per_texel = channels * n2;
    assert_eq!(coefficients.len(), texels * per_texel, "the payload's size");
    let per_channel = n2.div_ceil(4);
    let mut packed = vec![0.0f32; layer_count(channels, n2) * texels * 4];
    for (p, texel) in coefficients.chunks_exact(per_texel).enumerate() {
        for (i, &value) in texel.iter().enumerate() {
            let (c, j) = (i / n2, i % n2);
            packed[((c * per_channel + j / 4) * texels + p) * 4 + j % 4] = value;
        }
    }
    packed
}

/// A texel bake's transfer as uploaded: the buffer or the array holds it, the other is a
/// placeholder (a binding cannot be empty).
#[derive(Debug)]
pub struct TexelTransfer {
    pub buffer: wgpu::Buffer,
    pub array: wgpu::TextureView,
    /// Whether the buffer holds it.
    pub in_buffer: bool,
}

impl TexelTransfer {
    /// Placeholders only: a vertex bake's, whose shaders never read them.
    pub fn placeholder(device: &wgpu::Device) -> TexelTransfer {
        TexelTransfer {
            buffer: placeholder_buffer(device),
            array: view(&array_texture(device, (1, 1), 1)),
            in_buffer: false,
        }
    }

    /// Uploads a W×H lightmap's transfer (`channels` channels of `n2` coefficients per
    /// texel): to the buffer where it fits and `storage` allows, else to the texture array;
    /// an error naming the file where neither fits the device's limits.
    pub fn upload(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        file: &std::path::Path,
        (width, height): (u32, u32),
        coefficients: &[f32],
        (channels, n2): (usize, usize),
        storage: TexelStorage,
    ) -> Result<TexelTransfer> {
        let texels = (width * height) as usize;
        let layers = layer_count(channels, n2);
        let limits = device.limits();
        let buffer_limit = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let bytes = (texels * layers * 16) as u64;
        if bytes <= buffer_limit && storage == TexelStorage::Fit {
            let packed = pack_texel_major(coefficients, texels, channels, n2);
            let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("texel transfer"),
                contents: bytemuck::cast_slice(&packed),
                usage: wgpu::BufferUsages::STORAGE,
            });
            return Ok(TexelTransfer {
                buffer,
                array: view(&array_texture(device, (1, 1), 1)),
                in_buffer: true,
            });
        }
        let layers = layers as u32;
        if width.max(height) > limits.max_texture_dimension_2d
            || layers > limits.max_texture_array_layers
        {
            return Err(Error::Device(format!(
                "{}: the {width}×{height} lightmap's transfer takes {bytes} bytes or {layers} texture layers; the device allows a {buffer_limit}-byte storage buffer, {}×{} texels and {} layers",
                file.display(),
                limits.max_texture_dimension_2d,
                limits.max_texture_dimension_2d,
                limits.max_texture_array_layers
            )));
        }
        let packed = pack_layers(coefficients, texels, channels, n2);
        let texture = array_texture(device, (width, height), layers);
        queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&packed),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(width * 16),
                rows_per_image: Some(height),
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: layers,
            },
        );
        Ok(TexelTransfer {
            buffer: placeholder_buffer(device),
            array: view(&texture),
            in_buffer: false,
        })
    }
}

fn placeholder_buffer(device: &wgpu::Device) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("texel transfer placeholder"),
        contents: &[0u8; 16],
        usage: wgpu::BufferUsages::STORAGE,
    })
}

fn array_texture(device: &wgpu::Device, (width, height): (u32, u32), layers: u32) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("texel transfer"),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: layers,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

fn view(texture: &wgpu::Texture) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coefficients_go_four_per_texel_layer_by_layer() {
        // Two texels of 9 coefficients (order 3, grey): 3 layers, the last holding one.
        let coefficients: Vec<f32> = (0..18).map(|i| i as f32 + 1.0).collect();
        let packed = pack_layers(&coefficients, 2, 1, 9);
        assert_eq!(layer_count(1, 9), 3);
        assert_eq!(packed.len(), 3 * 2 * 4);
        // Layer 0: texel 0 holds 1..4, texel 1 holds 10..13.
        assert_eq!(&packed[0..8], &[1.0, 2.0, 3.0, 4.0, 10.0, 11.0, 12.0, 13.0]);
        // Layer 2: coefficient 8 of each texel, then zeros.
        assert_eq!(&packed[16..24], &[9.0, 0.0, 0.0, 0.0, 18.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn each_channel_starts_a_layer() {
        // One texel, RGB, order 3: channel c's 9 coefficients 100c + 1..=9 fill layers
        // 3c..3c + 2, the last of them padded with zeros.
        let coefficients: Vec<f32> = (0..3)
            .flat_map(|c| (1..=9).map(move |j| (100 * c + j) as f32))
            .collect();
        // With one texel the two layouts coincide.
        for packed in [
            pack_layers(&coefficients, 1, 3, 9),
            pack_texel_major(&coefficients, 1, 3, 9),
        ] {
            assert_eq!(layer_count(3, 9), 9);
            assert_eq!(packed.len(), 9 * 4);
            assert_eq!(&packed[0..4], &[1.0, 2.0, 3.0, 4.0]);
            assert_eq!(&packed[8..12], &[9.0, 0.0, 0.0, 0.0]);
            assert_eq!(&packed[12..16], &[101.0, 102.0, 103.0, 104.0]);
            assert_eq!(&packed[32..36], &[209.0, 0.0, 0.0, 0.0]);
        }
    }

    #[test]
    fn the_buffer_holds_each_texel_s_coefficients_together() {
        // Two texels, grey, order 2 (4 coefficients): one vec4 each, texel after texel.
        let coefficients: Vec<f32> = (1..=8).map(|i| i as f32).collect();
        assert_eq!(pack_texel_major(&coefficients, 2, 1, 4), coefficients);
        // The array puts them layer by layer: the same here (one layer).
        assert_eq!(pack_layers(&coefficients, 2, 1, 4), coefficients);
        // Order 3 grey: 9 coefficients, 3 vec4s per texel, the third padded.
        let coefficients: Vec<f32> = (1..=18).map(|i| i as f32).collect();
        let packed = pack_texel_major(&coefficients, 2, 1, 9);
        assert_eq!(
            &packed[8..16],
            &[9.0, 0.0, 0.0, 0.0, 10.0, 11.0, 12.0, 13.0]
        );
    }
}
