//! Step 5 of the export: `asset.extras.prt`, the conventions and what the file holds
//! (docs/gltf.md).

use serde_json::{Value, json};

use super::light::{light_in_gltf_frame, light_json};
use super::{Contents, LightmapContents, Materials, VertexTransfer};
use crate::formats::header::TransferKind;
use crate::math::sh;

/// Step 5: `asset.extras.prt`, the conventions and what the file holds.
pub(super) fn asset_extras(
    contents: &Contents<'_>,
    transfer: &VertexTransfer,
    lightmap: Option<&LightmapContents<'_>>,
    materials: &Materials,
    cpca: Option<Value>,
) -> Option<Value> {
    if let Some(file) = contents.file {
        let h = &file.header;
        let mut prt = json!({
            "order": h.order,
            "channels": h.channels,
            "attributes": transfer.names,
            "coefficients_per_channel": sh::coeff_count(h.order as usize),
            "convention": "real orthonormal SH, index l(l+1)+m, Condon-Shortley phase, of \
                directions in this file's coordinates (theta from +z, phi from +x towards +y); \
                transfer excludes the albedo (the base colour)",
            "mode": h.mode.name(),
            "transfer": h.transfer.name(),
            "colour_0": match (transfer.colour.is_some(), h.transfer) {
                (false, _) => "absent",
                (true, TransferKind::Vector) => "transfer . light per channel, clamped to [0, 1]; times the base colour it is the relit radiance",
                (true, TransferKind::Matrix) => "the diffuse render (the glossy layers left out) per channel with albedo 1, clamped to [0, 1]; times the base colour it is the diffuse radiance",
            },
        });
        if transfer.ao.is_some() {
            prt["ao"] = json!("_AO: SCALAR float, the ambient accessibility per vertex");
        }
        if let Some(light) = contents.light {
            prt["light"] = light_json(&light_in_gltf_frame(light, contents.up));
        }
        if let Some(cpca) = cpca {
            prt["cpca"] = cpca;
        }
        if let Some((q, scales)) = &transfer.quantized {
            let scales: serde_json::Map<String, Value> = transfer
                .names
                .iter()
                .zip(scales)
                .map(|(name, scale)| (name.clone(), json!(scale)))
                .collect();
            prt["quantization"] = json!({
                "bits": q.bits(),
                "scales": scales,
                "decode": "transfer = attribute (normalized signed integer, in [-1, 1]) x its scale",
            });
        }
        return Some(json!({ "prt": prt }));
    }
    let l = lightmap?;
    let h = &l.file.header;
    let mut lightmap_json = json!({
        "width": l.width,
        "height": l.height,
        "texCoord": 1,
        "uv_convention": "glTF's: v down from the image's top; row 0 of the \
            lightmap images prt-bake writes (export --exr, relight) is v = 0",
        "transfer": "per texel, not in this file: prt-bake export --exr writes it \
            as images (manifest.json)",
        "texture": materials.lightmap_texture,
        "texture_holds": if materials.lightmap_texture.is_some() { "transfer . light per channel (albedo 1), clamped to [0, 1], sRGB-encoded; times the base colour it is the relit radiance" } else { "absent" },
    });
    if let Some(t) = materials.lightmap_texture {
        lightmap_json["material_slot"] = json!(format!(
            "every material's baseColorTexture (texCoord 1), unlit (KHR_materials_unlit): texture {t}"
        ));
    }
    if let Some(t) = materials.occlusion_texture {
        lightmap_json["ao_texture"] = json!(t);
    }
    let mut prt = json!({
        "order": h.order,
        "channels": h.channels,
        "mode": h.mode.name(),
        "lightmap": lightmap_json,
    });
    if let Some(light) = &l.light {
        prt["light"] = light_json(light);
    }
    Some(json!({ "prt": prt }))
}
