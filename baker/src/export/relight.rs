//! `prt-bake relight`: a bake lit by a light rig on the CPU, written as a coloured mesh (vertex
//! bakes) or a lightmap image (texel bakes: tone-mapped PNG, or linear OpenEXR).
//!
//! Per vertex and colour channel c, outgoing radiance = albedo_c · Σ_j T_j·L_cj, with T the
//! stored transfer (channel c's own when the file holds three, the grey one otherwise), L the
//! rig projected at the file's order, and albedo the scene's linear Kd × texture at the
//! vertex. This is the reference a GPU viewer must reproduce, and a way to look at a bake
//! without one.
//!
//! The 8-bit colour is tone-mapped by the simplest operator that leaves radiance in [0, 1]
//! untouched: scale by 2^exposure, clamp to [0, 1] (negative SH ringing shows black, anything
//! above 1 white), and encode with the sRGB transfer curve. The float radiance beside it is
//! not tone-mapped.
//!
//! Transfer-matrix bakes (plain or CPCA-compressed) are rendered by
//! [`crate::export::relight_glossy`]: diffuse without a view, glossy with one.

use std::path::Path;

use glam::Vec3;

use crate::formats::coefficient_file::CoefficientFile;
use crate::formats::cpca_block;
use crate::formats::header::TransferKind;
use crate::formats::ply::ColouredMesh;
use crate::light::{LightCoefficients, Rig};
use crate::math::cpca::Cpca;
use crate::scene::Scene;
use crate::support::error::Result;

/// Per-vertex linear RGB radiance of a bake lit by `light` (of the file's order).
pub fn vertex_radiance(
    file: &CoefficientFile,
    albedo: &[Vec3],
    light: &LightCoefficients,
) -> Vec<[f32; 3]> {
    assert_eq!(
        light.order(),
        file.header.order as usize,
        "light and transfer orders differ"
    );
    let channels = file.header.channels as usize;
    albedo
        .iter()
        .enumerate()
        .map(|(v, a)| {
            let mut radiance = [0.0f32; 3];
            for (c, out) in radiance.iter_mut().enumerate() {
                let transfer = file.vertex(v, if channels == 3 { c } else { 0 });
                let dot: f64 = transfer
                    .iter()
                    .zip(&light.rgb[c])
                    .map(|(t, l)| f64::from(*t) * l)
                    .sum();
                *out = (f64::from(a[c]) * dot) as f32;
            }
            radiance
        })
        .collect()
}

/// The display colour of a linear radiance: × 2^exposure, clamped to [0, 1], sRGB-encoded.
pub fn display_colour(radiance: [f32; 3], exposure: f64) -> [u8; 3] {
    let scale = exposure.exp2() as f32;
    radiance.map(|x| {
        let x = (x * scale).clamp(0.0, 1.0);
        let encoded = if x <= 0.003_130_8 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        };
        (encoded * 255.0).round() as u8
    })
}

/// What [`relight`] did, for the CLI's summary line.
#[derive(Clone, Debug)]
pub struct Relit {
    /// Vertices lit, or a lightmap's texels (W·H).
    pub vertex_count: usize,
    /// Whether the bake was a lightmap (texel) bake, written as an image.
    pub lightmap: bool,
    pub order: usize,
    pub light_count: usize,
    /// The largest radiance of any channel at any vertex.
    pub max_radiance: f32,
    /// Whether the file held transfer matrices.
    pub matrix: bool,
}

impl Relit {
    /// Vector transfer lit at `vertex_count` vertices by `rig` at `order`, before the PLY
    /// writer fills in the largest radiance.
    pub fn vertices(vertex_count: usize, order: usize, rig: &Rig) -> Relit {
        Relit {
            vertex_count,
            lightmap: false,
            order,
            light_count: rig.lights.len(),
            max_radiance: 0.0,
            matrix: false,
        }
    }
}

/// Lights the bake `coefficients` of `scene` with the rig and writes `output` (PLY, see
/// [`crate::formats::ply`]) atomically. Refuses a coefficient file baked for another scene.
pub fn relight(
    scene: &Path,
    coefficients: &Path,
    rig: &Path,
    output: &Path,
    exposure: f64,
) -> Result<Relit> {
    relight_from(scene, coefficients, rig, output, exposure, None)
}

