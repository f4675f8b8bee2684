//! One exported material (step 3 of the export): base colour, PBR factors, unlit, and a texel
//! bake's lightmap and AO slots (docs/reference/gltf.md).

use glam::Vec3;
use serde_json::{Value, json};

/// One material: base colour Kd (× its texture), metallic 0, roughness 1; unlit when the
/// file carries the relit light. A texel bake's relit lightmap takes the base colour texture
/// slot on TEXCOORD_1 (the albedo texture, if any, is then named in
/// `extras.prt_albedo_texture`), its AO the occlusion slot on TEXCOORD_1.
pub(super) fn material(
    m: &crate::scene::Material,
    unlit: bool,
    lightmap_texture: Option<usize>,
    occlusion_texture: Option<usize>,
) -> Value {
    // glTF's factor is at most 1 (a reflectance); an OBJ's Kd may exceed it.
    let kd = m.kd.clamp(Vec3::ZERO, Vec3::ONE);
    let mut pbr = json!({
        "baseColorFactor": [kd.x, kd.y, kd.z, 1.0],
        "metallicFactor": 0.0,
        "roughnessFactor": 1.0,
    });
    match (lightmap_texture, m.texture) {
        (Some(t), _) => pbr["baseColorTexture"] = json!({"index": t, "texCoord": 1}),
        (None, Some(t)) => pbr["baseColorTexture"] = json!({"index": t}),
        (None, None) => {}
    }
    let mut material = json!({"name": m.name, "pbrMetallicRoughness": pbr});
    if unlit {
        material["extensions"] = json!({"KHR_materials_unlit": {}});
    }
    if let Some(t) = occlusion_texture {
        material["occlusionTexture"] = json!({"index": t, "texCoord": 1});
    }
    if let Some(t) = lightmap_texture {
        material["extras"] = json!({"prt_lightmap": {"index": t, "texCoord": 1}});
        if let Some(albedo) = m.texture {
            material["extras"]["prt_albedo_texture"] = json!({"index": albedo, "texCoord": 0});
        }
    }
    material
}
