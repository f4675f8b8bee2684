//! Reading back what the PRT vertex shader computes, vertex by vertex, so tests can compare
//! it with the CPU reference (`prt_baker::export::relight::vertex_radiance`).
//!
//! A debug pipeline draws vertex v as a single point at pixel (v mod 256, v div 256) of a
//! 32-bit float target, coloured with `prt_radiance(v)` — the same WGSL function the PRT
//! vertex shader calls — before albedo and tone mapping. Nothing is interpolated (the
//! output is flat) and nothing is rounded to 8 bits, so what comes back is the shader's own
//! f32 result.

use crate::error::Result;
use crate::offscreen::read_texture;
use crate::renderer::Renderer;
use crate::resources::{readable_target, scene_shader};

/// Points per row; `PROBE_WIDTH` in probe.wgsl.
pub const WIDTH: u32 = 256;
const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// Σ_j T_j·L_j per channel for every vertex, as the GPU computes it for the light last given
/// to [`Renderer::update`].
pub fn vertex_radiance(
    renderer: &Renderer,
    device: &wgpu::Device,
    queue: &wgpu::Queue,
) -> Result<Vec<[f32; 3]>> {
    if renderer.is_glossy() {
        return Err(crate::error::Error::InvalidOption(
            "a transfer-matrix bake has no transfer vectors: read it with glossy_vertex_terms"
                .into(),
        ));
    }
    let count = renderer.vertex_count();
    let rows = count.div_ceil(WIDTH).max(1);
    let (target, view) = readable_target(device, "probe", (WIDTH, rows), FORMAT);
    let (frame_layout, frame_bind_group) = renderer.frame_bindings();
    let pipeline = probe_pipeline(device, frame_layout, rows);
    draw_points(device, queue, &pipeline, frame_bind_group, &view, count);
    let bytes = read_texture(device, queue, &target, 16)?;
    // Copied into f32s: the byte vector need not be 4-aligned.
    let texels: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&bytes);
    Ok(texels[..count as usize]
        .iter()
        .map(|[r, g, b, _]| [*r, *g, *b])
        .collect())
}

/// The debug pipeline: probe.wgsl's points, one per vertex, into a `rows`-row float target
/// with no blending, so each texel is exactly one vertex's `prt_radiance`.
fn probe_pipeline(
    device: &wgpu::Device,
    frame_layout: &wgpu::BindGroupLayout,
    rows: u32,
) -> wgpu::RenderPipeline {
    let module = scene_shader(device, "probe", include_str!("shaders/probe.wgsl"));
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("probe"),
        bind_group_layouts: &[Some(frame_layout)],
        immediate_size: 0,
    });
    let constants = [("PROBE_ROWS", f64::from(rows))];
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("probe"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_probe"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &constants,
                zero_initialize_workgroup_memory: false,
            },
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::PointList,
            ..Default::default()
        },
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_probe"),
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

/// Draws the `count` points into `view`, cleared to NaN first, and submits the work.
fn draw_points(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    pipeline: &wgpu::RenderPipeline,
    frame_bind_group: &wgpu::BindGroup,
    view: &wgpu::TextureView,
    count: u32,
) {
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("probe"),
    });
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("probe"),
            color_attachments: &[nan_cleared(view)],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, frame_bind_group, &[]);
        pass.draw(0..count, 0..1);
    }
    queue.submit([encoder.finish()]);
}

/// One vertex's (diffuse, glossy) sums, RGB.
pub type GlossyTerms = ([f32; 3], [f32; 3]);

/// A glossy (transfer-matrix) bake's two per-vertex sums as the glossy vertex shader computes
/// them for the frame last given to [`Renderer::update`] (its camera and light): per vertex,
/// Σ ĝ_l(1) L′ y(n) (the diffuse term per unit albedo, before the diffuse weight) and
/// Σ ĝ_l(s) L′ y(r) (the glossy term before Ks), s the vertex's material's exponent. `None`
/// for a vector bake.
pub fn glossy_vertex_terms(
    renderer: &Renderer,
    device: &wgpu::Device,
    queue: &wgpu::Queue,
) -> Result<Option<Vec<GlossyTerms>>> {
    let Some((vertices, draws, layouts, [frame, glossy])) = renderer.glossy_bindings() else {
        return Ok(None);
    };
    let count = renderer.vertex_count();
    let rows = count.div_ceil(WIDTH).max(1);
    let (diffuse_target, diffuse_view) = readable_target(device, "probe", (WIDTH, rows), FORMAT);
    let (glossy_target, glossy_view) = readable_target(device, "probe", (WIDTH, rows), FORMAT);
    let module = scene_shader(device, "glossy probe", include_str!("shaders/glossy.wgsl"));
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("glossy probe"),
        bind_group_layouts: &layouts.map(Some),
        immediate_size: 0,
    });
    let constants = [("PROBE_ROWS", f64::from(rows))];
    let target = Some(wgpu::ColorTargetState {
        format: FORMAT,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("glossy probe"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_glossy_probe"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &constants,
                zero_initialize_workgroup_memory: false,
            },
            buffers: &[Some(crate::renderer::vertex_layout())],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::PointList,
            ..Default::default()
        },
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_glossy_probe"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &constants,
                zero_initialize_workgroup_memory: false,
            },
            targets: &[target.clone(), target],
        }),
        multiview_mask: None,
        cache: None,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("glossy probe"),
    });
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("glossy probe"),
            color_attachments: &[nan_cleared(&diffuse_view), nan_cleared(&glossy_view)],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, frame, &[]);
        pass.set_bind_group(2, glossy, &[]);
        pass.set_vertex_buffer(0, vertices.slice(..));
        for (range, material) in draws {
            pass.set_bind_group(1, material, &[]);
            pass.draw(range, 0..1);
        }
    }
    queue.submit([encoder.finish()]);
    let read = |target| -> Result<Vec<[f32; 4]>> {
        Ok(bytemuck::pod_collect_to_vec(&read_texture(
            device, queue, target, 16,
        )?))
    };
    let (diffuse, glossy) = (read(&diffuse_target)?, read(&glossy_target)?);
    Ok(Some(
        diffuse
            .iter()
            .zip(&glossy)
            .take(count as usize)
            .map(|([a, b, c, _], [d, e, f, _])| ([*a, *b, *c], [*d, *e, *f]))
            .collect(),
    ))
}

/// A probe target cleared to NaN: a vertex that drew no point reads back as NaN and fails any
/// comparison.
fn nan_cleared(view: &wgpu::TextureView) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(wgpu::Color {
                r: f64::NAN,
                g: f64::NAN,
                b: f64::NAN,
                a: f64::NAN,
            }),
            store: wgpu::StoreOp::Store,
        },
    })
}
