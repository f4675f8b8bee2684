//! The on-screen readout: text from the 5×7 font ([`crate::font`]) on a translucent panel in
//! the top-left corner, one instanced quad per character.

use bytemuck::{Pod, Zeroable};

use crate::font;
use crate::resources::{
    PipelineSpec, buffer_binding, pipeline, texture_2d, texture_entry, uniform_buffer,
    uniform_entry, view_binding,
};
use crate::textures;

/// Screen pixels per font pixel, halved below [`DOUBLE_SIZE_WIDTH`] so the readout fits.
const SCALE: f32 = 2.0;
const DOUBLE_SIZE_WIDTH: u32 = 600;
/// Margin around the text, in screen pixels.
const MARGIN: f32 = 8.0;
/// Characters the readout can show in one frame.
const MAX_GLYPHS: usize = 512;

/// `GlyphIn` of overlay.wgsl: one character (or the panel behind them), in pixels.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct GlyphInstance {
    origin: [f32; 2],
    size: [f32; 2],
    glyph: u32,
    colour: [f32; 4],
}

/// `Overlay` of overlay.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct OverlayUniform {
    screen: [f32; 2],
    pad: [f32; 2],
}

/// The readout's pipeline, font atlas and per-frame characters.
#[derive(Debug)]
pub struct Overlay {
    pipeline: wgpu::RenderPipeline,
    uniform: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    glyphs: wgpu::Buffer,
    count: u32,
}

impl Overlay {
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, format: wgpu::TextureFormat) -> Overlay {
        let (width, height, pixels) = font::atlas();
        let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
        let atlas = texture_2d(
            device,
            "font",
            (width, height),
            1,
            wgpu::TextureFormat::R8Unorm,
            usage,
        );
        textures::write_level(queue, &atlas, 0, width, height, &pixels);
        let atlas_view = atlas.create_view(&wgpu::TextureViewDescriptor::default());
        let uniform = uniform_buffer(device, "overlay", std::mem::size_of::<OverlayUniform>());
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("overlay"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::VERTEX),
                texture_entry(1, false),
            ],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("overlay"),
            layout: &layout,
            entries: &[buffer_binding(0, &uniform), view_binding(1, &atlas_view)],
        });
        let glyphs = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("glyphs"),
            size: (MAX_GLYPHS * std::mem::size_of::<GlyphInstance>()) as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("overlay"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shaders/overlay.wgsl").into()),
        });
        let instances = wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<GlyphInstance>() as u64,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &wgpu::vertex_attr_array![0 => Float32x2, 1 => Float32x2, 2 => Uint32, 3 => Float32x4],
        };
        let pipeline = pipeline(
            device,
            PipelineSpec {
                label: "overlay",
                bind_group_layouts: &[Some(&layout)],
                module: &module,
                entry_points: ("vs_glyph", "fs_glyph"),
                buffers: &[Some(instances)],
                topology: wgpu::PrimitiveTopology::TriangleList,
                format,
                depth_test: false,
                cull_mode: None,
                blend: Some(wgpu::BlendState::ALPHA_BLENDING),
            },
        );
        Overlay {
            pipeline,
            uniform,
            bind_group,
            glyphs,
            count: 0,
        }
    }

    /// The text to show (none: nothing) on a target of `size` pixels.
    pub fn update(&mut self, queue: &wgpu::Queue, text: Option<&str>, (w, h): (u32, u32)) {
        let scale = if w >= DOUBLE_SIZE_WIDTH { SCALE } else { 1.0 };
        let glyphs = text.map_or(Vec::new(), |text| glyphs(text, scale));
        queue.write_buffer(&self.glyphs, 0, bytemuck::cast_slice(&glyphs));
        self.count = glyphs.len() as u32;
        let uniform = OverlayUniform {
            screen: [w as f32, h as f32],
            pad: [0.0; 2],
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
    }

    /// Draws the text, if any, into the renderer's pass.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        if self.count > 0 {
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.set_vertex_buffer(0, self.glyphs.slice(..));
            pass.draw(0..6, 0..self.count);
        }
    }
}

/// The characters on a translucent panel, from the top-left corner.
fn glyphs(text: &str, scale: f32) -> Vec<GlyphInstance> {
    let (placed, (w, h)) = font::layout(text);
    let (s, m) = (scale, MARGIN);
    let panel = GlyphInstance {
        origin: [m / 2.0, m / 2.0],
        size: [w as f32 * s + m, h as f32 * s + m],
        glyph: font::glyph(font::SOLID),
        colour: [0.0, 0.0, 0.0, 0.6],
    };
    let cell = [font::GLYPH_WIDTH as f32 * s, font::GLYPH_HEIGHT as f32 * s];
    std::iter::once(panel)
        .chain(placed.iter().map(|p| GlyphInstance {
            origin: [m + p.x as f32 * s, m + p.y as f32 * s],
            size: cell,
            glyph: p.glyph,
            colour: [1.0, 1.0, 1.0, 1.0],
        }))
        .take(MAX_GLYPHS)
        .collect()
}
