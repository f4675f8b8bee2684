//! The renderer: `new` / `resize` / `update` / `render(&TextureView, &Device, &Queue)`.
//!
//! One vertex buffer (position, normal, uv, lightmap uv) and one index buffer hold the scene;
//! the coefficient file's payload goes to a storage buffer unchanged, and the summed light
//! (n² × RGB) to another, which the PRT vertex shader reads by vertex index. Each object is
//! drawn with its material's bind group (Kd, texture). Normals, light vectors and the
//! readout are drawn on top.
//!
//! A lightmap (texel) bake instead puts its transfer in a texture array
//! ([`crate::texel_transfer`]); each PRT frame first dots every texel with the same light
//! buffer into a radiance map ([`crate::texel_radiance`]), which the PRT fragment shader
//! samples at the fragment's lightmap uv. Its lightmap UVs are per triangle corner, so the
//! vertex buffer then holds one vertex per corner (indices 0, 1, 2, …), and objects are drawn
//! by the same triangle ranges.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};
use prt_baker::light::LightCoefficients;
use prt_baker::math::occlusion::Sphere;
use wgpu::util::DeviceExt;

use crate::bake::Bake;
use crate::camera::Camera;
use crate::controls::{Mode, View};
use crate::error::{Error, Result};
use crate::glossy::GlossyResources;
use crate::lights::{MAX_LIGHTS, PhongLights, PhongShape};
use crate::materials::materials;
use crate::overlay::Overlay;
use crate::probe_scene::ProbeScene;
use crate::resources::{
    DEPTH_FORMAT, PipelineSpec, buffer_binding, pipeline, scene_shader, storage_entry, texture_2d,
    uniform_buffer, uniform_entry, view_binding,
};
use crate::texel_radiance::RadianceMap;
use crate::texel_transfer::{TexelStorage, TexelTransfer};

/// Behind the scene: a dark grey, linear.
const BACKGROUND: wgpu::Color = wgpu::Color {
    r: 0.02,
    g: 0.02,
    b: 0.025,
    a: 1.0,
};
/// Drawn normals, as a fraction of the scene's radius.
const NORMAL_LENGTH: f32 = 0.03;
/// Light vectors the renderer has room for (one line each).
const LIGHT_VECTOR_CAPACITY: usize = 64;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Vertex {
    position: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
    /// Lightmap uv (texel bakes; zero for vertex bakes).
    uv1: [f32; 2],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct LineVertex {
    position: [f32; 3],
    colour: [f32; 4],
}

/// `PhongLight` of common.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct PhongLightUniform {
    direction: [f32; 4],
    colour: [f32; 4],
    ground: [f32; 4],
}

/// `Frame` of common.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct FrameUniform {
    view_projection: [[f32; 4]; 4],
    camera_position: [f32; 4],
    coefficient_count: u32,
    channels: u32,
    use_textures: u32,
    exposure_scale: f32,
    light_count: u32,
    /// A texel bake's lightmap width (the radiance pass's texel index is y·W + x).
    lightmap_width: u32,
    pad: [u32; 2],
    ambient: [f32; 4],
    lights: [PhongLightUniform; MAX_LIGHTS],
}

/// Everything one frame shows, taken from a [`View`] (or built by a test).
#[derive(Clone, Debug)]
pub struct FrameInputs {
    pub camera: Camera,
    pub mode: Mode,
    pub textures: bool,
    pub normals: bool,
    pub light_vectors: bool,
    /// Exposure in stops.
    pub exposure: f32,
    /// PRT's light: the summed, rotated coefficients (of the bake's order).
    pub prt_light: LightCoefficients,
    pub phong: PhongLights,
    /// Light vectors to draw: direction, colour, whether it is the active light.
    pub light_lines: Vec<(Vec3, Vec3, bool)>,
    /// Text drawn in the top-left corner.
    pub readout: Option<String>,
}

impl FrameInputs {
    /// The frame of a view; `readout` is drawn over it if given.
    pub fn from_view(view: &View, readout: Option<String>) -> FrameInputs {
        FrameInputs {
            camera: view.camera,
            mode: view.mode,
            textures: view.textures,
            normals: view.normals,
            light_vectors: view.light_vectors,
            exposure: view.exposure,
            prt_light: view.lights.prt(),
            phong: view.lights.phong(),
            light_lines: view
                .lights
                .iter()
                .enumerate()
                .filter(|(_, l)| l.is_directed())
                .map(|(i, l)| (l.direction(), l.display_colour(), i == view.active_light))
                .collect(),
            readout,
        }
    }
}

