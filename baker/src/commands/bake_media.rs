//! `prt-bake bake`'s subsurface media: a glTF scene's own (`KHR_materials_volume` with
//! `KHR_materials_diffuse_transmission`), overridden per material name by `--materials`; and
//! the bakes that cannot take them refused as usage errors before anything is traced
//! (docs/guides/subsurface.md).

use std::path::Path;

use prt_baker::bake::options::TransferKind;
use prt_baker::math::medium::Medium;
use prt_baker::scene::{Materials, gltf_media};
use prt_baker::{BakeOptions, Error, Scene};

/// Per scene material, its medium (`None`: opaque): the materials file `materials` where it
/// names the material, else the glTF file's; empty where there are none. `in_parts`: the
/// bake is sharded or checkpointed.
pub fn media(
    scene: &Scene,
    materials: Option<&Path>,
    options: &BakeOptions,
    in_parts: bool,
) -> Result<Vec<Option<Medium>>, Error> {
    let is_gltf = scene
        .path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"));
    let from_gltf = match is_gltf {
        true => gltf_media(&scene.path)?,
        false => Default::default(),
    };
    for warning in &from_gltf.warnings {
        eprintln!("warning: {}: {warning}", scene.path.display());
    }
    let file = materials.map(Materials::load).transpose()?;
    let from_file = match &file {
        Some(m) => m.media_for(&scene.path, &scene.materials)?,
        None => vec![None; scene.materials.len()],
    };
    let media: Vec<Option<Medium>> = scene
        .materials
        .iter()
        .zip(from_file)
        .map(|(material, given)| {
            let named = file
                .as_ref()
                .is_some_and(|f| f.entries.iter().any(|e| e.name == material.name));
            match named {
                true => given,
                false => from_gltf
                    .media
                    .iter()
                    .find(|(name, _)| *name == material.name)
                    .map(|(_, m)| *m),
            }
        })
        .collect();
    if !media.iter().any(Option::is_some) {
        return Ok(media);
    }
    let refuse = |why: &str| {
        Err(Error::InvalidOption(format!(
            "a subsurface medium (--materials, or the glTF's KHR_materials_volume) {why}"
        )))
    };
    if !options.mode.casts_rays() {
        return refuse("needs rays: use --mode shadowed or interreflected");
    }
    if options.transfer != TransferKind::Vector {
        return refuse("needs --transfer vector");
    }
    if in_parts {
        return refuse("bakes whole files (not with --shard or --checkpoint yet)");
    }
    Ok(media)
}
