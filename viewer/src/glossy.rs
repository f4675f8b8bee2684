//! Glossy PRT: a transfer-matrix bake (`prt-bake bake --transfer matrix`) rendered with the
//! diffuse term and each material's Phong lobe, evaluated per vertex in the reflected view
//! direction every frame (`shaders/glossy.wgsl`; the formula is
//! [`prt_baker::math::glossy`]'s).
//!
//! The per-vertex incident radiance L′ = M·L is found one of two ways:
//!
//! * **uncompressed**: the vertex shader multiplies the vertex's matrix (the coefficient file's
//!   payload, already in group 0's transfer buffer) by the summed light: n⁴ products per
//!   vertex on the GPU, nothing per vertex on the CPU and nothing uploaded per frame;
//! * **CPCA-compressed** (version-2 files): once per frame the CPU projects the light through
//!   every cluster's mean and components (K·(M + 1) matrix–vector products of n² × n², a few
//!   hundred thousand multiply-adds at 64 × 4, order 4) and uploads them; each vertex then
//!   combines its cluster's M + 1 vectors with its M weights (Sloan et al. 2003, §4).
//!
//! Group 2 holds the frame's glossy parameters and the compressed arrays; each material's
//! Ks, diffuse weight and band factors ĝ_l(s) are in its material uniform (group 1).

use bytemuck::{Pod, Zeroable};
use prt_baker::export::relight_glossy::ClusterProjections;
use prt_baker::light::LightCoefficients;
use prt_baker::math::cpca::Cpca;
use prt_baker::math::{glossy, sh};
use wgpu::util::DeviceExt;

use crate::bake::Bake;
use crate::error::{Error, Result};
use crate::resources::{buffer_binding, storage_entry, uniform_entry};

/// The largest order shown as glossy PRT: n² ≤ 64 (`MAX_N2` in glossy.wgsl); a matrix is n⁴
/// floats per vertex, 4,096 at order 8.
pub const MAX_GLOSSY_ORDER: usize = 8;

/// `GlossyParams` of glossy.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct ParamsUniform {
    /// Columns of the rotation from the viewer's z-up frame into the bake's.
    to_bake: [[f32; 4]; 3],
    diffuse_bands: [[f32; 4]; 2],
    order: u32,
    compressed: u32,
    pcs: u32,
    pad: u32,
    sh_scale: [[f32; 4]; 16],
}

/// A material's glossy fields (`ks`, `glossy_bands` of `Material` in common.wgsl).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct MaterialLobe {
    /// rgb Ks, w the diffuse weight.
    pub ks: [f32; 4],
    pub bands: [[f32; 4]; 2],
}

/// The lobe of `material` at `order`: its Ks, diffuse weight and ĝ_l(s); a material without
/// a glossy layer reflects only diffusely (Ks 0, weight 1).
pub(crate) fn material_lobe(material: &prt_baker::scene::Material, order: usize) -> MaterialLobe {
    let Some(g) = material.glossy else {
        return MaterialLobe {
            ks: [0.0, 0.0, 0.0, 1.0],
            bands: [[0.0; 4]; 2],
        };
    };
    MaterialLobe {
        ks: g.ks.extend(g.diffuse_weight).to_array(),
        bands: packed_bands(&glossy::lobe_bands(g.exponent, order.min(MAX_GLOSSY_ORDER))),
    }
}

fn packed_bands(bands: &[f32]) -> [[f32; 4]; 2] {
    let mut out = [[0.0; 4]; 2];
    for (l, g) in bands.iter().enumerate().take(8) {
        out[l / 4][l % 4] = *g;
    }
    out
}

/// The glossy bind group (group 2) and what a compressed bake needs per frame.
#[derive(Debug)]
pub(crate) struct GlossyResources {
    pub layout: wgpu::BindGroupLayout,
    pub bind_group: wgpu::BindGroup,
    /// A compressed bake's stored arrays (None: the matrices are in the transfer buffer).
    cpca: Option<Cpca>,
    projected: wgpu::Buffer,
    order: usize,
    channels: usize,
}

