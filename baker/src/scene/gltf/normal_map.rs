//! A glTF material's `normalTexture` as a [`NormalMap`], and the texture coordinate set a
//! primitive's textures are read with.

use glam::{Vec3, Vec4};
use gltf::texture::WrappingMode;

use crate::scene::alpha::Wrap;
use crate::scene::normal_map::NormalMap;

/// The normal map of `info`, whose image is the scene's texture `texture`, with the
/// texture's sampler wrap modes. (`KHR_texture_transform` on a normal texture is not read:
/// `gltf` 1.4 exposes it only for `Info`, and `docs/guides/lightmaps.md` says so.)
pub fn read(info: &gltf::material::NormalTexture, texture: usize) -> NormalMap {
    let sampler = info.texture().sampler();
    let wrap = |mode: WrappingMode| match mode {
        WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        WrappingMode::Repeat => Wrap::Repeat,
    };
    NormalMap {
        texture,
        scale: if info.scale().is_finite() {
            info.scale()
        } else {
            1.0
        },
        wrap: [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())],
    }
}

/// The TEXCOORD set the scene's uvs are read from: the base colour texture's, else the
/// normal texture's, else 0. The scene keeps one set, so two textures on different sets
/// are refused rather than one read with the other's coordinates.
pub fn uv_set(
    base_colour: Option<&gltf::texture::Info>,
    normal: Option<&gltf::material::NormalTexture>,
) -> std::result::Result<u32, String> {
    match (
        base_colour.map(|i| i.tex_coord()),
        normal.map(|n| n.tex_coord()),
    ) {
        (Some(a), Some(b)) if a != b => Err(format!(
            "the base colour texture reads TEXCOORD_{a} and the normal texture TEXCOORD_{b}; \
             the baker reads one set per primitive"
        )),
        (Some(set), _) | (None, Some(set)) => Ok(set),
        (None, None) => Ok(0),
    }
}

/// World-space tangents from a mesh's own by its world matrix's linear part; a mirror flips
/// the bitangent's sign (the normal goes by the inverse transpose, so n × t flips with it).
pub fn tangents_to_world(
    linear: glam::Mat3,
    tangents: impl Iterator<Item = [f32; 4]>,
) -> Vec<Vec4> {
    let flip = if linear.determinant() < 0.0 {
        -1.0
    } else {
        1.0
    };
    tangents
        .map(|[x, y, z, w]| {
            let t = (linear * Vec3::new(x, y, z)).normalize_or_zero();
            t.extend(if w < 0.0 { -flip } else { flip })
        })
        .collect()
}