/// One draw call: an object's triangles and its material.
#[derive(Clone, Debug)]
struct Draw {
    indices: Range<u32>,
    material: usize,
    /// A back sheet or the front it twins: drawn with back faces culled.
    one_sided: bool,
}

/// The scene on the GPU and the pipelines that draw it.
#[derive(Debug)]
pub struct Renderer {
    format: wgpu::TextureFormat,
    size: (u32, u32),
    depth: wgpu::TextureView,
    order: usize,
    channels: usize,
    lightmap_width: u32,
    vertex_count: u32,
    centre: Vec3,
    radius: f32,

    frame_layout: wgpu::BindGroupLayout,
    frame_buffer: wgpu::Buffer,
    light_buffer: wgpu::Buffer,
    /// A vertex bake's transfer (rewritten per frame under a mover's shadow).
    transfer: wgpu::Buffer,
    frame_bind_group: wgpu::BindGroup,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    draws: Vec<Draw>,
    /// Each object's vertex range and material (the glossy probe draws vertices as points).
    vertex_draws: Vec<(Range<u32>, usize)>,
    materials: Vec<wgpu::BindGroup>,
    material_layout: wgpu::BindGroupLayout,
    /// The PRT pipeline: diffuse PRT, per texel for a lightmap bake, or glossy PRT for a
    /// transfer-matrix bake.
    prt: wgpu::RenderPipeline,
    /// A transfer-matrix bake's glossy resources (group 2 of the PRT pipeline).
    glossy: Option<GlossyResources>,
    phong: wgpu::RenderPipeline,
    /// `prt` and `phong` with back faces culled, where the scene has two-sheet surfaces.
    culled: Option<(wgpu::RenderPipeline, wgpu::RenderPipeline)>,
    /// A texel bake's radiance map, refilled before every PRT frame.
    texel_radiance: Option<RadianceMap>,

    normal_lines: wgpu::Buffer,
    light_lines: wgpu::Buffer,
    light_line_vertices: u32,
    lines_depth_tested: wgpu::RenderPipeline,
    lines_on_top: wgpu::RenderPipeline,

    overlay: Overlay,

    mode: Mode,
    normals: bool,
    light_vectors: bool,
    /// Transfer probes and a moving object lit by them (`--probes`, `--mover`).
    probe_scene: Option<ProbeScene>,
    /// The mover's shadow on a vertex bake (`--mover-occluder`, occluders.rs).
    mover_shadow: Option<crate::occluders::MoverShadow>,
}

