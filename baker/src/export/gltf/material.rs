//! One exported material (step 3 of the export): the source material's own properties kept
//! (base colour factor and texture with its sampler and `KHR_texture_transform`, alpha mode
//! and cutoff, `doubleSided`, normal texture), PBR factors, unlit, and a texel bake's
//! lightmap and AO beside them (docs/reference/gltf.md, "Materials").

use glam::Vec3;
use serde_json::{Value, json};

use super::builder::*;
use crate::scene::{AlphaMode, Material, Scene, Wrap};
use crate::support::error::Result;

/// The glTF textures a material's slots name (indices into the file's `textures`).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Slots {
    /// The base colour texture (the source's albedo, on TEXCOORD_0).
    pub base_colour: Option<usize>,
    /// The normal texture (on TEXCOORD_0, with the mesh's TANGENT).
    pub normal: Option<usize>,
    /// A texel bake's relit lightmap (on TEXCOORD_1), named in `extras.prt_lightmap`.
    pub lightmap: Option<usize>,
    /// A texel bake's AO (on TEXCOORD_1): the occlusion slot.
    pub occlusion: Option<usize>,
    /// An OBJ `map_d` (a coverage image of its own, which glTF cannot name), in
    /// `extras.prt_alpha_texture`.
    pub alpha: Option<usize>,
}

/// One material: base colour Kd (× its texture, alpha = the source's), metallic 0, roughness
/// 1; unlit when the file carries the relit light per vertex (COLOR_0).
pub(super) fn material(m: &Material, unlit: bool, slots: Slots) -> Value {
    // glTF's factor is at most 1 (a reflectance); an OBJ's Kd may exceed it.
    let kd = m.kd.clamp(Vec3::ZERO, Vec3::ONE);
    let alpha_factor = m.alpha.as_ref().map_or(1.0, |a| a.factor);
    let mut pbr = json!({
        "baseColorFactor": [kd.x, kd.y, kd.z, alpha_factor],
        "metallicFactor": 0.0,
        "roughnessFactor": 1.0,
    });
    if let Some(t) = slots.base_colour {
        let mut info = json!({"index": t, "texCoord": 0});
        if let Some(transform) = m.sampling.transform {
            info["extensions"] = json!({"KHR_texture_transform": {
                "offset": transform.offset,
                "rotation": transform.rotation,
                "scale": transform.scale,
            }});
        }
        pbr["baseColorTexture"] = info;
    }
    let mut material = json!({"name": m.name, "pbrMetallicRoughness": pbr});
    match m.alpha.as_ref().map(|a| a.mode) {
        None => {}
        Some(AlphaMode::Mask { cutoff }) => {
            material["alphaMode"] = json!("MASK");
            material["alphaCutoff"] = json!(cutoff);
        }
        Some(AlphaMode::Blend) => material["alphaMode"] = json!("BLEND"),
    }
    if m.double_sided {
        material["doubleSided"] = json!(true);
    }
    if let (Some(t), Some(map)) = (slots.normal, &m.normal_map) {
        material["normalTexture"] = json!({"index": t, "texCoord": 0, "scale": map.scale});
    }
    if unlit {
        material["extensions"] = json!({"KHR_materials_unlit": {}});
    }
    if let Some(t) = slots.occlusion {
        material["occlusionTexture"] = json!({"index": t, "texCoord": 1});
    }
    if let Some(t) = slots.lightmap {
        material["extras"]["prt_lightmap"] = json!({"index": t, "texCoord": 1});
    }
    if let Some(t) = slots.alpha {
        material["extras"]["prt_alpha_texture"] = json!({"index": t, "texCoord": 0, "channel": m.alpha.as_ref().map_or(3, |a| a.channel)});
    }
    material
}

/// Images, textures, samplers and materials, and which textures are the lightmap's.
pub(super) struct Materials {
    pub(super) images: Vec<Value>,
    pub(super) textures: Vec<Value>,
    pub(super) samplers: Vec<Value>,
    pub(super) materials: Vec<Value>,
    /// The relit lightmap's texture index.
    pub(super) lightmap_texture: Option<usize>,
    /// The texel AO's texture index (occlusionTexture).
    pub(super) occlusion_texture: Option<usize>,
    pub(super) unlit: bool,
    /// Whether a material carries a `KHR_texture_transform`.
    pub(super) texture_transform: bool,
}

/// glTF's number of a wrap mode.
fn wrap_code(wrap: Wrap) -> u32 {
    match wrap {
        Wrap::Repeat => REPEAT,
        Wrap::ClampToEdge => CLAMP_TO_EDGE,
        Wrap::MirroredRepeat => MIRRORED_REPEAT,
    }
}

