//! The transfer probes and the moving object on the GPU (docs/guides/probes.md): drawn into the
//! renderer's pass after the scene, depth-tested against it.
//!
//! * The moving object ([`Mover`]): its vertices placed and its radiance computed on the
//!   CPU each frame (`moving.rs`), uploaded, and drawn with the scene's tone map.
//! * The probes (P toggles them): a small sphere at each valid probe, shaded as a white
//!   diffuse ball there would be: E(n)/π = Σ_j (A_l/π) L_in,j y_j(n), A_l the clamped
//!   cosine's bands, evaluated per pixel from the probe's L_in = M·L (uploaded each frame, as
//!   the light may turn). Shown as irradiance rather than raw incident radiance: a sun's
//!   few SH bands overshoot and ring, which the cosine smooths, and the balls then read as
//!   the moving object (a white diffuse object) would look at each probe.

use glam::{DQuat, Vec3};
use prt_baker::light::LightCoefficients;

use crate::error::{Error, Result};
use crate::moving::{Mover, Probes};
use crate::resources::{PipelineSpec, buffer_binding, pipeline, scene_shader, storage_entry};
use crate::skinned::Skinned;

/// A probe sphere's radius, as a fraction of the grid's smallest spacing.
const SPHERE_RADIUS: f32 = 0.12;
/// The probe spheres' tessellation (longitude × latitude segments).
const SPHERE_SEGMENTS: (u32, u32) = (16, 10);

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct MoverVertex {
    position: [f32; 3],
    colour: [f32; 4],
}

/// The probe scene's CPU state and GPU resources.
#[derive(Debug)]
pub struct ProbeScene {
    probes: Probes,
    mover: Option<Mover>,
    /// Distance along the mover's path.
    pub distance: f32,
    /// A skinned character walking through the probes instead of a rigid mover, and the
    /// seconds since its animation started ([`ProbeScene::set_walker`]).
    walker: Option<Skinned>,
    pub seconds: f64,
    /// Whether the probe spheres are drawn.
    pub show_probes: bool,
    /// The valid probes' indices in the file.
    valid: Vec<usize>,
    mover_vertices: Option<wgpu::Buffer>,
    mover_indices: Option<(wgpu::Buffer, u32)>,
    mover_pipeline: wgpu::RenderPipeline,
    sphere: (wgpu::Buffer, wgpu::Buffer, u32),
    instances: wgpu::Buffer,
    incident: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    sphere_pipeline: wgpu::RenderPipeline,
}

