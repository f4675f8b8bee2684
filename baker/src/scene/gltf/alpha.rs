//! A glTF material's `alphaMode`, `alphaCutoff`, base colour alpha and the base colour
//! texture's sampler and `KHR_texture_transform`, as an [`Alpha`] and a [`Sampling`].

use gltf::material::AlphaMode as GltfMode;
use gltf::texture::WrappingMode;

use crate::scene::alpha::{Alpha, AlphaMode, Sampling, TextureTransform, Wrap};

/// The material's alpha test, `None` for `OPAQUE`; `texture` is the scene's index of its
/// base colour texture. Refuses a cutoff outside [0, 1] (the specification's range) and a
/// non-finite transform.
pub fn material_alpha(
    material: &gltf::Material,
    texture: Option<usize>,
) -> std::result::Result<Option<Alpha>, String> {
    let mode = match material.alpha_mode() {
        GltfMode::Opaque => return Ok(None),
        GltfMode::Blend => AlphaMode::Blend,
        GltfMode::Mask => {
            let cutoff = material.alpha_cutoff().unwrap_or(0.5);
            if !(0.0..=1.0).contains(&cutoff) {
                return Err(format!("alphaCutoff {cutoff} is outside [0, 1]"));
            }
            AlphaMode::Mask { cutoff }
        }
    };
    let pbr = material.pbr_metallic_roughness();
    let factor = pbr.base_color_factor()[3];
    if !(0.0..=1.0).contains(&factor) {
        return Err(format!(
            "baseColorFactor's alpha {factor} is outside [0, 1]"
        ));
    }
    let sampling = base_colour_sampling(material)?;
    Ok(Some(Alpha {
        mode,
        factor,
        texture,
        channel: 3,
        wrap: sampling.wrap,
        transform: sampling.matrix(),
    }))
}

/// The base colour texture's sampler wrap modes and `KHR_texture_transform` (repeat and none
/// without a texture). Refuses a non-finite transform.
pub fn base_colour_sampling(material: &gltf::Material) -> std::result::Result<Sampling, String> {
    let info = material.pbr_metallic_roughness().base_color_texture();
    let sampler = info.as_ref().map(|i| i.texture().sampler());
    let wrap = |mode: Option<WrappingMode>| match mode {
        Some(WrappingMode::ClampToEdge) => Wrap::ClampToEdge,
        Some(WrappingMode::MirroredRepeat) => Wrap::MirroredRepeat,
        Some(WrappingMode::Repeat) | None => Wrap::Repeat,
    };
    let transform = match info.as_ref().and_then(|i| i.texture_transform()) {
        None => None,
        Some(t) => {
            let transform = TextureTransform {
                offset: t.offset(),
                rotation: t.rotation(),
                scale: t.scale(),
            };
            if transform.matrix().iter().flatten().any(|x| !x.is_finite()) {
                return Err("KHR_texture_transform has a non-finite value".into());
            }
            Some(transform)
        }
    };
    Ok(Sampling {
        wrap: [
            wrap(sampler.as_ref().map(|s| s.wrap_s())),
            wrap(sampler.as_ref().map(|s| s.wrap_t())),
        ],
        transform,
    })
}
