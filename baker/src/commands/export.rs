//! `prt-bake export`: a bake as NumPy arrays, binary glTF or OpenEXR images.

use std::io::Read;
use std::path::{Path, PathBuf};

use clap::ValueEnum;
use prt_baker::Error;
use prt_baker::support::output::Output;

#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("outputs").required(true).multiple(true).args(["npz", "gltf", "exr"])))]
pub struct ExportArgs {
    /// The .prt file, or an LDPRT file (`bake --transfer ldprt` of a skinned .glb): with
    /// --gltf alone, its lobes are written into a copy of that .glb (docs/guides/characters.md).
    file: PathBuf,
    /// The scene it was baked from.
    #[arg(long)]
    scene: PathBuf,
    /// Output .npz file (positions, normals, albedo, transfer, uv, triangles, aux arrays).
    #[arg(long)]
    npz: Option<PathBuf>,
    /// Output .glb file: the scene in world space, y up, with the transfer as `_PRT_k`
    /// vertex attributes, or for a lightmap bake with its lightmap UVs as TEXCOORD_1
    /// (docs/reference/gltf.md).
    #[arg(long, visible_alias = "glb")]
    gltf: Option<PathBuf>,
    /// With --gltf: a light rig (TOML) whose relit shading goes into COLOR_0 (vertex bakes)
    /// or into an embedded lightmap texture (lightmap bakes).
    #[arg(long, requires = "gltf")]
    lights: Option<PathBuf>,
    /// With --gltf: the transfer attributes as normalized 16- or 8-bit integers, a scale per
    /// attribute (docs/reference/gltf.md); float without it.
    #[arg(long, value_name = "BITS", requires = "gltf")]
    quantize: Option<u32>,
    /// Output directory (created if missing) for a lightmap bake's coefficients as OpenEXR
    /// images, 4 per RGBA image, with the texel mask, AO, bent normals and a manifest.json
    /// (docs/guides/lightmaps.md).
    #[arg(long, value_name = "DIR")]
    exr: Option<PathBuf>,
    /// With --exr: the images' pixel type.
    #[arg(long, value_enum, default_value_t = ExrTypeArg::F32, requires = "exr")]
    exr_type: ExrTypeArg,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
pub enum ExrTypeArg {
    /// 16-bit half floats (11 significant bits).
    F16,
    /// 32-bit floats: the .prt's values exactly.
    F32,
}

pub fn run(args: ExportArgs) -> Result<(), Error> {
    // Checked before the inputs are read; the writers check again against all of them.
    let mut inputs = vec![args.file.clone(), args.scene.clone()];
    inputs.extend(args.lights.clone());
    for output in args.npz.iter().chain(&args.gltf) {
        Output::new(output, &inputs)?;
    }
    if let Some(done) = ldprt(&args) {
        return done;
    }
    // First: it refuses a vertex bake before anything is written.
    if let Some(dir) = &args.exr {
        exr(&args, dir)?;
    }
    if let Some(npz) = &args.npz {
        prt_baker::export::numpy::export_npz(&args.file, &args.scene, npz)?;
        println!(
            "wrote {} (NumPy arrays of {})",
            npz.display(),
            args.file.display()
        );
    }
    if let Some(glb) = &args.gltf {
        gltf(&args, glb)?;
    }
    Ok(())
}

/// An LDPRT file: `--gltf` only, its lobes written into the skinned `.glb` it was baked
/// from; `None` for any other file.
fn ldprt(args: &ExportArgs) -> Option<Result<(), Error>> {
    let mut head = [0u8; 8];
    let read = std::fs::File::open(&args.file).and_then(|mut f| f.read(&mut head));
    if !matches!(read, Ok(8)) || !prt_baker::formats::ldprt_file::is_ldprt(&head) {
        return None;
    }
    let (Some(glb), None, None, None, None) = (
        &args.gltf,
        &args.npz,
        &args.exr,
        &args.lights,
        args.quantize,
    ) else {
        return Some(Err(Error::InvalidOption(
            "an LDPRT file exports with --gltf alone (not --npz, --exr, --lights or --quantize)"
                .into(),
        )));
    };
    Some(
        prt_baker::export::ldprt_gltf::export_ldprt_glb(&args.file, &args.scene, glb).map(|w| {
            println!(
                "wrote {} ({} bytes): the skinned glTF kept, {} vertices of {} primitive(s) with \
                 {} lobe(s) in {} attributes ({}..{})",
                glb.display(),
                w.bytes,
                w.vertex_count,
                w.primitives,
                w.lobes,
                w.attributes.len(),
                w.attributes.first().map_or("", String::as_str),
                w.attributes.last().map_or("", String::as_str)
            );
        }),
    )
}

/// `--exr DIR`: a lightmap bake as OpenEXR images.
fn exr(args: &ExportArgs, dir: &Path) -> Result<(), Error> {
    let pixel_type = match args.exr_type {
        ExrTypeArg::F16 => prt_baker::formats::openexr::PixelType::F16,
        ExrTypeArg::F32 => prt_baker::formats::openexr::PixelType::F32,
    };
    let written = prt_baker::export::numpy::export_exr(&args.file, &args.scene, dir, pixel_type)?;
    println!(
        "wrote {} {}×{} {} OpenEXR images of {} and {}",
        written.files.len(),
        written.width,
        written.height,
        pixel_type.name(),
        args.file.display(),
        written.manifest.display()
    );
    Ok(())
}

/// `--gltf OUT.glb`: the scene and the bake as binary glTF, and a summary line.
fn gltf(args: &ExportArgs, glb: &Path) -> Result<(), Error> {
    let written = prt_baker::export::gltf::export_glb_quantized(
        &args.file,
        &args.scene,
        glb,
        args.lights.as_deref(),
        prt_baker::export::gltf::Quantize::from_bits(args.quantize)?,
    )?;
    let prt = match written.prt_attributes.as_slice() {
        [] if written.lightmap.is_some() => {
            let [w, h] = written.lightmap.unwrap_or_default();
            format!(
                "TEXCOORD_1 = the {w}×{h} lightmap's UVs{}",
                if written.lightmap_texture {
                    ", the relit lightmap embedded (materials' extras.prt_lightmap)"
                } else {
                    ""
                }
            )
        }
        [] => String::from("no transfer"),
        _ if written.cpca.is_some() => {
            let (k, m) = written.cpca.unwrap_or_default();
            format!(
                "CPCA transfer ({k} clusters, {m} components) in _PRT_CLUSTER and {} VEC4 \
                 weight attribute(s), the clusters in asset.extras.prt.cpca",
                written.prt_attributes.len()
            )
        }
        [only] => format!("transfer in {only}"),
        [first, .., last] => format!(
            "transfer in {} VEC4 attributes {first}..{last}",
            written.prt_attributes.len()
        ),
    };
    println!(
        "wrote {} ({} bytes): {} vertices, {} triangles, {} material(s), {} texture(s), {prt}{}{}",
        glb.display(),
        written.bytes,
        written.vertex_count,
        written.triangle_count,
        written.materials,
        written.textures,
        if written.colour {
            ", COLOR_0 lit by the rig (unlit materials)"
        } else {
            ""
        },
        if written.turned_to_y_up {
            "; turned from z-up to glTF's y-up"
        } else {
            ""
        },
    );
    Ok(())
}
