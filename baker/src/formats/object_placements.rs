//! The trailing section of a texel file whose atlas packs each object's own lightmap UVs
//! with a scale and offset ([`AtlasSource::PerObject`](crate::formats::header::AtlasSource)):
//! a u32 object count, then per object its scale (2 × f32), offset (2 × f32) and which UVs
//! they map (u32, [`ObjectUvs`]). Files with other atlases have no such section, so their
//! bytes are what they were before it existed (docs/reference/coefficient-format.md).

use crate::formats::header::{Header, OBJECT_PLACEMENT_BYTES, ObjectPlacement, ObjectUvs};

/// The section's bytes.
pub(crate) fn encode(objects: &[ObjectPlacement]) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(4 + OBJECT_PLACEMENT_BYTES * objects.len());
    bytes.extend((objects.len() as u32).to_le_bytes());
    for o in objects {
        let floats = o.scale.iter().chain(&o.offset);
        bytes.extend(floats.flat_map(|x| x.to_le_bytes()));
        bytes.extend(o.uvs.code().to_le_bytes());
    }
    bytes
}

/// The section's length, given the bytes the arrays `needed` (None: overflowed) and the
/// announced `payload`: whatever the payload holds beyond the arrays must be a count and
/// whole placements for a per-object atlas, and nothing for any other file.
pub(crate) fn section_bytes(
    header: &Header,
    needed: Option<u64>,
    payload: u64,
    per_object: bool,
) -> Result<u64, String> {
    let section = match needed {
        Some(n) if per_object => payload
            .checked_sub(n)
            .filter(|s| *s >= 4 && (s - 4) % OBJECT_PLACEMENT_BYTES as u64 == 0),
        Some(n) if n == payload => Some(0),
        _ => None,
    };
    section.ok_or_else(|| {
        format!(
            "{} vertices × {} coefficients need {} bytes{}, the header announces {payload}",
            header.vertex_count,
            header.coefficients_per_vertex(),
            needed.map_or_else(|| "more than 2^64".into(), |n| n.to_string()),
            match per_object {
                true =>
                    format!(" and a per-object section (4 + {OBJECT_PLACEMENT_BYTES} per object)"),
                false => String::new(),
            }
        )
    })
}

/// Reads and checks a section (empty: no placements): the count matches, every scale is
/// positive and finite, every offset finite (or the object left out: scale 0, offset
/// (−1, −1)), every kind known.
pub(crate) fn decode(section: &[u8]) -> Result<Vec<ObjectPlacement>, String> {
    if section.is_empty() {
        return Ok(Vec::new());
    }
    let count = (section.len() - 4) / OBJECT_PLACEMENT_BYTES;
    let stored = u32::from_le_bytes(section[..4].try_into().expect("4 bytes"));
    if stored as usize != count {
        return Err(format!(
            "the per-object section holds {count} placements, its count says {stored}"
        ));
    }
    let mut objects = Vec::with_capacity(count);
    for (i, entry) in section[4..]
        .chunks_exact(OBJECT_PLACEMENT_BYTES)
        .enumerate()
    {
        let word = |k: usize| entry[4 * k..4 * k + 4].try_into().expect("4 bytes");
        let f = |k: usize| f32::from_le_bytes(word(k));
        let (scale, offset) = ([f(0), f(1)], [f(2), f(3)]);
        let code = u32::from_le_bytes(word(4));
        let uvs = ObjectUvs::from_code(code)
            .ok_or_else(|| format!("object {i}: unknown lightmap UV kind {code}"))?;
        // Scale 0 at (−1, −1): an object left out of the atlas (`bake --receivers`).
        let left_out = scale == [0.0; 2] && offset == [-1.0; 2];
        let placed =
            scale.iter().all(|s| s.is_finite() && *s > 0.0) && offset.iter().all(|o| o.is_finite());
        if !(left_out || placed) {
            return Err(format!(
                "object {i}: lightmap scale {scale:?} and offset {offset:?} are not a placement"
            ));
        }
        objects.push(ObjectPlacement { scale, offset, uvs });
    }
    Ok(objects)
}
