//! The scene's materials on the GPU, drawn as engines draw glTF and OBJ materials: the base
//! colour texture (sRGB, mipmapped) with its sampler's wrap modes and `KHR_texture_transform`,
//! and the alpha the bake traced (docs/reference/viewer.md, "Materials"):
//!
//! * glTF `MASK`: fragments whose coverage (the base colour factor's alpha × the texture's
//!   alpha) is below `alphaCutoff` are discarded, the test the baker's rays make at a hit;
//! * glTF `BLEND` and OBJ `map_d`: **alpha-hashed** (stochastic) transparency: a fragment is
//!   kept where a hash of its pixel is below the coverage, the per-pixel counterpart of the
//!   baker's stochastic coverage, with depth writes and no sorting;
//! * `doubleSided`: the bake's back sheets and their fronts are drawn with back faces culled
//!   (renderer.rs), every other surface from both sides with its own transfer.
//!
//! `MaterialUniform` is `Material` of common.wgsl; one bind group per material holds it, the
//! base colour texture (white where there is none), the coverage texture (an OBJ `map_d` is
//! an image of its own, read as data; glTF's is the base colour texture's alpha) and a
//! trilinear sampler with the material's wrap modes.

use bytemuck::{Pod, Zeroable};
use prt_baker::scene::{AlphaMode, Material, Scene, Wrap};
use wgpu::util::DeviceExt;

use crate::glossy::material_lobe;
use crate::resources::{buffer_binding, texture_entry, uniform_entry, view_binding};
use crate::textures;

/// `Material::alpha_mode` of common.wgsl.
const OPAQUE: u32 = 0;
const MASK: u32 = 1;
const HASHED: u32 = 2;

/// `Material` of common.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct MaterialUniform {
    /// rgb Kd, w the base colour factor's alpha.
    kd: [f32; 4],
    has_texture: u32,
    /// OPAQUE, MASK or HASHED.
    alpha_mode: u32,
    /// The coverage texture's channel (3 alpha, 0 red for grey `map_d` images), 4 for none.
    alpha_channel: u32,
    alpha_cutoff: f32,
    /// Glossy PRT: rgb Ks, w the diffuse weight.
    ks: [f32; 4],
    /// ĝ_l(s), band l at [l / 4][l % 4].
    glossy_bands: [[f32; 4]; 2],
    /// The base colour texture's transform: rows (a, b, c) of a·u + b·v + c in glTF's
    /// texture coordinates (v down).
    uv_transform: [[f32; 4]; 2],
    /// The coverage texture's.
    alpha_uv_transform: [[f32; 4]; 2],
}

/// A 2 × 3 affine map as the shader's two vec4 rows.
fn rows(m: [[f32; 3]; 2]) -> [[f32; 4]; 2] {
    m.map(|[a, b, c]| [a, b, c, 0.0])
}

fn address_mode(wrap: Wrap) -> wgpu::AddressMode {
    match wrap {
        Wrap::Repeat => wgpu::AddressMode::Repeat,
        Wrap::ClampToEdge => wgpu::AddressMode::ClampToEdge,
        Wrap::MirroredRepeat => wgpu::AddressMode::MirrorRepeat,
    }
}

fn uniform(m: &Material, order: usize) -> MaterialUniform {
    let lobe = material_lobe(m, order);
    let (alpha_mode, alpha_cutoff) = match m.alpha.as_ref().map(|a| a.mode) {
        None => (OPAQUE, 0.0),
        Some(AlphaMode::Mask { cutoff }) => (MASK, cutoff),
        Some(AlphaMode::Blend) => (HASHED, 0.0),
    };
    let alpha = m.alpha.as_ref();
    MaterialUniform {
        kd: m.kd.extend(alpha.map_or(1.0, |a| a.factor)).to_array(),
        has_texture: u32::from(m.texture.is_some()),
        alpha_mode,
        alpha_channel: alpha
            .filter(|a| a.texture.is_some())
            .map_or(4, |a| a.channel as u32),
        alpha_cutoff,
        ks: lobe.ks,
        glossy_bands: lobe.bands,
        uv_transform: rows(m.sampling.matrix()),
        alpha_uv_transform: rows(alpha.map_or(prt_baker::scene::Alpha::IDENTITY, |a| a.transform)),
    }
}

/// The materials' bind group layout, and one bind group per material of `scene`.
pub fn materials(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    scene: &Scene,
    order: usize,
) -> (wgpu::BindGroupLayout, Vec<wgpu::BindGroup>) {
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("material"),
        entries: &[
            // The glossy vertex shader reads the lobe's band factors.
            uniform_entry(0, wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT),
            texture_entry(1, true),
            wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
            texture_entry(3, true),
        ],
    });
    let colour_views: Vec<wgpu::TextureView> = scene
        .textures
        .iter()
        .map(|t| textures::upload(device, queue, t))
        .collect();
    let white = textures::white(device, queue);
    let groups = scene
        .materials
        .iter()
        .map(|m| {
            let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("material"),
                contents: bytemuck::bytes_of(&uniform(m, order)),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let [u, v] = m.sampling.wrap.map(address_mode);
            let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("albedo"),
                address_mode_u: u,
                address_mode_v: v,
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                mipmap_filter: wgpu::MipmapFilterMode::Linear,
                ..Default::default()
            });
            let colour = m.texture.map_or(&white, |t| &colour_views[t]);
            // glTF's coverage is the base colour texture's alpha (linear in an sRGB texture);
            // an OBJ map_d is an image of its own, read as data (its grey is not decoded).
            let coverage = m.alpha.as_ref().and_then(|a| a.texture).map(|t| {
                if Some(t) == m.texture {
                    colour_views[t].clone()
                } else {
                    textures::upload_data(device, queue, &scene.textures[t])
                }
            });
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("material"),
                layout: &layout,
                entries: &[
                    buffer_binding(0, &uniform),
                    view_binding(1, colour),
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::Sampler(&sampler),
                    },
                    view_binding(3, coverage.as_ref().unwrap_or(&white)),
                ],
            })
        })
        .collect();
    (layout, groups)
}
