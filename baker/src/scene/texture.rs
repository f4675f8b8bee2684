//! Albedo textures (TGA, PNG through the `image` crate), sampled bilinearly with wrapping.
//!
//! Texels are taken as sRGB-encoded colour, as painted albedo maps are, and decoded to linear
//! reflectance through a 256-entry table at lookup; all lighting arithmetic is linear. Keeping
//! the 4-byte sRGB pixels rather than 12-byte linear ones matters: the interreflection pass
//! looks textures up at tens of millions of random hit points, and a third of the footprint
//! keeps a texture in cache.

use std::path::{Path, PathBuf};

use std::sync::LazyLock;

use glam::{Vec2, Vec3};

use crate::support::error::{Error, Location, Result};

#[derive(Clone, Debug)]
pub struct Texture {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    /// 8-bit sRGB RGBA pixels, row-major, top row first (as stored in the image); renderers
    /// can upload them as is.
    pub srgb8: Vec<[u8; 4]>,
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear values of the 256 sRGB codes.
static DECODE: LazyLock<[f32; 256]> =
    LazyLock::new(|| std::array::from_fn(|v| srgb_to_linear(v as f32 / 255.0)));

impl Texture {
    /// Loads an image. `referenced_at` is where the scene named it, for the error message.
    /// Only a regular file is read, no larger than the memory limit: a device or FIFO would
    /// hang the decoder ([`crate::support::input_path`]).
    pub fn load(path: &Path, referenced_at: &Location) -> Result<Texture> {
        let cannot_read = |err: &dyn std::fmt::Display| {
            Error::scene(
                referenced_at.clone(),
                format!("cannot read texture {}: {err}", path.display()),
            )
        };
        let bytes = crate::support::input_path::read(path).map_err(|err| match err {
            Error::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
                Error::scene(
                    referenced_at.clone(),
                    format!("texture {} does not exist", path.display()),
                )
            }
            Error::Io { source, .. } => cannot_read(&source),
            Error::InputPath { message, .. } => Error::InputPath {
                location: referenced_at.clone(),
                message: format!("texture {}: {message}", path.display()),
            },
            other => other,
        })?;
        // The format by the extension, as `ImageReader::open` takes it (a TGA has no magic).
        let open = || {
            let mut reader = image::ImageReader::new(std::io::Cursor::new(&bytes[..]));
            if let Ok(format) = image::ImageFormat::from_path(path) {
                reader.set_format(format);
            }
            Ok::<_, Error>(reader)
        };
        // The header's size first: decoding (up to 8 bytes a pixel), the RGBA copy and the
        // kept sRGB pixels (4 each) must fit before a byte of pixels is allocated.
        let (width, height) = open()?.into_dimensions().map_err(|err| cannot_read(&err))?;
        crate::support::limits::check_image(path, width, height, 16)
            .map_err(|err| Error::scene(referenced_at.clone(), format!("texture {err}")))?;
        let mut reader = open()?;
        reader.limits(crate::support::limits::image_limits());
        let image = reader.decode().map_err(|err| cannot_read(&err))?;
        let rgba = image.to_rgba8();
        let (width, height) = rgba.dimensions();
        if width == 0 || height == 0 {
            return Err(Error::scene(
                referenced_at.clone(),
                format!("texture {} is empty", path.display()),
            ));
        }
        let srgb8: Vec<[u8; 4]> = rgba.pixels().map(|p| p.0).collect();
        Ok(Texture {
            path: path.to_path_buf(),
            width,
            height,
            srgb8,
        })
    }

    /// A texture from linear texels (tests, generated content), stored as sRGB8 like a
    /// loaded one: values are clamped to [0, 1] and quantised.
    pub fn from_linear(
        path: impl Into<PathBuf>,
        width: u32,
        height: u32,
        texels: Vec<Vec3>,
    ) -> Texture {
        assert_eq!(texels.len(), (width * height) as usize);
        let encode = |c: f32| {
            let c = c.clamp(0.0, 1.0);
            let s = if c <= 0.003_130_8 {
                c * 12.92
            } else {
                1.055 * c.powf(1.0 / 2.4) - 0.055
            };
            (s * 255.0).round() as u8
        };
        let srgb8 = texels
            .iter()
            .map(|t| [encode(t.x), encode(t.y), encode(t.z), 255])
            .collect();
        Texture {
            path: path.into(),
            width,
            height,
            srgb8,
        }
    }

    /// The linear colour of texel (x, y), counted from the image's top-left corner.
    pub fn texel(&self, x: usize, y: usize) -> Vec3 {
        self.decoded_texel(&DECODE, x, y)
    }