/// [`relight`], seen from `eye` (a camera position in the scene's coordinates) if given: a
/// transfer-matrix bake then adds each material's glossy layer
/// ([`crate::export::relight_glossy`]). A view is refused for a vector bake, which has no
/// view dependence to render.
pub fn relight_from(
    scene: &Path,
    coefficients: &Path,
    rig: &Path,
    output: &Path,
    exposure: f64,
    eye: Option<Vec3>,
) -> Result<Relit> {
    let rig = Rig::load(rig)?;
    let (file, cpca) = read_with_cpca(coefficients)?;
    let matrix = file.header.transfer == TransferKind::Matrix;
    if eye.is_some() && !matrix {
        return Err(crate::Error::InvalidOption(format!(
            "{}: --view renders the glossy layer of a transfer-matrix bake (bake --transfer \
             matrix); this file holds diffuse transfer vectors",
            coefficients.display()
        )));
    }
    let scene_path = scene;
    let scene = file.load_scene(scene)?;
    if file.lightmap.is_some() {
        return relight_lightmap(&file, coefficients, &scene, &rig, output, exposure);
    }
    match matrix {
        true => file.check_scene_of_any_transfer(coefficients, &scene)?,
        false => file.check_scene(coefficients, &scene)?,
    }
    // A bake of some objects (`bake --receivers`): the others are relit unshadowed.
    let file = file.spread_to_scene(coefficients, &scene)?;
    refuse_image_output(output, PER_VERTEX_TO_MESH)?;
    let output = relight_output(&scene, &[coefficients], &rig, output)?;
    let order = file.header.order as usize;
    // Rigs are written for a z-up world; a y-up bake gets them turned to its up axis.
    let light = rig.project(order).in_scene_frame(file.header.up);
    let albedo = scene.vertex_albedo();
    let radiance = match matrix {
        true => {
            let receivers = crate::export::relight_glossy::Receivers::of_scene(&scene, &albedo);
            crate::export::relight_glossy::matrix_vertex_radiance(
                &file,
                cpca.as_ref(),
                &receivers,
                &light,
                eye,
            )
        }
        false => vertex_radiance(&file, &albedo, &light),
    };
    let view = match eye {
        Some(e) => format!(", seen from ({}, {}, {})", e.x, e.y, e.z),
        None if matrix => ", diffuse (no --view)".into(),
        None => String::new(),
    };
    let relit = Relit {
        matrix,
        ..Relit::vertices(scene.vertex_count(), order, &rig)
    };
    let comment = format!(
        "prt-bake relight: scene {}, transfer {}, lights {} (order {order}, window {}){view}",
        scene_path.display(),
        coefficients.display(),
        rig.path.display(),
        rig.window.name()
    );
    write_vertex_ply(&output, &scene, &radiance, exposure, comment, relit)
}

/// Writes relit vertices as a PLY (display colours and linear radiance) with `comment` on
/// what was relit, and returns `relit` with its largest radiance.
pub(crate) fn write_vertex_ply(
    output: &crate::support::output::Output,
    scene: &Scene,
    radiance: &[[f32; 3]],
    exposure: f64,
    comment: String,
    relit: Relit,
) -> Result<Relit> {
    let colours: Vec<[u8; 3]> = radiance
        .iter()
        .map(|r| display_colour(*r, exposure))
        .collect();
    let mesh = ColouredMesh {
        positions: &scene.positions,
        normals: &scene.normals,
        colours: &colours,
        radiance,
        triangles: &scene.triangles,
        comments: vec![
            comment,
            format!(
                "radiance_*: linear outgoing radiance; red green blue: radiance x 2^{exposure}, clamped to [0, 1], sRGB-encoded"
            ),
        ],
    };
    output.write(&mesh.to_bytes())?;
    Ok(Relit {
        max_radiance: radiance.iter().flatten().fold(0.0, |a, &b| a.max(b)),
        ..relit
    })
}

