//! Albedo textures on the GPU: the scene's sRGB8 pixels as `Rgba8UnormSrgb` (so sampling
//! decodes to linear, as the baker's lookup does), with a mip chain.
//!
//! The baker samples bilinearly at one level because it only looks textures up at vertices.
//! A rasteriser minifies them, and without mipmaps the checkered floor aliases into moiré
//! that moves with every step of the camera (and differs between rasterisers, which the
//! golden-image tests would feel). The levels are box-filtered in linear light on the CPU.

use prt_baker::export::relight::display_colour;
use prt_baker::scene::{Texture, srgb_to_linear};

use crate::resources::texture_2d;

/// The mip chain of a texture: level 0 is its pixels; each next level halves both sides
/// (rounding down, at least 1), averaging up to 2×2 texels in linear light.
pub fn mip_chain(texture: &Texture) -> Vec<(u32, u32, Vec<[u8; 4]>)> {
    let mut levels = vec![(texture.width, texture.height, texture.srgb8.clone())];
    loop {
        let (w, h, pixels) = levels.last().expect("level 0");
        if *w == 1 && *h == 1 {
            return levels;
        }
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let texel = |x: u32, y: u32| pixels[(y.min(h - 1) * w + x.min(w - 1)) as usize];
        let mut next = Vec::with_capacity((nw * nh) as usize);
        for y in 0..nh {
            for x in 0..nw {
                let quad = [
                    texel(2 * x, 2 * y),
                    texel(2 * x + 1, 2 * y),
                    texel(2 * x, 2 * y + 1),
                    texel(2 * x + 1, 2 * y + 1),
                ];
                let mean = |c: usize| {
                    quad.iter()
                        .map(|p| srgb_to_linear(f32::from(p[c]) / 255.0))
                        .sum::<f32>()
                        / 4.0
                };
                let [r, g, b] = display_colour([mean(0), mean(1), mean(2)], 0.0);
                let alpha = quad
                    .iter()
                    .map(|p| u32::from(p[3]))
                    .sum::<u32>()
                    .div_ceil(4);
                next.push([r, g, b, alpha as u8]);
            }
        }
        levels.push((nw, nh, next));
    }
}

/// Uploads a texture and its mip chain.
pub fn upload(device: &wgpu::Device, queue: &wgpu::Queue, texture: &Texture) -> wgpu::TextureView {
    upload_as(device, queue, texture, wgpu::TextureFormat::Rgba8UnormSrgb)
}

/// Uploads a texture of data (an OBJ `map_d` coverage image, whose grey is not sRGB colour)
/// and its mip chain: sampling returns the bytes / 255.
pub fn upload_data(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &Texture,
) -> wgpu::TextureView {
    upload_as(device, queue, texture, wgpu::TextureFormat::Rgba8Unorm)
}

fn upload_as(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &Texture,
    format: wgpu::TextureFormat,
) -> wgpu::TextureView {
    let levels = mip_chain(texture);
    let gpu = texture_2d(
        device,
        "albedo",
        (texture.width, texture.height),
        levels.len() as u32,
        format,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
    );
    for (level, (w, h, pixels)) in levels.iter().enumerate() {
        write_level(
            queue,
            &gpu,
            level as u32,
            *w,
            *h,
            bytemuck::cast_slice(pixels),
        );
    }
    gpu.create_view(&wgpu::TextureViewDescriptor::default())
}

/// A 1×1 white texture, bound where a material has none.
pub fn white(device: &wgpu::Device, queue: &wgpu::Queue) -> wgpu::TextureView {
    let white = Texture {
        path: "white".into(),
        width: 1,
        height: 1,
        srgb8: vec![[255; 4]],
    };
    upload(device, queue, &white)
}

/// Writes one level of tightly packed RGBA8 (or R8, by `bytes.len()`) texels.
pub fn write_level(
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    level: u32,
    width: u32,
    height: u32,
    bytes: &[u8],
) {
    let bytes_per_pixel = bytes.len() as u32 / (width * height);
    queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: level,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        bytes,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(width * bytes_per_pixel),
            rows_per_image: Some(height),
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mips_average_in_linear_light_down_to_one_texel() {
        // 4×2 of black and white columns: every level-1 texel mixes one black and one white
        // column, linear 0.5, which sRGB encodes as 188.
        let pixels = (0..8)
            .map(|i| if i % 2 == 0 { [0, 0, 0, 255] } else { [255; 4] })
            .collect();
        let texture = Texture {
            path: "t".into(),
            width: 4,
            height: 2,
            srgb8: pixels,
        };
        let levels = mip_chain(&texture);
        let sizes: Vec<_> = levels.iter().map(|(w, h, _)| (*w, *h)).collect();
        assert_eq!(sizes, [(4, 2), (2, 1), (1, 1)]);
        assert_eq!(levels[1].2, vec![[188, 188, 188, 255]; 2]);
        assert_eq!(levels[2].2, vec![[188, 188, 188, 255]]);
    }
}