impl GlossyResources {
    /// Refuses what the glossy path cannot show: an order above [`MAX_GLOSSY_ORDER`] or a
    /// lightmap matrix bake (none exist).
    pub fn new(device: &wgpu::Device, bake: &Bake) -> Result<GlossyResources> {
        let order = bake.order();
        if order > MAX_GLOSSY_ORDER || bake.lightmap().is_some() {
            return Err(Error::InvalidOption(format!(
                "{}: prt-view shows transfer-matrix bakes per vertex up to order {MAX_GLOSSY_ORDER}; this one is {}",
                bake.file_path.display(),
                if bake.lightmap().is_some() {
                    "a lightmap bake".to_string()
                } else {
                    format!("order {order}")
                }
            )));
        }
        let n2 = order * order;
        let cpca = bake.cpca.clone();
        let mut scale = [[0.0f32; 4]; 16];
        for l in 0..order {
            for m in -(l as i32)..=l as i32 {
                let k = sh::normalization(l, m.abs());
                let k = if m == 0 {
                    k
                } else {
                    std::f64::consts::SQRT_2 * k
                };
                let i = (l * (l + 1)) as i32 + m;
                scale[i as usize / 4][i as usize % 4] = k as f32;
            }
        }
        let to_bake = bake.up().from_z_up().as_mat3();
        let params = ParamsUniform {
            to_bake: [to_bake.x_axis, to_bake.y_axis, to_bake.z_axis]
                .map(|c| c.extend(0.0).to_array()),
            diffuse_bands: packed_bands(&glossy::lobe_bands(1.0, order)),
            order: order as u32,
            compressed: u32::from(cpca.is_some()),
            pcs: cpca.as_ref().map_or(0, |c| c.pcs as u32),
            pad: 0,
            sh_scale: scale,
        };
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let params = init(
            "glossy",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::UNIFORM,
        );
        let storage = wgpu::BufferUsages::STORAGE;
        // A binding cannot be empty: an uncompressed bake binds four unread zeros.
        let zeros = [0u32; 4];
        let (clusters, weights, vectors) = match &cpca {
            Some(c) => (
                init("clusters", bytemuck::cast_slice(&c.cluster), storage),
                init(
                    "weights",
                    bytemuck::cast_slice(if c.weights.is_empty() {
                        &[0.0f32; 4][..]
                    } else {
                        &c.weights
                    }),
                    storage,
                ),
                c.clusters() * (c.pcs + 1) * n2,
            ),
            None => (
                init("clusters", bytemuck::cast_slice(&zeros), storage),
                init("weights", bytemuck::cast_slice(&zeros), storage),
                1,
            ),
        };
        let projected = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("projected light"),
            size: (vectors * 16) as u64,
            usage: storage | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let layout = layout(device);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("glossy"),
            layout: &layout,
            entries: &[
                buffer_binding(0, &params),
                buffer_binding(1, &clusters),
                buffer_binding(2, &weights),
                buffer_binding(3, &projected),
            ],
        });
        Ok(GlossyResources {
            layout,
            bind_group,
            cpca,
            projected,
            order,
            channels: bake.channels(),
        })
    }

    /// Whether the matrices are in the transfer buffer (not needed for a compressed bake).
    pub fn needs_matrices(&self) -> bool {
        self.cpca.is_none()
    }

    /// A compressed bake's per-frame work: the light projected through every cluster's mean
    /// and components, uploaded.
    pub fn update(&self, queue: &wgpu::Queue, light: &LightCoefficients) {
        if let Some(cpca) = &self.cpca {
            let vectors = project(cpca, light, self.order, self.channels);
            queue.write_buffer(&self.projected, 0, bytemuck::cast_slice(&vectors));
        }
    }
}

/// Per cluster k and vector p (0 the mean, 1 + i component i), the matrix it stores times
/// the light ([`ClusterProjections`], the CPU relight's, in f64): coefficient i's (R, G, B, 0)
/// at (k·(M + 1) + p)·n² + i.
pub fn project(
    cpca: &Cpca,
    light: &LightCoefficients,
    order: usize,
    channels: usize,
) -> Vec<[f32; 4]> {
    let n2 = order * order;
    let per = cpca.pcs + 1;
    let projected = ClusterProjections::new(cpca, channels, light);
    let mut out = vec![[0.0f32; 4]; cpca.clusters() * per * n2];
    for (vector, chunk) in out.chunks_exact_mut(n2).enumerate() {
        let (k, p) = (vector / per, vector % per);
        for (c, rgb) in (0..3).map(|c| (c, projected.vector(k, p, c, cpca.pcs))) {
            for (slot, value) in chunk.iter_mut().zip(rgb) {
                slot[c] = *value as f32;
            }
        }
    }
    out
}

/// Group 2: the parameters (0, read by the vertex shader), cluster indices (1), weights (2)
/// and projected light (3).
fn layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("glossy"),
        entries: &[
            uniform_entry(0, wgpu::ShaderStages::VERTEX),
            storage_entry(1, wgpu::ShaderStages::VERTEX),
            storage_entry(2, wgpu::ShaderStages::VERTEX),
            storage_entry(3, wgpu::ShaderStages::VERTEX),
        ],
    })
}
