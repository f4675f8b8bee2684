//! What a part of a denoised bake carries so that the merge can denoise without the scene:
//! each receiver's noise estimate and the denoiser's guides ([`Guides`]), 12 little-endian
//! words a receiver (docs/reference/coefficient-format.md, "Denoised parts").
//!
//! The denoiser's weights mix every receiver with its neighbours, which may lie in another
//! part, so no shard can denoise its own receivers: the filter runs where every receiver is
//! in, the merge (or a checkpointed bake's join). Carrying the guides costs 48 bytes a
//! receiver and keeps the merge free of the scene, its atlas and the prepared lightmap (a
//! merge that rebuilt them would load the scene and read the preparation again, fixed costs
//! every stage of a distributed bake already pays once too often).

use glam::Vec3;

use crate::bake::denoise::Guides;

/// Words (4 bytes) per receiver: noise, point (3), shading normal (3), surface normal (3),
/// group, spacing.
pub const GUIDE_WORDS: usize = 12;

/// The words of `guides`, receiver by receiver.
pub fn guide_bytes(guides: &Guides) -> Vec<u8> {
    let mut out = Vec::with_capacity(guides.points.len() * GUIDE_WORDS * 4);
    for i in 0..guides.points.len() {
        out.extend(guides.noise[i].to_le_bytes());
        for v in [guides.points[i], guides.normals[i], guides.surfaces[i]] {
            for f in v.to_array() {
                out.extend(f.to_le_bytes());
            }
        }
        out.extend(guides.groups[i].to_le_bytes());
        out.extend(guides.spacing[i].to_le_bytes());
    }
    out
}

/// The guides of `count` receivers from `bytes` (exactly their words); the error names the
/// first receiver (counting from the part's first) whose words no denoiser can use.
pub fn parse_guides(bytes: &[u8], count: usize) -> Result<Guides, String> {
    debug_assert_eq!(bytes.len(), count * GUIDE_WORDS * 4);
    let mut guides = Guides::default();
    for (i, words) in bytes.chunks_exact(GUIDE_WORDS * 4).enumerate() {
        let word = |k: usize| u32::from_le_bytes(words[4 * k..4 * k + 4].try_into().expect("4"));
        let float = |k: usize| f32::from_bits(word(k));
        let vec = |k: usize| Vec3::new(float(k), float(k + 1), float(k + 2));
        let (noise, point, normal, surface) = (float(0), vec(1), vec(4), vec(7));
        let spacing = float(11);
        let bad = match () {
            _ if !(noise >= 0.0 && noise.is_finite()) => "its noise is not a finite variance",
            _ if !point.is_finite() => "its point is not finite",
            _ if !normal.is_finite() || !surface.is_finite() => "a normal is not finite",
            _ if !(spacing > 0.0 && spacing.is_finite()) => "its spacing is not positive",
            _ => "",
        };
        if !bad.is_empty() {
            return Err(format!("the denoiser's guides of receiver {i}: {bad}"));
        }
        guides.noise.push(noise);
        guides.points.push(point);
        guides.normals.push(normal);
        guides.surfaces.push(surface);
        guides.groups.push(word(10));
        guides.spacing.push(spacing);
    }
    Ok(guides)
}
