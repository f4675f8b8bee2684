//! Subsurface media from a glTF file's materials: `KHR_materials_volume`,
//! `KHR_materials_diffuse_transmission` and `KHR_materials_ior`, read from the raw JSON (the
//! `gltf` crate is built without them), and mapped to the homogeneous medium a subsurface bake
//! walks in (`docs/guides/subsurface.md`, "glTF materials"). An approximation: glTF describes what a
//! real-time renderer shows, not the coefficients of a medium.
//!
//! A material is translucent when it has both a volume (`thicknessFactor` > 0: a closed
//! volume, not thin-walled) and diffuse transmission (`diffuseTransmissionFactor` > 0).
//! Then, per channel:
//!
//! * σa = −ln(attenuationColor) / attenuationDistance: Beer's law, as the volume extension
//!   defines its attenuation (white light turns into attenuationColor after that distance);
//! * the reduced albedo α′ = σs′/σt solves R_d(α′, η) = diffuseTransmissionColorFactor, the
//!   dipole's total diffuse reflectance ([`dipole_total_reflectance`]) inverted numerically,
//!   as Jensen & Buhler (2002, "A rapid hierarchical rendering technique for translucent
//!   materials", §2.4) invert it to fit a medium to a measured diffuse colour; so the medium's
//!   multiple-scattering colour is the transmission colour. The target is capped at
//!   [`MAX_DIFFUSE_ALBEDO`] (a colour of 1 would need no absorption at all);
//! * σs′ = σa · α′ / (1 − α′); η = `KHR_materials_ior`'s ior (default 1.5).
//!
//! A channel with no absorption (attenuationColor 1, or no attenuationDistance) leaves the
//! medium without a scale, so such a material stays opaque, with a warning.

use std::path::Path;

use glam::Vec3;
use serde_json::Value;

use crate::math::medium::{Medium, dipole_total_reflectance};
use crate::support::error::{Error, Location, Result};

/// The largest diffuse colour a medium is fitted to (α′ ≈ 0.9999 there).
pub const MAX_DIFFUSE_ALBEDO: f64 = 0.99;

/// What a glTF file's materials say about media: per material name (its `name`, or
/// "material I" as the loader names it), a medium; and a warning per translucent-looking
/// material that stays opaque.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GltfMedia {
    pub media: Vec<(String, Medium)>,
    pub warnings: Vec<String>,
}

/// Reads the media of the glTF file `path` (`.gltf` or `.glb`). Hostile values (negative,
/// non-finite, out of range, attenuationColor 0) are errors naming the file and the material.
pub fn gltf_media(path: &Path) -> Result<GltfMedia> {
    let fail = |message: String| Error::scene(Location::file(path), message);
    let bytes = crate::support::limits::read_file(path)?;
    let json: Vec<u8> = match bytes.starts_with(b"glTF") {
        true => gltf::Glb::from_slice(&bytes)
            .map_err(|err| fail(format!("not a readable GLB file: {err}")))?
            .json
            .into_owned(),
        false => bytes,
    };
    let root: Value = serde_json::from_slice(&json)
        .map_err(|err| fail(format!("not a readable glTF file: {err}")))?;
    let mut out = GltfMedia::default();
    let materials = root.get("materials").and_then(Value::as_array);
    for (index, material) in materials.into_iter().flatten().enumerate() {
        let name = material
            .get("name")
            .and_then(Value::as_str)
            .map_or_else(|| format!("material {index}"), str::to_string);
        let medium = material_medium(material)
            .map_err(|problem| fail(format!("material '{name}': {problem}")))?;
        match medium {
            Mapped::Opaque => {}
            Mapped::Medium(m) => out.media.push((name, m)),
            Mapped::NoScale => out.warnings.push(format!(
                "material '{name}' has KHR_materials_volume and KHR_materials_diffuse_transmission \
                 but no absorption in some channel (attenuationColor 1 or no attenuationDistance): \
                 it bakes opaque; give it a medium with --materials"
            )),
        }
    }
    Ok(out)
}