/// A coefficient file of any version, and for a compressed matrix file its CPCA form too
/// (rendered by projecting the light per cluster; compressed vector files are relit from
/// their reconstruction, as before).
pub(crate) fn read_with_cpca(path: &Path) -> Result<(CoefficientFile, Option<Cpca>)> {
    let bytes = crate::support::limits::read_file(path)?;
    if !cpca_block::is_compressed(&bytes) {
        let file = CoefficientFile::from_bytes(&bytes)
            .map_err(|message| crate::Error::coefficient_file(path, message))?;
        return Ok((file, None));
    }
    let compressed = cpca_block::from_bytes(&bytes)
        .map_err(|message| crate::Error::coefficient_file(path, message))?;
    let matrix = compressed.file.header.transfer == TransferKind::Matrix;
    Ok((compressed.file, matrix.then_some(compressed.cpca)))
}

/// The lightmap image formats `relight` writes, by the output's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ImageFormat {
    Png,
    Exr,
}

/// Whether `output` names an image (.png, .exr) rather than a mesh.
/// The write of a relit `output`, refused where it would overwrite the scene's files, the
/// `files` relit or the rig's.
pub(crate) fn relight_output(
    scene: &Scene,
    files: &[&Path],
    rig: &Rig,
    output: &Path,
) -> Result<crate::support::output::Output> {
    let mut inputs = scene.input_files();
    inputs.extend(files.iter().map(|f| f.to_path_buf()));
    inputs.extend(rig.input_files());
    crate::support::output::Output::new(output, &inputs)
}

/// Why a per-vertex bake refuses an image output.
pub(crate) const PER_VERTEX_TO_MESH: &str =
    "a per-vertex bake relights to a .ply mesh; images are for lightmap bakes";

/// Refuses an image `output` for a bake that relights to a mesh: `what` says which bake and
/// why (the error is "OUTPUT: WHAT").
pub(crate) fn refuse_image_output(output: &Path, what: &str) -> Result<()> {
    match image_format(output) {
        Some(_) => Err(crate::Error::InvalidOption(format!(
            "{}: {what}",
            output.display()
        ))),
        None => Ok(()),
    }
}

pub(crate) fn image_format(output: &Path) -> Option<ImageFormat> {
    let extension = output.extension()?.to_str()?.to_ascii_lowercase();
    match extension.as_str() {
        "png" => Some(ImageFormat::Png),
        "exr" => Some(ImageFormat::Exr),
        _ => None,
    }
}

/// A lightmap (texel) bake lit by the rig (turned to the bake's up axis), written as a W×H
/// image: per texel Σ_j T_j·L_cj, the light a surface of albedo 1 reflects there (the
/// renderer multiplies by its albedo). A `.png` gets [`display_colour`]'s tone mapping; an
/// `.exr` the linear values as they are (f32 RGBA, no exposure, no clamp, no sRGB curve;
/// A = 1 where the texel holds transfer, baked or dilated, 0 where it is empty). Rows as
/// [`crate::formats::openexr`] states: image row r is texel row H−1−r (the top row is v = 1 of the
/// file's UVs, v = 0 of glTF's TEXCOORD_1). Empty texels are black.
fn relight_lightmap(
    file: &CoefficientFile,
    coefficients: &Path,
    scene: &Scene,
    rig: &Rig,
    output: &Path,
    exposure: f64,
) -> Result<Relit> {
    let block = file.check_lightmap_scene(coefficients, scene)?;
    let Some(format) = image_format(output) else {
        return Err(crate::Error::InvalidOption(format!(
            "{}: a lightmap bake relights to a .png or .exr image",
            output.display()
        )));
    };
    let output_policy = relight_output(scene, &[coefficients], rig, output)?;
    let order = file.header.order as usize;
    let light = rig.project(order).in_scene_frame(file.header.up);
    let (w, h) = (block.width as usize, block.height as usize);
    let radiance = lightmap_radiance(file, &light);
    let bytes = lightmap_image(block, &radiance, format, output, exposure)?;
    output_policy.write(&bytes)?;
    Ok(Relit {
        vertex_count: w * h,
        lightmap: true,
        order,
        light_count: rig.lights.len(),
        max_radiance: radiance.iter().flatten().fold(0.0, |a, &b| a.max(b)),
        matrix: false,
    })
}

