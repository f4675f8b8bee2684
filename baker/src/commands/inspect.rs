//! `prt-bake inspect`: a coefficient file's (or a shard part's) header as JSON.

use std::path::Path;

use prt_baker::bake::adaptive::Summary;
use prt_baker::distribute::probe_parts::ProbePart;
use prt_baker::distribute::shard::{Part, PartId};
use prt_baker::formats::coefficient_file::LightmapBlock;
use prt_baker::formats::cpca_block::annotate_inspect;
use prt_baker::formats::header::{AtlasSource, HEADER_SIZE};
use prt_baker::support::limits;
use prt_baker::{CoefficientFile, Error};

pub fn run(path: &Path) -> Result<(), Error> {
    let bytes = limits::read_file(path)?;
    let is_part =
        bytes.len() >= HEADER_SIZE && matches!(PartId::from_header_bytes(&bytes), Ok(Some(_)));
    let json = if prt_baker::formats::ldprt_file::is_ldprt(&bytes) {
        prt_baker::formats::ldprt_file::LdprtFile::read(path)?.inspect_json()
    } else if ProbePart::is_probe_part(&bytes) {
        // A probe bake's part: its header, the shard and probes it holds, the bake's grid.
        let part = ProbePart::read(path)?;
        let mut json = serde_json::to_value(&part.header).expect("the header serialises");
        json["shard"] = serde_json::to_value(part.id).expect("the identity serialises");
        json["probes"] = serde_json::json!({ "count": part.header.vertex_count });
        if let Some(g) = &part.grid {
            json["probes"]["grid"] = serde_json::json!({
                "counts": g.counts,
                "lo": g.lo.to_array(),
                "hi": g.hi.to_array(),
            });
        }
        json
    } else if is_part {
        // A shard part: its header, plus which shard and vertices it holds.
        let part = Part::read(path)?;
        let mut json = serde_json::to_value(&part.header).expect("the header serialises");
        json["shard"] = serde_json::to_value(part.id).expect("the identity serialises");
        if let Some(l) = &part.lightmap {
            // A texel bake's part: its "vertices" are baked texels of this lightmap.
            json["lightmap"] = serde_json::json!({
                "width": l.width,
                "height": l.height,
                "baked_texels": l.receivers,
                "atlas_fingerprint": format!("{:016x}", l.fingerprint),
            });
        }
        json
    } else {
        let mut json = file_json(&CoefficientFile::read(path)?);
        // Version-2 files: how they were compressed.
        annotate_inspect(&bytes, &mut json);
        json
    };
    let json = serde_json::to_string_pretty(&json).expect("JSON serialises");
    println!("{json}");
    Ok(())
}

/// A whole file's header, with summaries of its per-vertex arrays and its lightmap block.
fn file_json(file: &CoefficientFile) -> serde_json::Value {
    let mut json = serde_json::to_value(&file.header).expect("the header serialises");
    // Adaptive bakes: how the per-vertex (per baked texel) rays and estimated errors are
    // distributed.
    if let (Some(adaptive), Some(rays), Some(errors)) =
        (file.header.adaptive, &file.rays, &file.error_estimate)
    {
        let (key, summary) = match &file.lightmap {
            Some(l) => {
                let baked = |t: &usize| l.valid[*t];
                let rays: Vec<u32> = (0..rays.len()).filter(baked).map(|t| rays[t]).collect();
                let errors: Vec<f32> = (0..errors.len()).filter(baked).map(|t| errors[t]).collect();
                (
                    "per_texel",
                    Summary::new(adaptive.target_error, &rays, &errors),
                )
            }
            None => (
                "per_vertex",
                Summary::new(adaptive.target_error, rays, errors),
            ),
        };
        json[key] = serde_json::to_value(summary).expect("the summary serialises");
    }
    if let Some(l) = &file.lightmap {
        json["lightmap"] = lightmap_json(l);
    }
    if let Some(p) = &file.probes {
        // Probe bakes: the "vertices" are the probes; their count and the box they fill.
        let (lo, hi) = p.positions.iter().fold(
            (glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY),
            |(lo, hi), x| (lo.min(*x), hi.max(*x)),
        );
        json["probes"] = serde_json::json!({
            "count": p.positions.len(),
            "min": lo.to_array(),
            "max": hi.to_array(),
        });
        if let Some(g) = &p.grid {
            json["probes"]["grid"] = serde_json::json!({
                "counts": g.counts,
                "lo": g.lo.to_array(),
                "hi": g.hi.to_array(),
            });
        }
    }
    json
}

/// Texel bakes: the lightmap block.
fn lightmap_json(l: &LightmapBlock) -> serde_json::Value {
    let texels = |flags: &[bool]| flags.iter().filter(|&&f| f).count();
    let mut json = serde_json::json!({
        "width": l.width,
        "height": l.height,
        "baked_texels": texels(&l.valid),
        "dilated_texels": texels(&l.dilated),
        "texel_size": l.texel_size,
        "atlas": l.source.name(),
        "scene_vertex_count": l.scene_vertex_count,
        "scene_triangle_count": l.scene_triangle_count,
    });
    // Per-object atlases: where each object's own UVs went (atlas uv = uv × scale + offset,
    // v up), in the scene's object order.
    if l.source == AtlasSource::PerObject {
        let objects: Vec<serde_json::Value> = l
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| {
                serde_json::json!({"object": i, "scale": o.scale, "offset": o.offset, "uvs": o.uvs.name()})
            })
            .collect();
        json["objects"] = serde_json::json!(objects);
    }
    json
}