impl Renderer {
    /// Uploads the scene and its transfer and builds the pipelines for a colour target of
    /// `format` (an sRGB format, so the tone-mapped linear colour is encoded on store) and
    /// `size` in pixels.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        bake: &Bake,
        format: wgpu::TextureFormat,
        size: (u32, u32),
    ) -> Result<Renderer> {
        Renderer::with_texel_storage(device, queue, bake, format, size, TexelStorage::Fit)
    }

    /// As [`Renderer::new`], with a texel bake's transfer stored as `storage` asks.
    pub fn with_texel_storage(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        bake: &Bake,
        format: wgpu::TextureFormat,
        size: (u32, u32),
        storage: TexelStorage,
    ) -> Result<Renderer> {
        let scene = &bake.scene;
        let glossy = if bake.is_matrix() {
            Some(GlossyResources::new(device, bake)?)
        } else {
            None
        };
        // A compressed matrix bake is drawn from its clusters, not its reconstruction.
        let upload_transfer = glossy.as_ref().is_none_or(GlossyResources::needs_matrices);
        if upload_transfer {
            check_transfer_size(device, bake)?;
        }
        let (vertices, indices) = mesh_buffers(device, bake);
        let frame = FrameResources::new(device, queue, bake, storage, upload_transfer)?;
        let (material_layout, materials) = materials(device, queue, scene, bake.order());
        let twinned: Vec<usize> = scene
            .back_sheets
            .fronts
            .iter()
            .map(|&f| f as usize)
            .collect();
        let draws: Vec<Draw> = scene
            .objects
            .iter()
            .enumerate()
            .filter(|(_, o)| !o.triangles.is_empty())
            .map(|(k, o)| Draw {
                indices: 3 * o.triangles.start..3 * o.triangles.end,
                material: scene.vertex_material[o.vertices.start as usize] as usize,
                one_sided: scene.front_of(k).is_some() || twinned.contains(&k),
            })
            .collect();
        let texel_radiance = bake.lightmap().map(|l| {
            let size = (l.width, l.height);
            RadianceMap::new(device, &frame.layout, size, frame.texel_transfer_in_buffer)
        });
        let vertex_draws = scene
            .objects
            .iter()
            .filter(|o| !o.vertices.is_empty())
            .map(|o| {
                let material = scene.vertex_material[o.vertices.start as usize] as usize;
                (o.vertices.start..o.vertices.end, material)
            })
            .collect();
        let layouts = [&frame.layout, &material_layout];
        let group_2 = match (&texel_radiance, &glossy) {
            (Some(r), _) => Group2::TexelRadiance(&r.layout),
            (None, Some(g)) => Group2::Glossy(&g.layout),
            (None, None) => Group2::None,
        };
        let (prt, phong) = scene_pipelines(device, layouts, format, group_2, None);
        // The sheets of two-sheet surfaces (glTF doubleSided back sheets and their fronts)
        // each show their own side's transfer: drawn with back faces culled.
        let one_sided = draws.iter().any(|d: &Draw| d.one_sided);
        let culled = one_sided
            .then(|| scene_pipelines(device, layouts, format, group_2, Some(wgpu::Face::Back)));
        let (centre, radius) = {
            let (lo, hi) = scene.bounds();
            (0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(1e-6))
        };
        let lines = LineResources::new(device, &frame.layout, format, bake, radius);
        Ok(Renderer {
            format,
            size,
            depth: depth_view(device, size),
            order: bake.order(),
            channels: bake.channels(),
            lightmap_width: bake.lightmap().map_or(0, |l| l.width),
            vertex_count: scene.vertex_count() as u32,
            centre,
            radius,
            frame_layout: frame.layout,
            frame_buffer: frame.frame_buffer,
            light_buffer: frame.light_buffer,
            transfer: frame.transfer,
            frame_bind_group: frame.bind_group,
            vertices,
            indices,
            draws,
            vertex_draws,
            materials,
            material_layout,
            prt,
            glossy,
            phong,
            culled,
            texel_radiance,
            normal_lines: lines.normals,
            light_lines: lines.light_vectors,
            light_line_vertices: 0,
            lines_depth_tested: lines.depth_tested,
            lines_on_top: lines.on_top,
            overlay: Overlay::new(device, queue, format),
            mode: Mode::Prt,
            normals: false,
            light_vectors: false,
            probe_scene: None,
            mover_shadow: None,
        })
    }

    /// Shows transfer probes and, if given, an object moving through them (probe_scene.rs);
    /// both of the bake's order.
    pub fn set_probe_scene(
        &mut self,
        device: &wgpu::Device,
        probes: crate::moving::Probes,
        mover: Option<crate::moving::Mover>,
    ) -> Result<()> {
        self.probe_scene = Some(ProbeScene::new(
            device,
            (&self.frame_layout, self.format),
            self.order,
            probes,
            mover,
        )?);
        Ok(())
    }

    /// A skinned character walking through the probe scene (`set_probe_scene` first).
    pub fn set_walker(
        &mut self,
        device: &wgpu::Device,
        walker: crate::skinned::Skinned,
    ) -> Result<()> {
        match &mut self.probe_scene {
            Some(scene) => scene.set_walker(device, walker),
            None => Err(Error::InvalidOption(
                "a character walks through transfer probes: give --probes".into(),
            )),
        }
    }

    /// Darkens the scene where the probe scene's mover stands, each frame (occluders.rs):
    /// `bake` is this renderer's, whose lightmap (if any) gets the occluded radiance pass.
    pub fn set_mover_shadow(
        &mut self,
        device: &wgpu::Device,
        bake: &Bake,
        shadow: crate::occluders::MoverShadow,
    ) -> Result<()> {
        self.add_occluders(device, bake)?;
        self.mover_shadow = Some(shadow);
        Ok(())
    }

    /// Readies a lightmap bake's radiance pass for occluder spheres (texel_occluders.rs);
    /// nothing for a vertex bake.
    pub fn add_occluders(&mut self, device: &wgpu::Device, bake: &Bake) -> Result<()> {
        match &mut self.texel_radiance {
            Some(radiance) => radiance.add_occluders(device, &self.frame_layout, bake),
            None => Ok(()),
        }
    }

    /// Shadows a lightmap bake with `spheres` (placed in the scene) from the next frame on;
    /// a vertex bake's shadow is its transfer, rewritten by [`Renderer::set_transfer`].
    pub fn set_occluder_spheres(&mut self, queue: &wgpu::Queue, spheres: &[Sphere]) -> Result<()> {
        match &mut self.texel_radiance {
            Some(radiance) => radiance.set_occluder_spheres(queue, spheres),
            None => Ok(()),
        }
    }

    /// Replaces a vertex bake's transfer (as the file holds it) from the next frame on.
    pub fn set_transfer(&self, queue: &wgpu::Queue, transfer: &[f32]) {
        queue.write_buffer(&self.transfer, 0, bytemuck::cast_slice(transfer));
    }

    /// Replaces a vertex bake's positions and normals (a posed skinned mesh, in the viewer's
    /// z-up frame; its UVs are `scene`'s) from the next frame on.
    pub fn set_vertices(&self, queue: &wgpu::Queue, scene: &prt_baker::Scene) {
        let vertices: Vec<Vertex> = (0..scene.vertex_count())
            .map(|v| Vertex {
                position: scene.positions[v].to_array(),
                normal: scene.normals[v].to_array(),
                uv: scene.uvs[v].to_array(),
                uv1: [0.0; 2],
            })
            .collect();
        queue.write_buffer(&self.vertices, 0, bytemuck::cast_slice(&vertices));
    }

    pub fn probe_scene(&self) -> Option<&ProbeScene> {
        self.probe_scene.as_ref()
    }

    pub fn probe_scene_mut(&mut self) -> Option<&mut ProbeScene> {
        self.probe_scene.as_mut()
    }

    /// The colour format the pipelines write.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// The target size in pixels.
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// A new target size: recreates the depth buffer.
    pub fn resize(&mut self, device: &wgpu::Device, size: (u32, u32)) {
        if size != self.size {
            self.size = size;
            self.depth = depth_view(device, size);
        }
    }

    /// Uploads one frame's camera, lights, toggles and readout.
    pub fn update(&mut self, queue: &wgpu::Queue, inputs: &FrameInputs) {
        assert_eq!(
            inputs.prt_light.order(),
            self.order,
            "the light's order must be the transfer's"
        );
        let (w, h) = self.size;
        let aspect = w as f32 / h.max(1) as f32;
        let mut lights = [PhongLightUniform::default(); MAX_LIGHTS];
        for (uniform, light) in lights.iter_mut().zip(&inputs.phong.lights) {
            let (kind, colour, ground) = match light.shape {
                PhongShape::Directional { irradiance } => (0.0, irradiance, Vec3::ZERO),
                PhongShape::Hemisphere { sky, ground } => (1.0, sky, ground),
                PhongShape::Ambient { radiance } => (0.0, radiance, Vec3::ZERO),
            };
            *uniform = PhongLightUniform {
                direction: light.direction.extend(kind).to_array(),
                colour: colour.extend(0.0).to_array(),
                ground: ground.extend(0.0).to_array(),
            };
        }
        let frame = FrameUniform {
            view_projection: inputs.camera.view_projection(aspect).to_cols_array_2d(),
            camera_position: inputs.camera.position.extend(1.0).to_array(),
            coefficient_count: (self.order * self.order) as u32,
            channels: self.channels as u32,
            use_textures: u32::from(inputs.textures),
            exposure_scale: inputs.exposure.exp2(),
            light_count: inputs.phong.lights.len().min(MAX_LIGHTS) as u32,
            lightmap_width: self.lightmap_width,
            pad: [0; 2],
            ambient: inputs.phong.ambient.extend(0.0).to_array(),
            lights,
        };
        queue.write_buffer(&self.frame_buffer, 0, bytemuck::bytes_of(&frame));
        queue.write_buffer(
            &self.light_buffer,
            0,
            bytemuck::cast_slice(&light_vectors(&inputs.prt_light)),
        );
        if let (Mode::Prt, Some(glossy)) = (inputs.mode, &self.glossy) {
            glossy.update(queue, &inputs.prt_light);
        }
        if let Some(probes) = &self.probe_scene {
            probes.update(queue, &inputs.prt_light);
            if let (Some(shadow), Some(placement)) = (&self.mover_shadow, probes.placement()) {
                let spheres = shadow.spheres(placement);
                match &mut self.texel_radiance {
                    Some(radiance) => radiance
                        .set_occluder_spheres(queue, &spheres)
                        .expect("MoverShadow::new checked the sphere count"),
                    None => queue.write_buffer(
                        &self.transfer,
                        0,
                        bytemuck::cast_slice(&shadow.transfer_for(&spheres)),
                    ),
                }
            }
        }

        let lines: Vec<LineVertex> = inputs
            .light_lines
            .iter()
            .take(LIGHT_VECTOR_CAPACITY)
            .flat_map(|(direction, colour, active)| {
                let colour = if *active {
                    Vec4::new(1.0, 1.0, 0.0, 1.0)
                } else {
                    colour.extend(1.0)
                };
                [self.centre, self.centre + *direction * self.radius].map(|p| LineVertex {
                    position: p.to_array(),
                    colour: colour.to_array(),
                })
            })
            .collect();
        queue.write_buffer(&self.light_lines, 0, bytemuck::cast_slice(&lines));
        self.light_line_vertices = lines.len() as u32;

        self.overlay
            .update(queue, inputs.readout.as_deref(), self.size);

        self.mode = inputs.mode;
        self.normals = inputs.normals;
        self.light_vectors = inputs.light_vectors;
    }

    /// Draws the frame last given to [`Renderer::update`] into `target` (of the renderer's
    /// format and size) and submits it.
    pub fn render(&self, target: &wgpu::TextureView, device: &wgpu::Device, queue: &wgpu::Queue) {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame"),
        });
        if let (Mode::Prt, Some(radiance)) = (self.mode, &self.texel_radiance) {
            radiance.encode(&mut encoder, &self.frame_bind_group);
        }
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("frame"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(BACKGROUND),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            let pipeline = |one_sided: bool| {
                let (prt, phong) = match (one_sided, &self.culled) {
                    (true, Some((prt, phong))) => (prt, phong),
                    _ => (&self.prt, &self.phong),
                };
                match self.mode {
                    Mode::Prt => prt,
                    Mode::Phong => phong,
                }
            };
            pass.set_pipeline(pipeline(false));
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            if let (Mode::Prt, Some(radiance)) = (self.mode, &self.texel_radiance) {
                pass.set_bind_group(2, &radiance.bind_group, &[]);
            }
            if let (Mode::Prt, Some(glossy)) = (self.mode, &self.glossy) {
                pass.set_bind_group(2, &glossy.bind_group, &[]);
            }
            pass.set_vertex_buffer(0, self.vertices.slice(..));
            pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
            for draw in &self.draws {
                if self.culled.is_some() {
                    pass.set_pipeline(pipeline(draw.one_sided));
                }
                pass.set_bind_group(1, &self.materials[draw.material], &[]);
                pass.draw_indexed(draw.indices.clone(), 0, 0..1);
            }
            if let Some(probes) = &self.probe_scene {
                probes.draw(&mut pass, &self.frame_bind_group);
            }
            if self.normals {
                pass.set_pipeline(&self.lines_depth_tested);
                pass.set_vertex_buffer(0, self.normal_lines.slice(..));
                pass.draw(0..2 * self.vertex_count, 0..1);
            }
            if self.light_vectors && self.light_line_vertices > 0 {
                pass.set_pipeline(&self.lines_on_top);
                pass.set_vertex_buffer(0, self.light_lines.slice(..));
                pass.draw(0..self.light_line_vertices, 0..1);
            }
            self.overlay.draw(&mut pass);
        }
        queue.submit([encoder.finish()]);
    }

    /// The frame bind group's layout and the bind group (transfer, light, frame uniform), for
    /// the probe.
    pub(crate) fn frame_bindings(&self) -> (&wgpu::BindGroupLayout, &wgpu::BindGroup) {
        (&self.frame_layout, &self.frame_bind_group)
    }

    pub fn vertex_count(&self) -> u32 {
        self.vertex_count
    }

    /// Whether the bake is a transfer-matrix bake, shown as glossy PRT.
    pub fn is_glossy(&self) -> bool {
        self.glossy.is_some()
    }

    /// What the glossy probe draws with: the vertex buffer, each object's vertex range and
    /// material bind group, and the bind group layouts of groups 0–2 with their groups 0 and
    /// 2 (None for a vector bake).
    #[allow(clippy::type_complexity)]
    pub(crate) fn glossy_bindings(
        &self,
    ) -> Option<(
        &wgpu::Buffer,
        Vec<(Range<u32>, &wgpu::BindGroup)>,
        [&wgpu::BindGroupLayout; 3],
        [&wgpu::BindGroup; 2],
    )> {
        let glossy = self.glossy.as_ref()?;
        let draws = self
            .vertex_draws
            .iter()
            .map(|(range, m)| (range.clone(), &self.materials[*m]))
            .collect();
        Some((
            &self.vertices,
            draws,
            [&self.frame_layout, &self.material_layout, &glossy.layout],
            [&self.frame_bind_group, &glossy.bind_group],
        ))
    }

    /// A texel bake's radiance map as the last PRT frame left it (None for vertex bakes).
    pub fn texel_radiance(&self) -> Option<&wgpu::Texture> {
        self.texel_radiance.as_ref().map(RadianceMap::texture)
    }
}

