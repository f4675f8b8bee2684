//! A lightmap (texel) bake's transfer as a 2D texture array, for the per-pixel PRT shader.
//!
//! Texel (x, y)'s C·n² coefficients (channel c, coefficient j at c·n² + j, as in the file)
//! are packed four per RGBA texel: coefficient i goes to layer i / 4, component i mod 4, at
//! texel (x, y) of that layer, so ⌈C·n²/4⌉ layers hold them all. Row y of every layer is the
//! file's texel row y (row 0 is v = 0, no flip).
//!
//! The format is `Rgba32Float`, read with `textureLoad` and filtered bilinearly by hand in
//! the shader (`prt_radiance_texel` in common.wgsl), not `Rgba16Float` sampled by the
//! hardware: 32-bit floats are only filterable with wgpu's `FLOAT32_FILTERABLE` feature,
//! which GL and some Vulkan devices lack, and half floats (11 significant bits) would round
//! every coefficient by up to 2⁻¹¹ of itself. So at a texel's centre the shader reads the
//! file's coefficients exactly, on any device. The cost is four loads per layer instead of
//! one sample.

use crate::error::{Error, Result};

/// The format of the coefficient texture array.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// How many RGBA layers hold `per_texel` coefficients.
pub fn layer_count(per_texel: usize) -> usize {
    per_texel.div_ceil(4)
}

/// The file's texel-major coefficients (`per_texel` per texel, `texels` texels) packed
/// layer by layer, four per texel: coefficient i of texel p at
/// `((i / 4)·texels + p)·4 + i mod 4`, zero beyond the last.
pub fn pack(coefficients: &[f32], texels: usize, per_texel: usize) -> Vec<f32> {
    assert_eq!(coefficients.len(), texels * per_texel, "the payload's size");
    let layers = layer_count(per_texel);
    let mut packed = vec![0.0f32; layers * texels * 4];
    for (p, texel) in coefficients.chunks_exact(per_texel).enumerate() {
        for (i, &c) in texel.iter().enumerate() {
            packed[((i / 4) * texels + p) * 4 + i % 4] = c;
        }
    }
    packed
}

/// Uploads a W×H lightmap's transfer (`per_texel` coefficients per texel) as a texture
/// array; an error naming the file where the device's texture limits are too small.
pub fn upload(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    file: &std::path::Path,
    (width, height): (u32, u32),
    coefficients: &[f32],
    per_texel: usize,
) -> Result<wgpu::TextureView> {
    let layers = layer_count(per_texel) as u32;
    let limits = device.limits();
    if width.max(height) > limits.max_texture_dimension_2d
        || layers > limits.max_texture_array_layers
    {
        return Err(Error::Device(format!(
            "{}: the {width}×{height} lightmap's transfer takes {layers} texture layers; the device allows {}×{} texels and {} layers",
            file.display(),
            limits.max_texture_dimension_2d,
            limits.max_texture_dimension_2d,
            limits.max_texture_array_layers
        )));
    }
    let texels = (width * height) as usize;
    let packed = pack(coefficients, texels, per_texel);
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
    Ok(view(&texture))
}

/// A 1×1 array of one zero texel: bound in place of the transfer textures for vertex
/// bakes, whose shaders never read it.
pub fn placeholder(device: &wgpu::Device) -> wgpu::TextureView {
    view(&array_texture(device, (1, 1), 1))
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
        let packed = pack(&coefficients, 2, 9);
        assert_eq!(layer_count(9), 3);
        assert_eq!(packed.len(), 3 * 2 * 4);
        // Layer 0: texel 0 holds 1..4, texel 1 holds 10..13.
        assert_eq!(&packed[0..8], &[1.0, 2.0, 3.0, 4.0, 10.0, 11.0, 12.0, 13.0]);
        // Layer 2: coefficient 8 of each texel, then zeros.
        assert_eq!(&packed[16..24], &[9.0, 0.0, 0.0, 0.0, 18.0, 0.0, 0.0, 0.0]);
    }
}