/// What one material maps to.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Mapped {
    Opaque,
    Medium(Medium),
    /// Translucent, but a channel has no absorption: no scale for the medium.
    NoScale,
}

/// The medium of one glTF material object (see the module doc), or why its values are bad.
fn material_medium(material: &Value) -> std::result::Result<Mapped, String> {
    let extensions = material.get("extensions");
    let extension = |name: &str| extensions.and_then(|e| e.get(name));
    let (volume, diffuse) = (
        extension("KHR_materials_volume"),
        extension("KHR_materials_diffuse_transmission"),
    );
    let (Some(volume), Some(diffuse)) = (volume, diffuse) else {
        return Ok(Mapped::Opaque);
    };
    let thickness = number(volume, "KHR_materials_volume", "thicknessFactor", 0.0)?;
    let distance = number(
        volume,
        "KHR_materials_volume",
        "attenuationDistance",
        f64::INFINITY,
    )?;
    let colour = triple(volume, "KHR_materials_volume", "attenuationColor")?;
    let factor = number(
        diffuse,
        "KHR_materials_diffuse_transmission",
        "diffuseTransmissionFactor",
        0.0,
    )?;
    let transmission = triple(
        diffuse,
        "KHR_materials_diffuse_transmission",
        "diffuseTransmissionColorFactor",
    )?;
    if thickness < 0.0 || distance <= 0.0 || !(0.0..=1.0).contains(&factor) {
        return Err(format!(
            "thicknessFactor {thickness} must be ≥ 0, attenuationDistance {distance} > 0 and \
             diffuseTransmissionFactor {factor} in [0, 1]"
        ));
    }
    if let Some(c) = colour.iter().find(|&&c| c <= 0.0) {
        return Err(format!(
            "KHR_materials_volume attenuationColor {c} absorbs everything (σa = −ln(0)/d is \
             infinite): it must be in (0, 1]"
        ));
    }
    if thickness == 0.0 || factor == 0.0 {
        return Ok(Mapped::Opaque); // thin-walled, or no diffuse transmission
    }
    let ior = match extension("KHR_materials_ior") {
        Some(e) => number(e, "KHR_materials_ior", "ior", 1.5)?,
        None => 1.5,
    };
    if !(1.0..=10.0).contains(&ior) {
        return Err(format!("KHR_materials_ior ior {ior} is not in [1, 10]"));
    }
    let absorption = colour.map(|c| -c.ln() / distance);
    if absorption.iter().any(|&a| a <= 0.0) {
        return Ok(Mapped::NoScale);
    }
    let albedo = transmission.map(|t| reduced_albedo(t.min(MAX_DIFFUSE_ALBEDO), ior));
    let scattering: [f64; 3] =
        std::array::from_fn(|c| absorption[c] * albedo[c] / (1.0 - albedo[c]));
    let vec = |v: [f64; 3]| Vec3::from_array(v.map(|x| x as f32));
    Ok(Mapped::Medium(Medium {
        scattering: vec(scattering),
        absorption: vec(absorption),
        ior: ior as f32,
    }))
}