/// The image bytes of per-texel radiance (texel order) in `format`: tone-mapped PNG, or
/// linear OpenEXR with A = 1 where the texel holds transfer (see [`relight_lightmap`]).
pub(crate) fn lightmap_image(
    block: &crate::formats::coefficient_file::LightmapBlock,
    radiance: &[[f32; 3]],
    format: ImageFormat,
    output: &Path,
    exposure: f64,
) -> Result<Vec<u8>> {
    let (w, h) = (block.width as usize, block.height as usize);
    let rows = crate::formats::openexr::image_rows(radiance, w, h);
    Ok(match format {
        ImageFormat::Png => png_bytes(&rows, block.width, block.height, exposure, output)?,
        ImageFormat::Exr => {
            let filled: Vec<f32> = (0..w * h)
                .map(|t| f32::from(u8::from(block.valid[t] || block.dilated[t])))
                .collect();
            let channel = |c: usize| rows.iter().map(|r| r[c]).collect::<Vec<f32>>();
            crate::formats::openexr::encode(
                output,
                w,
                h,
                vec![
                    ("R", channel(0)),
                    ("G", channel(1)),
                    ("B", channel(2)),
                    ("A", crate::formats::openexr::image_rows(&filled, w, h)),
                ],
                crate::formats::openexr::PixelType::F32,
            )?
        }
    })
}

/// An 8-bit sRGB PNG of linear radiances given in image rows, tone-mapped by
/// [`display_colour`]; `path` names the image in errors.
pub fn png_bytes(
    rows: &[[f32; 3]],
    width: u32,
    height: u32,
    exposure: f64,
    path: &Path,
) -> Result<Vec<u8>> {
    let pixels: Vec<u8> = rows
        .iter()
        .flat_map(|r| display_colour(*r, exposure))
        .collect();
    crate::formats::png::encode(&pixels, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|err| crate::Error::io(path, std::io::Error::other(err)))
}

/// Per texel (texel order) Σ_j T_j·L_cj: the linear light a surface of albedo 1 reflects.
/// `light` is in the bake's frame.
pub fn lightmap_radiance(file: &CoefficientFile, light: &LightCoefficients) -> Vec<[f32; 3]> {
    let texels = file.header.vertex_count as usize;
    vertex_radiance(file, &vec![Vec3::ONE; texels], light)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file of order 1 (one coefficient per channel) holding `coefficients`.
    fn file(channels: u32, coefficients: Vec<f32>) -> CoefficientFile {
        let vertices = (coefficients.len() / channels as usize) as u64;
        crate::formats::coefficient_file::fixture(1, channels, vertices, coefficients)
    }

    #[test]
    fn grey_transfer_serves_every_channel_and_rgb_transfer_its_own() {
        let light = LightCoefficients::tinted(1, &[1.0], glam::DVec3::new(10.0, 100.0, 1000.0));
        let albedo = [Vec3::ONE, Vec3::splat(0.5)];
        let grey = vertex_radiance(&file(1, vec![1.0, 4.0]), &albedo, &light);
        assert_eq!(grey, [[10.0, 100.0, 1000.0], [20.0, 200.0, 2000.0]]);
        let rgb = vertex_radiance(
            &file(3, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
            &albedo,
            &light,
        );
        assert_eq!(rgb, [[10.0, 200.0, 3000.0], [20.0, 250.0, 3000.0]]);
    }

    #[test]
    fn display_colour_clamps_and_encodes_srgb() {
        assert_eq!(display_colour([0.0, 1.0, 2.0], 0.0), [0, 255, 255]);
        assert_eq!(display_colour([-0.5, 0.5, 0.25], 1.0), [0, 255, 188]);
        // The inverse of the texture decoder at every 8-bit value.
        for k in 0..=255u8 {
            let linear = crate::scene::srgb_to_linear(f32::from(k) / 255.0);
            assert_eq!(display_colour([linear; 3], 0.0), [k; 3]);
        }
    }
}