/// Step 3: the scene's textures as PNG (albedo, normal and alpha maps as the source had
/// them, each glTF texture with its source sampler's wrap modes), a texel bake's relit
/// lightmap and AO as textures of their own, and one material per scene material that keeps
/// the source's properties (material.rs). Unlit (`KHR_materials_unlit`) where the file
/// carries the relit light per vertex (COLOR_0, docs/reference/gltf.md says why); a texel bake's
/// relit lightmap goes beside the albedo, in `extras.prt_lightmap`, never over it.
pub(super) fn materials(
    b: &mut Builder,
    scene: &Scene,
    vertex_lit: bool,
    (lightmap_png, ao_png): (Option<&[u8]>, Option<&[u8]>),
) -> Result<Materials> {
    let mut images = Vec::new();
    for texture in &scene.textures {
        let png = png_bytes(texture)?;
        let view = b.view(&png, None);
        images.push(json!({"bufferView": view, "mimeType": "image/png"}));
    }
    let mut samplers = vec![json!({
        "magFilter": LINEAR,
        "minFilter": LINEAR_MIPMAP_LINEAR,
        "wrapS": REPEAT,
        "wrapT": REPEAT,
    })];
    let mut textures: Vec<Value> = (0..scene.textures.len())
        .map(|i| json!({"source": i, "sampler": ALBEDO_SAMPLER}))
        .collect();
    // A texture of image `image` sampled with `wrap`: the repeating one made above, or one
    // made (once) with a sampler of those modes.
    let mut wrapped = std::collections::HashMap::new();
    let mut texture_of = |image: usize, wrap: [Wrap; 2], textures: &mut Vec<Value>| {
        if wrap == [Wrap::Repeat; 2] {
            return image;
        }
        *wrapped.entry((image, wrap)).or_insert_with(|| {
            let codes = wrap.map(wrap_code);
            let sampler = samplers
                .iter()
                .position(|s| {
                    s["minFilter"] == LINEAR_MIPMAP_LINEAR
                        && s["wrapS"] == codes[0]
                        && s["wrapT"] == codes[1]
                })
                .unwrap_or_else(|| {
                    samplers.push(json!({
                        "magFilter": LINEAR,
                        "minFilter": LINEAR_MIPMAP_LINEAR,
                        "wrapS": codes[0],
                        "wrapT": codes[1],
                    }));
                    samplers.len() - 1
                });
            textures.push(json!({"source": image, "sampler": sampler}));
            textures.len() - 1
        })
    };
    let slots: Vec<Slots> = scene
        .materials
        .iter()
        .map(|m| Slots {
            base_colour: m
                .texture
                .map(|t| texture_of(t, m.sampling.wrap, &mut textures)),
            normal: m
                .normal_map
                .as_ref()
                .map(|n| texture_of(n.texture, n.wrap, &mut textures)),
            alpha: m
                .alpha
                .as_ref()
                .and_then(|a| a.texture.filter(|&t| Some(t) != m.texture)),
            ..Slots::default()
        })
        .collect();
    let needs_lightmap_sampler = lightmap_png.is_some() || ao_png.is_some();
    let lightmap_sampler = samplers.len();
    if needs_lightmap_sampler {
        samplers.push(json!({
            "magFilter": LINEAR,
            "minFilter": LINEAR,
            "wrapS": CLAMP_TO_EDGE,
            "wrapT": CLAMP_TO_EDGE,
        }));
    }
    let mut embed = |png: Option<&[u8]>, name: &str| {
        png.map(|png| {
            let view = b.view(png, None);
            images.push(json!({"bufferView": view, "mimeType": "image/png", "name": name}));
            textures.push(
                json!({"source": images.len() - 1, "sampler": lightmap_sampler, "name": name}),
            );
            textures.len() - 1
        })
    };
    let lightmap_texture = embed(lightmap_png, "prt_lightmap");
    let occlusion_texture = embed(ao_png, "prt_ao");
    let unlit = vertex_lit;
    let materials = scene
        .materials
        .iter()
        .zip(slots)
        .map(|(m, slots)| {
            let slots = Slots {
                lightmap: lightmap_texture,
                occlusion: occlusion_texture,
                ..slots
            };
            material(m, unlit, slots)
        })
        .collect();
    Ok(Materials {
        images,
        textures,
        samplers,
        materials,
        lightmap_texture,
        occlusion_texture,
        unlit,
        texture_transform: scene
            .materials
            .iter()
            .any(|m| m.texture.is_some() && m.sampling.transform.is_some()),
    })
}