/// Refuses a vertex bake whose transfer does not fit in the device's largest storage buffer.
fn check_transfer_size(device: &wgpu::Device, bake: &Bake) -> Result<()> {
    let lightmap = bake.lightmap();
    let transfer_bytes = match lightmap {
        Some(_) => 0,
        None => std::mem::size_of_val(bake.file.coefficients.as_slice()) as u64,
    };
    let limits = device.limits();
    let limit = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    if transfer_bytes > limit {
        return Err(Error::Device(format!(
            "{}: the transfer takes {transfer_bytes} bytes, more than the device's largest storage buffer ({limit} bytes)",
            bake.file_path.display()
        )));
    }

    Ok(())
}

/// The scene's vertices and indices; a texel bake's are split per triangle corner, each
/// with its lightmap UV.
fn mesh_buffers(device: &wgpu::Device, bake: &Bake) -> (wgpu::Buffer, wgpu::Buffer) {
    let scene = &bake.scene;
    let lightmap = bake.lightmap();
    let vertex = |v: usize, uv1: glam::Vec2| Vertex {
        position: scene.positions[v].to_array(),
        normal: scene.normals[v].to_array(),
        uv: scene.uvs[v].to_array(),
        uv1: uv1.to_array(),
    };
    let (vertices, indices): (Vec<Vertex>, Vec<u32>) = match lightmap {
        None => (
            (0..scene.vertex_count())
                .map(|v| vertex(v, glam::Vec2::ZERO))
                .collect(),
            scene.triangles.iter().flatten().copied().collect(),
        ),
        Some(l) => (
            scene
                .triangles
                .iter()
                .zip(&l.uv1)
                .flat_map(|(t, uv1)| (0..3).map(move |k| (t[k] as usize, uv1[k])))
                .map(|(v, uv1)| vertex(v, uv1))
                .collect(),
            (0..3 * scene.triangles.len() as u32).collect(),
        ),
    };
    // COPY_DST: a skinned mesh's vertices are rewritten each frame (skinned.rs).
    let vertex_buffer = buffer_init(
        device,
        "vertices",
        bytemuck::cast_slice(&vertices),
        wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
    );
    let index_buffer = buffer_init(
        device,
        "indices",
        bytemuck::cast_slice(&indices),
        wgpu::BufferUsages::INDEX,
    );
    (vertex_buffer, index_buffer)
}

