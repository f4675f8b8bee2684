//! A lightmap (texel) bake's radiance map: Σ_j T_j·L_j per texel and channel, computed once
//! per PRT frame by a pass over the lightmap, then sampled per pixel.
//!
//! Shading is linear in the transfer, so dotting each texel with the light and filtering
//! the radiance bilinearly gives the same colour as filtering the transfer per pixel and
//! dotting it (the first version of per-pixel PRT). The light is the same for every pixel,
//! so the dot product per texel is all the per-frame work: each coefficient is read once
//! per texel and frame (W·H·C·⌈n²/4⌉ vec4s) instead of four times per pixel (a bilinear
//! footprint of every layer: 48 loads per pixel for order-4 RGB transfer), and each pixel
//! reads one filtered sample. On lavapipe, which runs the shaders on the CPU, the loads were
//! the cost (docs/explanation/performance.md, "Per-pixel PRT at Blinn-Phong's cost").
//!
//! The cost moves from the screen's pixels to the lightmap's texels: for a 512² lightmap
//! at 1280×720, 262,144 texels against 921,600 pixels, once per frame. A 2048² lightmap has
//! 16 × more texels; its pass then costs about what the per-pixel dot product did.
//!
//! The map is `Rgba16Float`, filterable on every device (32-bit floats need wgpu's
//! `FLOAT32_FILTERABLE`), so a pixel takes one hardware bilinear sample. Half floats keep 11
//! significant bits: the radiance is rounded by less than 2⁻¹⁰ of itself (lavapipe truncates),
//! at most a tenth of an 8-bit display code (tests/lightmap.rs bounds it against `relight`).
//! The transfer it is
//! computed from stays f32 ([`crate::texel_transfer`]), read exactly.

use crate::resources::{scene_shader, texture_2d, texture_entry};
use crate::texel_occluders::{self, TexelOccluders};

/// The radiance map's format.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The radiance map, the pass that fills it and the bind group the scene's PRT pipeline
/// samples it through (group 2).
#[derive(Debug)]
pub struct RadianceMap {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    pipeline: wgpu::RenderPipeline,
    pub layout: wgpu::BindGroupLayout,
    pub bind_group: wgpu::BindGroup,
    transfer_in_buffer: bool,
    /// Moving occluders' pass (texel_occluders.rs), once [`RadianceMap::add_occluders`].
    occluded: Option<(wgpu::RenderPipeline, TexelOccluders)>,
}

impl RadianceMap {
    /// A W×H radiance map, filled from the frame bind group (the transfer, in its buffer if
    /// `transfer_in_buffer`, else its texture array; the light) by [`RadianceMap::encode`].
    pub fn new(
        device: &wgpu::Device,
        frame_layout: &wgpu::BindGroupLayout,
        (width, height): (u32, u32),
        transfer_in_buffer: bool,
    ) -> RadianceMap {
        let texture = texture_2d(
            device,
            "texel radiance",
            (width, height),
            1,
            FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let module = scene_shader(
            device,
            "texel radiance",
            include_str!("shaders/texel_radiance.wgsl"),
        );
        let entry = if transfer_in_buffer {
            "fs_texel_radiance_buffer"
        } else {
            "fs_texel_radiance_array"
        };
        let pipeline = radiance_pipeline(device, &[Some(frame_layout)], &module, entry);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("texel radiance"),
            entries: &[
                texture_entry(0, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        // Bilinear, held at the edge: texel (x, y)'s value at its centre ((x + ½, y + ½)/(W, H)),
        // as the baker's dilated charts expect. One level: no mipmaps yet.
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("texel radiance"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("texel radiance"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Sampler(&sampler),
                },
            ],
        });
        RadianceMap {
            texture,
            view,
            pipeline,
            layout,
            bind_group,
            transfer_in_buffer,
            occluded: None,
        }
    }

    /// Builds the occluded pass for `bake` (this map's lightmap bake); its spheres are set
    /// per frame by [`RadianceMap::set_occluder_spheres`].
    pub fn add_occluders(
        &mut self,
        device: &wgpu::Device,
        frame_layout: &wgpu::BindGroupLayout,
        bake: &crate::bake::Bake,
    ) -> crate::error::Result<()> {
        let occluders = TexelOccluders::new(device, bake)?;
        let source = format!(
            "{}\n{}",
            include_str!("shaders/texel_radiance.wgsl"),
            texel_occluders::shader_source(bake.order(), bake.channels(), self.transfer_in_buffer)
        );
        let module = scene_shader(device, "texel radiance, occluded", &source);
        let layouts = [Some(frame_layout), Some(&occluders.layout)];
        let pipeline = radiance_pipeline(device, &layouts, &module, "fs_texel_radiance_occluded");
        self.occluded = Some((pipeline, occluders));
        Ok(())
    }

    /// This frame's occluder spheres, placed in the scene (none: the plain pass).
    pub fn set_occluder_spheres(
        &mut self,
        queue: &wgpu::Queue,
        spheres: &[prt_baker::math::occlusion::Sphere],
    ) -> crate::error::Result<()> {
        match &mut self.occluded {
            Some((_, occluders)) => occluders.set_spheres(queue, spheres),
            None => Ok(()),
        }
    }

    /// Records the pass that fills the map from the frame's light: one fragment per texel.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder, frame_bind_group: &wgpu::BindGroup) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("texel radiance"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &self.view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    // Every texel is written.
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, frame_bind_group, &[]);
        match &self.occluded {
            Some((pipeline, occluders)) if occluders.count > 0 => {
                pass.set_pipeline(pipeline);
                pass.set_bind_group(1, &occluders.bind_group, &[]);
            }
            _ => pass.set_pipeline(&self.pipeline),
        }
        pass.draw(0..3, 0..1);
    }

    /// The map's texture (tests read it back).
    pub fn texture(&self) -> &wgpu::Texture {
        &self.texture
    }
}

/// The pass's pipeline: one full-screen triangle, fragment `entry` of `module`.
fn radiance_pipeline(
    device: &wgpu::Device,
    layouts: &[Option<&wgpu::BindGroupLayout>],
    module: &wgpu::ShaderModule,
    entry: &str,
) -> wgpu::RenderPipeline {
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("texel radiance"),
        bind_group_layouts: layouts,
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("texel radiance"),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_texel_radiance"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}
