//! Rendering without a display: an offscreen colour target, read back to an image.

use std::path::Path;

use crate::error::{Error, Result};
use crate::renderer::{FrameInputs, Renderer};
use crate::resources::readable_target;

/// The offscreen colour format: 8-bit sRGB, like a window's, so the tone-mapped linear
/// colour is encoded on store exactly as `prt-bake relight` encodes its 8-bit colours.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// A colour target that can be copied back to the CPU.
#[derive(Debug)]
pub struct Offscreen {
    texture: wgpu::Texture,
    pub view: wgpu::TextureView,
}

impl Offscreen {
    pub fn new(device: &wgpu::Device, size: (u32, u32)) -> Offscreen {
        let (texture, view) = readable_target(device, "offscreen", size, FORMAT);
        Offscreen { texture, view }
    }

    /// The target's pixels (sRGB-encoded, as a PNG stores them).
    pub fn read(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<image::RgbaImage> {
        let bytes = read_texture(device, queue, &self.texture, 4)?;
        Ok(
            image::RgbaImage::from_raw(self.texture.width(), self.texture.height(), bytes)
                .expect("the readback holds width × height pixels"),
        )
    }
}

/// Renders one frame into a new offscreen target of the renderer's size and reads it back.
pub fn render_image(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    renderer: &mut Renderer,
    inputs: &FrameInputs,
) -> Result<image::RgbaImage> {
    let target = Offscreen::new(device, renderer.size());
    renderer.update(queue, inputs);
    renderer.render(&target.view, device, queue);
    target.read(device, queue)
}

/// Writes an image as PNG, atomically (a temporary file renamed over `path`), so a failed
/// run never leaves half a screenshot.
pub fn save_png(image: &image::RgbaImage, path: &Path) -> Result<()> {
    save_png_to(image, &prt_baker::support::output::Output::new(path, &[])?)
}

/// As [`save_png`], to an output already checked against the run's inputs.
pub fn save_png_to(
    image: &image::RgbaImage,
    output: &prt_baker::support::output::Output,
) -> Result<()> {
    let path = output.path();
    let mut bytes = Vec::new();
    image
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|source| Error::Image {
            path: path.to_path_buf(),
            source,
        })?;
    output.write(&bytes)?;
    Ok(())
}

/// Copies level 0 of a texture to the CPU, tightly packed (wgpu pads rows to 256 bytes).
pub fn read_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    bytes_per_pixel: u32,
) -> Result<Vec<u8>> {
    let (width, height) = (texture.width(), texture.height());
    let row = width * bytes_per_pixel;
    let padded_row =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: u64::from(padded_row) * u64::from(height),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("readback"),
    });
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded_row),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
    queue.submit([encoder.finish()]);
    let slice = buffer.slice(..);
    let (sender, receiver) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        // The receiver waits below; if it is gone there is nobody to tell.
        let _ = sender.send(result);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|err| Error::Gpu(format!("waiting for the readback: {err}")))?;
    receiver
        .recv()
        .map_err(|_| Error::Gpu("the readback was dropped".into()))?
        .map_err(|err| Error::Gpu(format!("mapping the readback: {err}")))?;
    let mapped = slice
        .get_mapped_range()
        .map_err(|err| Error::Gpu(format!("reading the readback: {err}")))?;
    let mut bytes = Vec::with_capacity((row * height) as usize);
    for padded in mapped.chunks(padded_row as usize) {
        bytes.extend_from_slice(&padded[..row as usize]);
    }
    drop(mapped);
    buffer.unmap();
    Ok(bytes)
}
