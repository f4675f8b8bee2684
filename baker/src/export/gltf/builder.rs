//! The mechanics of a `.glb`: the binary chunk and its buffer views and accessors, glTF's
//! numbers for OpenGL enums, PNG encoding of embedded textures, and the container's framing.

use serde_json::{Value, json};

use crate::scene::Texture;
use crate::support::error::{Error, Result};

/// `export --quantize`: the transfer attributes as normalized signed integers, each attribute
/// scaled by its largest magnitude (in `asset.extras.prt.quantization.scales`): a shader
/// multiplies the attribute (in [−1, 1]) by its scale, or folds the scale into the light.
/// glTF core allows any component type but unsigned int for custom attributes, so no
/// extension is required (KHR_mesh_quantization would be needed only for POSITION etc.).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantize {
    /// BYTE, normalized: 4 bytes per VEC4 (float: 16).
    Bits8,
    /// SHORT, normalized: 8 bytes per VEC4.
    Bits16,
}

impl Quantize {
    /// `--quantize BITS`: 8, 16, or none.
    pub fn from_bits(bits: Option<u32>) -> Result<Option<Quantize>> {
        match bits {
            None => Ok(None),
            Some(8) => Ok(Some(Quantize::Bits8)),
            Some(16) => Ok(Some(Quantize::Bits16)),
            Some(other) => Err(Error::InvalidOption(format!(
                "--quantize {other}: the transfer quantizes to 16 or 8 bits"
            ))),
        }
    }

    /// The largest code, 2^(bits−1) − 1.
    pub(super) fn max_code(self) -> f32 {
        match self {
            Quantize::Bits8 => 127.0,
            Quantize::Bits16 => 32767.0,
        }
    }

    pub(super) fn bits(self) -> u32 {
        match self {
            Quantize::Bits8 => 8,
            Quantize::Bits16 => 16,
        }
    }

    pub(super) fn component_type(self) -> u32 {
        match self {
            Quantize::Bits8 => BYTE,
            Quantize::Bits16 => SHORT,
        }
    }
}

/// A growing binary chunk and the JSON objects that index it.
pub(super) struct Builder {
    pub bin: Vec<u8>,
    pub buffer_views: Vec<Value>,
    pub accessors: Vec<Value>,
}

// glTF's numbers for OpenGL enums (the specification's accessor, buffer view, primitive and
// sampler fields).
/// `componentType` of f32.
pub(super) const FLOAT: u32 = 5126;
/// `componentType` of i8 (quantized transfer).
pub(super) const BYTE: u32 = 5120;
/// `componentType` of i16 (quantized transfer).
pub(super) const SHORT: u32 = 5122;
/// `componentType` of u32 (indices).
pub(super) const UNSIGNED_INT: u32 = 5125;
/// `bufferView.target` of vertex attributes.
pub(super) const ARRAY_BUFFER: u32 = 34962;
/// `bufferView.target` of indices.
pub(super) const ELEMENT_ARRAY_BUFFER: u32 = 34963;
/// `primitive.mode` of a triangle list.
pub(super) const TRIANGLES: u32 = 4;
/// Sampler filter: linear.
pub(super) const LINEAR: u32 = 9729;
/// Sampler minification filter: linear between linear mipmaps (trilinear).
pub(super) const LINEAR_MIPMAP_LINEAR: u32 = 9987;
/// Sampler wrap mode: repeat.
pub(super) const REPEAT: u32 = 10497;
/// Sampler wrap mode: clamp to edge.
pub(super) const CLAMP_TO_EDGE: u32 = 33071;
/// Sampler wrap mode: mirrored repeat.
pub(super) const MIRRORED_REPEAT: u32 = 33648;

/// Sampler 0: the scene's textures, repeat wrapping, trilinear (textures whose source
/// sampler wraps otherwise get samplers of their own after it).
pub(super) const ALBEDO_SAMPLER: usize = 0;

