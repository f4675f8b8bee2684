//! [`PrtMaterial`]: a [`StandardMaterial`] whose diffuse lighting is replaced by T·L, per
//! vertex (the transfer attributes) or per texel (a texel bake's transfer array on
//! TEXCOORD_1), with Bevy's own specular from the scene's lights where
//! [`PrtExtension::specular`] asks for it.

use bevy::mesh::MeshVertexBufferLayoutRef;
use bevy::pbr::{
    ExtendedMaterial, MaterialExtension, MaterialExtensionKey, MaterialExtensionPipeline,
};
use bevy::prelude::*;
use bevy::render::render_resource::{
    AsBindGroup, RenderPipelineDescriptor, ShaderType, SpecializedMeshPipelineError,
};
use bevy::shader::ShaderRef;

use crate::export::PRT_TRANSFER;

/// The relighting material: `base` keeps the base colour, its texture, alpha and culling.
pub type PrtMaterial = ExtendedMaterial<StandardMaterial, PrtExtension>;

/// The most light VEC4s: 3 channels × 12 groups (order 6 grey; order 4 RGB uses 12).
pub const MAX_LIGHT_VEC4: usize = 36;

pub(crate) const SHADER_PATH: &str = "embedded://bevy_prt/prt.wgsl";

/// The light and the layout of the transfer, as the shader reads them.
#[derive(Clone, Debug, ShaderType, Reflect)]
pub struct PrtUniform {
    pub light: [Vec4; MAX_LIGHT_VEC4],
    pub groups: u32,
    pub rgb: u32,
    pub clamp_shading: u32,
    pub exposure: f32,
}

/// The PRT part of a [`PrtMaterial`].
#[derive(Asset, AsBindGroup, Reflect, Debug, Clone)]
#[bind_group_data(PrtKey)]
pub struct PrtExtension {
    #[uniform(100)]
    pub uniform: PrtUniform,
    /// A texel bake's transfer (texel.rs); None for vertex bakes.
    #[texture(101, dimension = "2d_array")]
    #[sampler(102)]
    pub transfer: Option<Handle<Image>>,
    /// The transfer's order (the light is cut or zero-padded to it).
    pub order: u32,
    /// The transfer VEC4s a vertex carries (0 for texel bakes).
    pub attributes: u32,
    /// The transfer is in a z-up bake's own frame (texel bakes of OBJ and scene files).
    pub z_up: bool,
    /// Lit by [`crate::ProbeLit`] from the probes, not by the [`crate::PrtLight`] directly.
    pub probe_lit: bool,
    /// Adds Bevy's own specular (its PBR lighting with the diffuse made zero) from the scene's
    /// Bevy lights (directional, point, spot, environment map, ambient), with `base`'s
    /// roughness, metallic and reflectance. Off by default: T·L alone. The specular is in
    /// Bevy's lit units (times the camera's exposure); T·L is not.
    pub specular: bool,
}

/// What the pipeline is specialised on.
#[repr(C)]
#[derive(Eq, PartialEq, Hash, Copy, Clone)]
pub struct PrtKey {
    texel: u32,
    attributes: u32,
    specular: u32,
}

impl From<&PrtExtension> for PrtKey {
    fn from(e: &PrtExtension) -> PrtKey {
        PrtKey {
            texel: e.transfer.is_some() as u32,
            attributes: e.attributes,
            specular: e.specular as u32,
        }
    }
}

impl PrtExtension {
    /// A material for a transfer of `order`, grey or `rgb`; `transfer` for texel bakes.
    /// `clamp_shading` clamps Σ T·L to [0, 1] as an export's COLOR_0 and lightmap are.
    pub fn new(
        order: usize,
        rgb: bool,
        transfer: Option<Handle<Image>>,
        z_up: bool,
        clamp_shading: bool,
    ) -> PrtExtension {
        let groups = (order * order).div_ceil(4) as u32;
        let attributes = if transfer.is_some() {
            0
        } else {
            groups * if rgb { 3 } else { 1 }
        };
        PrtExtension {
            uniform: PrtUniform {
                light: [Vec4::ZERO; MAX_LIGHT_VEC4],
                groups,
                rgb: rgb as u32,
                clamp_shading: clamp_shading as u32,
                exposure: 1.0,
            },
            transfer,
            order: order as u32,
            attributes,
            z_up,
            probe_lit: false,
            specular: false,
        }
    }

    /// Writes the light (R, G, B coefficients at least of this order) into the uniform.
    pub fn set_light(&mut self, rgb: &[Vec<f64>; 3]) {
        let groups = self.uniform.groups as usize;
        let n = (self.order * self.order) as usize;
        for (c, channel) in rgb.iter().enumerate() {
            for k in 0..groups {
                let at = |i: usize| {
                    if 4 * k + i < n {
                        channel.get(4 * k + i).copied().unwrap_or(0.0) as f32
                    } else {
                        0.0
                    }
                };
                self.uniform.light[c * groups + k] = Vec4::new(at(0), at(1), at(2), at(3));
            }
        }
    }
}

impl MaterialExtension for PrtExtension {
    fn vertex_shader() -> ShaderRef {
        SHADER_PATH.into()
    }

    fn fragment_shader() -> ShaderRef {
        SHADER_PATH.into()
    }

    fn enable_prepass() -> bool {
        false
    }

    fn enable_shadows() -> bool {
        false
    }

    fn specialize(
        _pipeline: &MaterialExtensionPipeline,
        descriptor: &mut RenderPipelineDescriptor,
        layout: &MeshVertexBufferLayoutRef,
        key: MaterialExtensionKey<Self>,
    ) -> Result<(), SpecializedMeshPipelineError> {
        let mut attributes = vec![
            Mesh::ATTRIBUTE_POSITION.at_shader_location(0),
            Mesh::ATTRIBUTE_NORMAL.at_shader_location(1),
            Mesh::ATTRIBUTE_UV_0.at_shader_location(2),
        ];
        let mut defs = Vec::new();
        if key.bind_group_data.specular != 0 {
            defs.push("PRT_SPECULAR".into());
        }
        if key.bind_group_data.texel != 0 {
            attributes.push(Mesh::ATTRIBUTE_UV_1.at_shader_location(3));
            defs.push("PRT_TEXEL".into());
        } else {
            // The shading goes to the fragment stage as the vertex colour.
            defs.push("VERTEX_COLORS".into());
            let count = key.bind_group_data.attributes as usize;
            for (i, attribute) in PRT_TRANSFER.iter().enumerate().take(count) {
                attributes.push(attribute.at_shader_location(3 + i as u32));
                defs.push(format!("PRT_T{i}").into());
            }
        }
        descriptor.vertex.buffers = vec![layout.0.get_layout(&attributes)?];
        descriptor.vertex.shader_defs.extend(defs.iter().cloned());
        if let Some(fragment) = descriptor.fragment.as_mut() {
            fragment.shader_defs.extend(defs);
        }
        Ok(())
    }
}