impl ProbeScene {
    /// GPU resources for `probes` and an optional `mover`, for the renderer's frame layout and
    /// colour `format`; both must be of the bake's `order`.
    pub fn new(
        device: &wgpu::Device,
        (frame_layout, format): (&wgpu::BindGroupLayout, wgpu::TextureFormat),
        order: usize,
        probes: Probes,
        mover: Option<Mover>,
    ) -> Result<ProbeScene> {
        let orders = [Some(probes.order()), mover.as_ref().map(Mover::order)];
        if let Some(other) = orders.into_iter().flatten().find(|&o| o != order) {
            return Err(Error::InvalidOption(format!(
                "the probes and the moving object must be baked at the scene's order {order}, not {other}"
            )));
        }
        let block = probes.file.probes.as_ref().expect("a probe file");
        let valid: Vec<usize> = (0..block.positions.len())
            .filter(|&p| block.valid(p))
            .collect();
        let grid = block.grid.expect("a grid bake");
        let spacing = (grid.hi - grid.lo) / Vec3::from_array(grid.counts.map(|c| c.max(1) as f32));
        let radius = SPHERE_RADIUS * spacing.min_element();
        let centres: Vec<[f32; 4]> = valid
            .iter()
            .map(|&p| block.positions[p].extend(radius).to_array())
            .collect();
        let init = |label, contents: &[u8], usage| {
            wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage,
                },
            )
        };
        let instances = init(
            "probe centres",
            bytemuck::cast_slice(&centres),
            wgpu::BufferUsages::VERTEX,
        );
        let n = order * order;
        let incident = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("probe incident radiance"),
            size: (16 * n * valid.len().max(1)) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("probes"),
            entries: &[storage_entry(0, wgpu::ShaderStages::FRAGMENT)],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("probes"),
            layout: &layout,
            entries: &[buffer_binding(0, &incident)],
        });
        let (unit, triangles) = unit_sphere();
        let sphere = (
            init(
                "probe sphere",
                bytemuck::cast_slice(&unit),
                wgpu::BufferUsages::VERTEX,
            ),
            init(
                "probe sphere indices",
                bytemuck::cast_slice(&triangles),
                wgpu::BufferUsages::INDEX,
            ),
            triangles.len() as u32,
        );
        let module = scene_shader(
            device,
            "probe scene",
            include_str!("shaders/probe_scene.wgsl"),
        );
        let mover_pipeline = pipeline(
            device,
            PipelineSpec {
                label: "mover",
                bind_group_layouts: &[Some(frame_layout)],
                module: &module,
                entry_points: ("vs_mover", "fs_mover"),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<MoverVertex>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4],
                })],
                topology: wgpu::PrimitiveTopology::TriangleList,
                format,
                depth_test: true,
                cull_mode: None,
                blend: None,
            },
        );
        let sphere_pipeline = pipeline(
            device,
            PipelineSpec {
                label: "probe spheres",
                bind_group_layouts: &[Some(frame_layout), Some(&layout)],
                module: &module,
                entry_points: ("vs_probe_sphere", "fs_probe_sphere"),
                buffers: &[
                    Some(wgpu::VertexBufferLayout {
                        array_stride: 12,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &wgpu::vertex_attr_array![0 => Float32x3],
                    }),
                    Some(wgpu::VertexBufferLayout {
                        array_stride: 16,
                        step_mode: wgpu::VertexStepMode::Instance,
                        attributes: &wgpu::vertex_attr_array![1 => Float32x4],
                    }),
                ],
                topology: wgpu::PrimitiveTopology::TriangleList,
                format,
                depth_test: true,
                cull_mode: None,
                blend: None,
            },
        );
        let (mover_vertices, mover_indices) = match &mover {
            Some(m) => {
                let indices: Vec<u32> = m.scene.triangles.iter().flatten().copied().collect();
                let vertices = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("mover"),
                    size: (m.scene.vertex_count() * std::mem::size_of::<MoverVertex>()) as u64,
                    usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                let index_buffer = init(
                    "mover indices",
                    bytemuck::cast_slice(&indices),
                    wgpu::BufferUsages::INDEX,
                );
                (Some(vertices), Some((index_buffer, indices.len() as u32)))
            }
            None => (None, None),
        };
        Ok(ProbeScene {
            probes,
            mover,
            distance: 0.0,
            walker: None,
            seconds: 0.0,
            show_probes: true,
            valid,
            mover_vertices,
            mover_indices,
            mover_pipeline,
            sphere,
            instances,
            incident,
            bind_group,
            sphere_pipeline,
        })
    }

    pub fn mover(&self) -> Option<&Mover> {
        self.mover.as_ref()
    }

    /// Where the mover is now (its position and rotation), if there is one.
    pub fn placement(&self) -> Option<(Vec3, DQuat)> {
        self.mover.as_ref().map(|m| m.placement(self.distance))
    }

    /// A skinned character with its LDPRT bake (skinned.rs) that plays its animation through
    /// the probes, lit each frame at its posed position; instead of a rigid mover.
    pub fn set_walker(&mut self, device: &wgpu::Device, walker: Skinned) -> Result<()> {
        if self.mover.is_some() {
            return Err(Error::InvalidOption(
                "one moving object at a time: a rigid mover or a character".into(),
            ));
        }
        if walker.order() != self.probes.order() {
            return Err(Error::InvalidOption(format!(
                "the character's LDPRT bake is of order {}, the probes of order {}",
                walker.order(),
                self.probes.order()
            )));
        }
        let indices: Vec<u32> = walker.triangles()?.into_iter().flatten().collect();
        let vertex_count = indices.iter().max().map_or(0, |&i| i as usize + 1);
        self.mover_vertices = Some(device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("character"),
            size: (vertex_count.max(1) * std::mem::size_of::<MoverVertex>()) as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        }));
        let index_buffer = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("character indices"),
                contents: bytemuck::cast_slice(&indices),
                usage: wgpu::BufferUsages::INDEX,
            },
        );
        self.mover_indices = Some((index_buffer, indices.len() as u32));
        self.walker = Some(walker);
        Ok(())
    }

    /// Moves the mover to where it is after `seconds` on its path (a character to its pose
    /// then).
    pub fn set_time(&mut self, seconds: f64) {
        self.seconds = seconds;
        if let Some(m) = &self.mover {
            self.distance = m.distance_at(seconds);
        }
    }

    /// Uploads the probes' incident radiance and the mover's placed, lit vertices for the
    /// scene's light `light` (its frame, the bake's order).
    pub fn update(&self, queue: &wgpu::Queue, light: &LightCoefficients) {
        let field = self.probes.field();
        let bands = clamped_cosine_bands(light.order());
        let incident: Vec<[f32; 4]> = self
            .valid
            .iter()
            .flat_map(|&p| {
                let l = field.probe_incident(p, light);
                let bands = &bands;
                (0..l.rgb[0].len()).map(move |j| {
                    let a = bands[(j as f64).sqrt() as usize];
                    [l.rgb[0][j], l.rgb[1][j], l.rgb[2][j], 0.0].map(|x| (a * x) as f32)
                })
            })
            .collect();
        queue.write_buffer(&self.incident, 0, bytemuck::cast_slice(&incident));
        if let (Some(m), Some(buffer), Some(placement)) =
            (&self.mover, &self.mover_vertices, self.placement())
        {
            let radiance = m.radiance(&self.probes, placement, light);
            let vertices: Vec<MoverVertex> = m
                .world_positions(placement)
                .iter()
                .zip(&radiance)
                .map(|(p, [r, g, b])| MoverVertex {
                    position: p.to_array(),
                    colour: [*r, *g, *b, 1.0],
                })
                .collect();
            queue.write_buffer(buffer, 0, bytemuck::cast_slice(&vertices));
        }
        if let (Some(walker), Some(buffer)) = (&self.walker, &self.mover_vertices) {
            let pose = walker.pose_at(self.seconds);
            match walker.lit_through_probes(&pose, &field, light) {
                Ok((positions, radiance)) => {
                    let vertices: Vec<MoverVertex> = positions
                        .iter()
                        .zip(&radiance)
                        .map(|(p, [r, g, b])| MoverVertex {
                            position: p.to_array(),
                            colour: [*r, *g, *b, 1.0],
                        })
                        .collect();
                    queue.write_buffer(buffer, 0, bytemuck::cast_slice(&vertices));
                }
                // The file was read and checked when loaded; a frame that cannot pose keeps
                // the last one.
                Err(err) => eprintln!("prt-view: the character at {pose}: {err}"),
            }
        }
    }

    /// Draws the mover and (when shown) the probe spheres; group 0 of `pass` must be the
    /// renderer's frame bind group.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, frame: &wgpu::BindGroup) {
        if let (Some(vertices), Some((indices, count))) =
            (&self.mover_vertices, &self.mover_indices)
        {
            pass.set_pipeline(&self.mover_pipeline);
            pass.set_bind_group(0, frame, &[]);
            pass.set_vertex_buffer(0, vertices.slice(..));
            pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..*count, 0, 0..1);
        }
        if self.show_probes && !self.valid.is_empty() {
            let (vertices, indices, count) = &self.sphere;
            pass.set_pipeline(&self.sphere_pipeline);
            pass.set_bind_group(0, frame, &[]);
            pass.set_bind_group(1, &self.bind_group, &[]);
            pass.set_vertex_buffer(0, vertices.slice(..));
            pass.set_vertex_buffer(1, self.instances.slice(..));
            pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..*count, 0, 0..self.valid.len() as u32);
        }
    }
}