/// The reduced albedo α′ in [0, 1) whose dipole diffuse reflectance at `eta` is `target` (in
/// [0, 1)), by bisection (R_d rises monotonically from 0 at α′ = 0 to 1 at α′ = 1).
pub fn reduced_albedo(target: f64, eta: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if dipole_total_reflectance(mid, eta) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// `object[key]` as a finite number, `default` where absent.
fn number(
    object: &Value,
    extension: &str,
    key: &str,
    default: f64,
) -> std::result::Result<f64, String> {
    match object.get(key) {
        None => Ok(default),
        Some(v) => v
            .as_f64()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{extension} {key} is {v}, not a finite number")),
    }
}

/// `object[key]` as 3 numbers in [0, 1], white where absent.
fn triple(object: &Value, extension: &str, key: &str) -> std::result::Result<[f64; 3], String> {
    let Some(v) = object.get(key) else {
        return Ok([1.0; 3]);
    };
    let bad = || format!("{extension} {key} is {v}, not 3 numbers in [0, 1]");
    let array = v.as_array().filter(|a| a.len() == 3).ok_or_else(bad)?;
    let mut out = [0.0; 3];
    for (o, x) in out.iter_mut().zip(array) {
        *o = x
            .as_f64()
            .filter(|x| (0.0..=1.0).contains(x))
            .ok_or_else(bad)?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn material(extensions: Value) -> Value {
        serde_json::json!({ "name": "wax", "extensions": extensions })
    }

    #[test]
    fn beers_law_and_the_inverted_dipole() {
        let m = material(serde_json::json!({
            "KHR_materials_volume": {
                "thicknessFactor": 1.0,
                "attenuationDistance": 2.0,
                "attenuationColor": [0.9, 0.5, 0.2]
            },
            "KHR_materials_diffuse_transmission": {
                "diffuseTransmissionFactor": 1.0,
                "diffuseTransmissionColorFactor": [0.8, 0.5, 0.1]
            },
            "KHR_materials_ior": { "ior": 1.3 }
        }));
        let Mapped::Medium(medium) = material_medium(&m).unwrap() else {
            panic!("a medium");
        };
        assert_eq!(medium.ior, 1.3);
        for (c, (colour, target)) in [(0.9f64, 0.8f64), (0.5, 0.5), (0.2, 0.1)]
            .into_iter()
            .enumerate()
        {
            let sigma_a = -colour.ln() / 2.0;
            assert!((f64::from(medium.absorption[c]) - sigma_a).abs() < 1e-6);
            // The medium's dipole colour is the transmission colour.
            let albedo = f64::from(medium.albedo()[c]);
            let rd = dipole_total_reflectance(albedo, 1.3);
            assert!((rd - target).abs() < 1e-4, "channel {c}: {rd} vs {target}");
        }
    }

    #[test]
    fn thin_walled_or_partial_materials_stay_opaque() {
        let volume = serde_json::json!({ "thicknessFactor": 0.0, "attenuationDistance": 1.0, "attenuationColor": [0.5, 0.5, 0.5] });
        let diffuse = serde_json::json!({ "diffuseTransmissionFactor": 1.0 });
        for extensions in [
            serde_json::json!({ "KHR_materials_volume": volume, "KHR_materials_diffuse_transmission": diffuse }),
            serde_json::json!({ "KHR_materials_diffuse_transmission": diffuse }),
            serde_json::json!({}),
        ] {
            assert_eq!(material_medium(&material(extensions)), Ok(Mapped::Opaque));
        }
        let no_absorption = serde_json::json!({
            "KHR_materials_volume": { "thicknessFactor": 1.0 },
            "KHR_materials_diffuse_transmission": diffuse,
        });
        assert_eq!(
            material_medium(&material(no_absorption)),
            Ok(Mapped::NoScale)
        );
    }

    #[test]
    fn hostile_values_are_refused() {
        let diffuse = serde_json::json!({ "diffuseTransmissionFactor": 1.0 });
        for volume in [
            serde_json::json!({ "thicknessFactor": -1.0 }),
            serde_json::json!({ "thicknessFactor": 1.0, "attenuationDistance": -2.0 }),
            serde_json::json!({ "thicknessFactor": 1.0, "attenuationDistance": 1.0, "attenuationColor": [0.0, 0.5, 0.5] }),
            serde_json::json!({ "thicknessFactor": 1.0, "attenuationDistance": 1.0, "attenuationColor": [1.5, 0.5, 0.5] }),
            serde_json::json!({ "thicknessFactor": "thick" }),
        ] {
            let m = material(serde_json::json!({
                "KHR_materials_volume": volume,
                "KHR_materials_diffuse_transmission": diffuse,
            }));
            assert!(material_medium(&m).is_err(), "{m}");
        }
        let ior = material(serde_json::json!({
            "KHR_materials_volume": { "thicknessFactor": 1.0, "attenuationDistance": 1.0, "attenuationColor": [0.5, 0.5, 0.5] },
            "KHR_materials_diffuse_transmission": diffuse,
            "KHR_materials_ior": { "ior": 0.5 },
        }));
        assert!(material_medium(&ior).is_err());
    }
}