/// Group 0 of every pipeline: the frame's uniforms, the transfer (a storage buffer, or a
/// texture array for texel bakes) and the light's coefficients.
struct FrameResources {
    layout: wgpu::BindGroupLayout,
    frame_buffer: wgpu::Buffer,
    light_buffer: wgpu::Buffer,
    /// A vertex bake's transfer (rewritten per frame under a mover's shadow).
    transfer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// Whether a texel bake's transfer is in the buffer (binding 4) or the array (3).
    texel_transfer_in_buffer: bool,
}

impl FrameResources {
    fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        bake: &Bake,
        storage: TexelStorage,
        upload_transfer: bool,
    ) -> Result<FrameResources> {
        let n2 = bake.order() * bake.order();
        let lightmap = bake.lightmap();
        // A texel bake's transfer goes to its own buffer or texture array (texel_transfer.rs);
        // the vertex transfer's buffer then holds unread zeros (a binding cannot be empty).
        let transfer = buffer_init(
            device,
            "transfer",
            match lightmap {
                None if upload_transfer => bytemuck::cast_slice(&bake.file.coefficients),
                _ => bytemuck::bytes_of(&[0.0f32; 4]),
            },
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        let texel_transfer = match lightmap {
            Some(l) => TexelTransfer::upload(
                device,
                queue,
                &bake.file_path,
                (l.width, l.height),
                &bake.file.coefficients,
                (bake.channels(), n2),
                storage,
            )?,
            None => TexelTransfer::placeholder(device),
        };
        let light_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("light"),
            // Padded with zeros to a multiple of 4 coefficients for the texel shader's grey
            // path, which reads them four at a time.
            size: (n2.next_multiple_of(4) * 16) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let frame_buffer = uniform_buffer(device, "frame", std::mem::size_of::<FrameUniform>());

        let layout = frame_layout(device);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &layout,
            entries: &[
                buffer_binding(0, &frame_buffer),
                buffer_binding(1, &transfer),
                buffer_binding(2, &light_buffer),
                view_binding(3, &texel_transfer.array),
                buffer_binding(4, &texel_transfer.buffer),
            ],
        });

        Ok(FrameResources {
            layout,
            frame_buffer,
            light_buffer,
            transfer,
            bind_group,
            texel_transfer_in_buffer: texel_transfer.in_buffer,
        })
    }
}