/// A unit UV sphere: positions (= normals) and triangle indices.
fn unit_sphere() -> (Vec<[f32; 3]>, Vec<u32>) {
    let (nu, nv) = SPHERE_SEGMENTS;
    let mut positions = Vec::new();
    for j in 0..=nv {
        let theta = std::f32::consts::PI * j as f32 / nv as f32;
        for i in 0..=nu {
            let phi = std::f32::consts::TAU * i as f32 / nu as f32;
            positions.push([
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ]);
        }
    }
    let mut indices = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            let a = j * (nu + 1) + i;
            indices.extend([a, a + nu + 1, a + 1, a + 1, a + nu + 1, a + nu + 2]);
        }
    }
    (positions, indices)
}

/// The clamped cosine's zonal coefficients per band over π, A_l/π (Ramamoorthi & Hanrahan
/// 2001): 1, 2/3, then 0 for odd l and 2(−1)^(l/2−1)/((l+2)(l−1)) · C(l, l/2)/2^l for even l.
pub fn clamped_cosine_bands(order: usize) -> Vec<f64> {
    (0..order)
        .map(|l| match l {
            0 => 1.0,
            1 => 2.0 / 3.0,
            l if l % 2 == 1 => 0.0,
            l => {
                let half = l / 2;
                let ratio: f64 = (1..=half)
                    .map(|k| (half + k) as f64 / k as f64 / 4.0)
                    .product();
                let sign = if half % 2 == 1 { 1.0 } else { -1.0 };
                2.0 * sign / ((l + 2) as f64 * (l - 1) as f64) * ratio
            }
        })
        .collect()
}