impl Builder {
    /// Appends bytes as a buffer view (4-byte aligned) and returns its index.
    pub(super) fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let mut view = json!({
            "buffer": 0,
            "byteOffset": self.bin.len(),
            "byteLength": bytes.len(),
        });
        if let Some(target) = target {
            view["target"] = json!(target);
        }
        self.bin.extend_from_slice(bytes);
        self.buffer_views.push(view);
        self.buffer_views.len() - 1
    }

    /// A float accessor of 1 to 4 `components` ("SCALAR", "VEC2", "VEC3", "VEC4") over
    /// `floats`; `bounds` adds the min and max the specification requires for POSITION.
    pub(super) fn floats(&mut self, floats: &[f32], components: usize, bounds: bool) -> usize {
        let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ARRAY_BUFFER));
        let kind = match components {
            1 => "SCALAR",
            2 => "VEC2",
            3 => "VEC3",
            _ => "VEC4",
        };
        let mut accessor = json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": floats.len() / components,
            "type": kind,
        });
        if bounds {
            let mut lo = vec![f32::INFINITY; components];
            let mut hi = vec![f32::NEG_INFINITY; components];
            for chunk in floats.chunks_exact(components) {
                for (i, x) in chunk.iter().enumerate() {
                    lo[i] = lo[i].min(*x);
                    hi[i] = hi[i].max(*x);
                }
            }
            accessor["min"] = json!(lo);
            accessor["max"] = json!(hi);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// A SCALAR float accessor over `floats` that no primitive reads (data a runtime reads from
    /// the buffer, such as CPCA's cluster means): its buffer view has no target.
    pub(super) fn data_floats(&mut self, floats: &[f32]) -> usize {
        let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes, None);
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": floats.len(),
            "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }

    /// A normalized signed-integer VEC4 accessor of `values` / `scale` (|values| ≤ scale).
    pub(super) fn quantized(&mut self, values: &[f32], scale: f32, quantize: Quantize) -> usize {
        let max = quantize.max_code();
        let codes = values
            .iter()
            .map(|x| (x / scale * max).round().clamp(-max, max));
        let bytes: Vec<u8> = match quantize {
            Quantize::Bits8 => codes.map(|c| (c as i8).to_le_bytes()[0]).collect(),
            Quantize::Bits16 => codes.flat_map(|c| (c as i16).to_le_bytes()).collect(),
        };
        let view = self.view(&bytes, Some(ARRAY_BUFFER));
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": quantize.component_type(),
            "normalized": true,
            "count": values.len() / 4,
            "type": "VEC4",
        }));
        self.accessors.len() - 1
    }

    pub(super) fn indices(&mut self, indices: &[u32]) -> usize {
        let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": UNSIGNED_INT,
            "count": indices.len(),
            "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }
}

/// Step 7: the binary container: header, JSON chunk (space-padded), BIN chunk.
pub(super) fn glb_container(root: &Value, bin: &[u8]) -> Result<Vec<u8>> {
    let mut json_bytes = serde_json::to_vec(root).map_err(|err| {
        Error::InvalidOption(format!("the glTF's JSON does not serialise: {err}"))
    })?;
    while json_bytes.len() % 4 != 0 {
        json_bytes.push(b' ');
    }
    let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
    let total_u32 = u32::try_from(total).map_err(|_| {
        Error::InvalidOption(format!(
            "the glTF would be {total} bytes, over the 4 GiB a .glb can hold"
        ))
    })?;
    let mut bytes = Vec::with_capacity(total);
    bytes.extend(b"glTF");
    bytes.extend(2u32.to_le_bytes());
    bytes.extend(total_u32.to_le_bytes());
    bytes.extend((json_bytes.len() as u32).to_le_bytes());
    bytes.extend(b"JSON");
    bytes.extend(&json_bytes);
    bytes.extend((bin.len() as u32).to_le_bytes());
    bytes.extend(b"BIN\0");
    bytes.extend(bin);
    Ok(bytes)
}

/// A texture's sRGB pixels as PNG.
pub(super) fn png_bytes(texture: &Texture) -> Result<Vec<u8>> {
    let pixels: Vec<u8> = texture.srgb8.iter().flatten().copied().collect();
    let (width, height) = (texture.width, texture.height);
    crate::formats::png::encode(&pixels, width, height, image::ExtendedColorType::Rgba8).map_err(
        |err| {
            Error::io(
                &texture.path,
                std::io::Error::other(format!("cannot encode as PNG: {err}")),
            )
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantized_transfer_decodes_within_half_a_step() {
        let values = [0.5f32, -1.25, 0.0, 1.25, 0.3, -0.7, 0.01, -0.01];
        let scale = 1.25;
        for q in [Quantize::Bits8, Quantize::Bits16] {
            let mut b = Builder {
                bin: Vec::new(),
                buffer_views: Vec::new(),
                accessors: Vec::new(),
            };
            b.quantized(&values, scale, q);
            let max = q.max_code();
            // glTF's decoding of normalized signed integers: max(c / max, −1).
            let decoded: Vec<f32> = match q {
                Quantize::Bits8 => b.bin.iter().map(|&c| f32::from(c as i8)).collect(),
                Quantize::Bits16 => b
                    .bin
                    .chunks_exact(2)
                    .map(|c| f32::from(i16::from_le_bytes([c[0], c[1]])))
                    .collect(),
            };
            assert_eq!(decoded.len(), values.len());
            for (v, code) in values.iter().zip(&decoded) {
                let d = (code / max).max(-1.0) * scale;
                assert!(
                    (v - d).abs() <= scale / (2.0 * max) * 1.0001,
                    "{q:?}: {v} decodes to {d}"
                );
            }
            assert_eq!(b.accessors[0]["normalized"], true);
            assert_eq!(b.accessors[0]["count"], 2);
        }
        assert_eq!(Quantize::from_bits(None).ok(), Some(None));
        assert_eq!(
            Quantize::from_bits(Some(8)).ok(),
            Some(Some(Quantize::Bits8))
        );
        assert!(Quantize::from_bits(Some(12)).is_err());
    }
}