/// Group 0's layout: the frame's uniforms (0), the transfer's storage buffer (1, read per
/// vertex), the light's coefficients (2) and a texel bake's transfer, as a texture array (3)
/// or a buffer (4), read by the radiance map's pass.
fn frame_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let vertex_and_fragment = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("frame"),
        entries: &[
            uniform_entry(0, vertex_and_fragment),
            storage_entry(1, wgpu::ShaderStages::VERTEX),
            storage_entry(2, vertex_and_fragment),
            wgpu::BindGroupLayoutEntry {
                binding: 3,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                count: None,
            },
            storage_entry(4, wgpu::ShaderStages::FRAGMENT),
        ],
    })
}

/// The scene's vertex buffer layout (position, normal, uv, lightmap uv).
pub(crate) fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    const ATTRIBUTES: [wgpu::VertexAttribute; 4] =
        wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2, 3 => Float32x2];
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<Vertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRIBUTES,
    }
}

/// What the PRT pipeline's group 2 holds.
#[derive(Clone, Copy)]
enum Group2<'a> {
    None,
    /// A texel bake's radiance map.
    TexelRadiance(&'a wgpu::BindGroupLayout),
    /// A matrix bake's glossy parameters and compressed arrays.
    Glossy(&'a wgpu::BindGroupLayout),
}

/// The PRT pipeline (per vertex, per texel from a radiance map, or glossy from transfer
/// matrices) and the Blinn-Phong one.
fn scene_pipelines(
    device: &wgpu::Device,
    [frame_layout, material_layout]: [&wgpu::BindGroupLayout; 2],
    format: wgpu::TextureFormat,
    group_2: Group2,
    cull_mode: Option<wgpu::Face>,
) -> (wgpu::RenderPipeline, wgpu::RenderPipeline) {
    let scene_module = scene_shader(device, "scene", include_str!("shaders/scene.wgsl"));
    let vertex_layout = vertex_layout();
    let glossy_module = match group_2 {
        Group2::Glossy(_) => Some(scene_shader(
            device,
            "glossy",
            include_str!("shaders/glossy.wgsl"),
        )),
        _ => None,
    };
    let scene_pipeline = |vs, fs, group_2: Option<&wgpu::BindGroupLayout>| {
        let mut layouts = vec![Some(frame_layout), Some(material_layout)];
        layouts.extend(group_2.map(Some));
        pipeline(
            device,
            PipelineSpec {
                label: vs,
                bind_group_layouts: &layouts,
                module: glossy_module
                    .as_ref()
                    .filter(|_| vs == "vs_glossy")
                    .unwrap_or(&scene_module),
                entry_points: (vs, fs),
                buffers: &[Some(vertex_layout.clone())],
                topology: wgpu::PrimitiveTopology::TriangleList,
                format,
                depth_test: true,
                blend: None,
                cull_mode,
            },
        )
    };
    let prt = match group_2 {
        Group2::TexelRadiance(radiance) => {
            scene_pipeline("vs_prt_texel", "fs_prt_texel", Some(radiance))
        }
        Group2::Glossy(glossy) => scene_pipeline("vs_glossy", "fs_glossy", Some(glossy)),
        Group2::None => scene_pipeline("vs_prt", "fs_prt", None),
    };
    let phong = scene_pipeline("vs_phong", "fs_phong", None);

    (prt, phong)
}

/// The normals and light vectors drawn as lines (the thesis's debugging views).
struct LineResources {
    normals: wgpu::Buffer,
    light_vectors: wgpu::Buffer,
    depth_tested: wgpu::RenderPipeline,
    on_top: wgpu::RenderPipeline,
}

impl LineResources {
    fn new(
        device: &wgpu::Device,
        frame_layout: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
        bake: &Bake,
        radius: f32,
    ) -> LineResources {
        let scene = &bake.scene;
        let normal_lines: Vec<LineVertex> = (0..scene.vertex_count())
            .flat_map(|v| {
                let (p, n) = (scene.positions[v], scene.normals[v]);
                let colour = (0.5 * n + Vec3::splat(0.5)).extend(1.0).to_array();
                [p, p + n * NORMAL_LENGTH * radius].map(|q| LineVertex {
                    position: q.to_array(),
                    colour,
                })
            })
            .collect();
        let normal_lines = buffer_init(
            device,
            "normals",
            bytemuck::cast_slice(&normal_lines),
            wgpu::BufferUsages::VERTEX,
        );
        let light_lines = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("light vectors"),
            size: (LIGHT_VECTOR_CAPACITY * 2 * std::mem::size_of::<LineVertex>()) as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let lines_module = scene_shader(device, "lines", include_str!("shaders/lines.wgsl"));
        let line_vertex_layout = wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<LineVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4],
        };
        let line_pipeline = |depth_test| {
            pipeline(
                device,
                PipelineSpec {
                    label: "lines",
                    bind_group_layouts: &[Some(frame_layout)],
                    module: &lines_module,
                    entry_points: ("vs_line", "fs_line"),
                    buffers: &[Some(line_vertex_layout.clone())],
                    topology: wgpu::PrimitiveTopology::LineList,
                    format,
                    depth_test,
                    cull_mode: None,
                    blend: None,
                },
            )
        };
        let lines_depth_tested = line_pipeline(true);
        let lines_on_top = line_pipeline(false);
        LineResources {
            normals: normal_lines,
            light_vectors: light_lines,
            depth_tested: lines_depth_tested,
            on_top: lines_on_top,
        }
    }
}

/// A buffer created holding `contents`.
fn buffer_init(
    device: &wgpu::Device,
    label: &str,
    contents: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage,
    })
}

/// The light as the shader reads it: coefficient j's (R, G, B, 0) at j.
fn light_vectors(light: &LightCoefficients) -> Vec<[f32; 4]> {
    let [r, g, b] = &light.rgb;
    r.iter()
        .zip(g)
        .zip(b)
        .map(|((r, g), b)| [*r as f32, *g as f32, *b as f32, 0.0])
        .collect()
}

fn depth_view(device: &wgpu::Device, size: (u32, u32)) -> wgpu::TextureView {
    texture_2d(
        device,
        "depth",
        size,
        1,
        DEPTH_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    )
    .create_view(&wgpu::TextureViewDescriptor::default())
}