    #[inline]
    fn decoded_texel(&self, decode: &[f32; 256], x: usize, y: usize) -> Vec3 {
        let [r, g, b, _] = self.srgb8[y * self.width as usize + x];
        Vec3::new(decode[r as usize], decode[g as usize], decode[b as usize])
    }

    /// Whether every texel is grey (R = G = B).
    pub fn is_grey(&self) -> bool {
        self.srgb8.iter().all(|[r, g, b, _]| r == g && g == b)
    }

    /// Bilinear lookup with repeat wrapping. OBJ's v runs up from the bottom of the image.
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as usize, self.height as usize);
        // Wrap once in float, so each axis needs at most one neighbour wrapped below.
        let x = (uv.x - uv.x.floor()) * w as f32 - 0.5;
        let y = (1.0 - (uv.y - uv.y.floor())) * h as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let wrap = |i: f32, size: usize| -> (usize, usize) {
            // i is in [-1, size]: the pair (i, i + 1) modulo size.
            let i = i as isize;
            let first = if i < 0 {
                size - 1
            } else {
                (i as usize).min(size - 1)
            };
            let second = if i + 1 >= size as isize {
                0
            } else {
                (i + 1) as usize
            };
            (first, second)
        };
        let ((x0, x1), (y0, y1)) = (wrap(x0, w), wrap(y0, h));
        let decode: &[f32; 256] = &DECODE; // one initialisation check per lookup, not twelve
        let texel = |x, y| self.decoded_texel(decode, x, y);
        let top = texel(x0, y0).lerp(texel(x1, y0), fx);
        let bottom = texel(x0, y1).lerp(texel(x1, y1), fx);
        top.lerp(bottom, fy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_sampling_wraps_and_flips_v() {
        // 2×1 texture: left black, right white.
        let t = Texture::from_linear("t", 2, 1, vec![Vec3::ZERO, Vec3::ONE]);
        assert_eq!(t.sample(Vec2::new(0.25, 0.5)), Vec3::ZERO);
        assert_eq!(t.sample(Vec2::new(0.75, 0.5)), Vec3::ONE);
        assert!((t.sample(Vec2::new(0.5, 0.5)) - Vec3::splat(0.5)).length() < 1e-6);
        // At u = 0 the left texel blends with the right one across the wrap.
        assert!((t.sample(Vec2::new(0.0, 0.5)) - Vec3::splat(0.5)).length() < 1e-6);
        assert_eq!(t.sample(Vec2::new(1.25, 0.5)), Vec3::ZERO);

        // 1×2: top row red, bottom row blue; v = 0.25 is the bottom half of the image.
        let t = Texture::from_linear("t", 1, 2, vec![Vec3::X, Vec3::Z]);
        assert_eq!(t.sample(Vec2::new(0.5, 0.25)), Vec3::Z);
        assert_eq!(t.sample(Vec2::new(0.5, 0.75)), Vec3::X);
    }

    /// The fast wrap against the obvious formulation, over uvs far outside [0, 1].
    #[test]
    fn sampling_matches_integer_wrapping_everywhere() {
        let (w, h) = (5u32, 3u32);
        let texels = (0..w * h)
            .map(|i| Vec3::new(i as f32, (i * 7 % 11) as f32, 1.0))
            .collect();
        let t = Texture::from_linear("t", w, h, texels);
        let reference = |uv: Vec2| {
            let texel = |x: i64, y: i64| {
                t.texel(
                    x.rem_euclid(w as i64) as usize,
                    y.rem_euclid(h as i64) as usize,
                )
            };
            let x = uv.x * w as f32 - 0.5;
            let y = (1.0 - uv.y) * h as f32 - 0.5;
            let (x0, y0) = (x.floor(), y.floor());
            let (fx, fy) = (x - x0, y - y0);
            let (x0, y0) = (x0 as i64, y0 as i64);
            let top = texel(x0, y0).lerp(texel(x0 + 1, y0), fx);
            let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), fx);
            top.lerp(bottom, fy)
        };
        let mut rng = crate::math::sampling::Pcg32::new(1, 2);
        for _ in 0..10_000 {
            let uv = Vec2::new(rng.next_f32() * 8.0 - 4.0, rng.next_f32() * 8.0 - 4.0);
            let (fast, slow) = (t.sample(uv), reference(uv));
            assert!(
                (fast - slow).abs().max_element() < 1e-3,
                "uv {uv}: {fast} vs {slow}"
            );
        }
    }

    #[test]
    fn srgb_decoding_matches_reference_values() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-5);
    }
}
