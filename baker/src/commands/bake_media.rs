//! `prt-bake bake --materials`: the scene's subsurface media, and the bakes that cannot take
//! them refused as usage errors before anything is traced (docs/subsurface.md).

use std::path::Path;

use prt_baker::bake::options::TransferKind;
use prt_baker::math::medium::Medium;
use prt_baker::scene::Materials;
use prt_baker::{BakeOptions, Error, Scene};

/// Per scene material, its medium (`None`: opaque), from the materials file `materials`;
/// empty without one.
pub fn media(
    scene: &Scene,
    materials: Option<&Path>,
    options: &BakeOptions,
    receivers: bool,
) -> Result<Vec<Option<Medium>>, Error> {
    let media = match materials.map(Materials::load).transpose()? {
        Some(m) => m.media_for(&scene.path, &scene.materials)?,
        None => Vec::new(),
    };
    if !media.iter().any(Option::is_some) {
        return Ok(media);
    }
    let refuse = |why: &str| {
        Err(Error::InvalidOption(format!(
            "--materials with a subsurface medium {why}"
        )))
    };
    if !options.mode.casts_rays() {
        return refuse("needs rays: use --mode shadowed or interreflected");
    }
    if options.transfer != TransferKind::Vector {
        return refuse("needs --transfer vector");
    }
    if receivers {
        return refuse("bakes every object (not with --receivers yet)");
    }
    Ok(media)
}
