//! Alpha-tested occlusion: which parts of a surface rays pass through.
//!
//! A material's [`Alpha`] says how its coverage is found (a factor times a texture channel,
//! looked up with the texture's own wrap modes and `KHR_texture_transform`) and what is done
//! with it: glTF `MASK` compares it with the cutoff; `BLEND` (and OBJ `map_d`, which says no
//! more) treats it as the probability that a ray is stopped, decided by a hash of the ray and
//! the triangle so a bake stays deterministic for any thread count and both backends agree
//! (`docs/guides/production-assets.md`, "Alpha"). [`Cutouts`] is what the tracers hold: per triangle, whether it
//! is cut out, and what to look up at a hit.

use glam::{Vec2, Vec3};

use super::texture::Texture;

/// What a material's coverage decides.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// glTF `MASK`: a hit counts where coverage ≥ `cutoff`.
    Mask { cutoff: f32 },
    /// glTF `BLEND`, OBJ `map_d`: a ray is stopped with probability = coverage.
    Blend,
}

/// A texture's wrap mode along one axis (glTF sampler `wrapS` / `wrapT`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Wrap {
    #[default]
    Repeat,
    ClampToEdge,
    MirroredRepeat,
}

/// `KHR_texture_transform` of a texture reference, as the source wrote it: offset, rotation
/// (radians, counter-clockwise in the image) and scale, applied to glTF texture coordinates
/// (v down from the image's top) as translation × rotation × scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureTransform {
    pub offset: [f32; 2],
    pub rotation: f32,
    pub scale: [f32; 2],
}

impl TextureTransform {
    /// The transform as an affine map: rows `[a, b, c]` give `a·u + b·v + c`.
    pub fn matrix(&self) -> [[f32; 3]; 2] {
        let ([ox, oy], [sx, sy]) = (self.offset, self.scale);
        let (sin, cos) = self.rotation.sin_cos();
        [[cos * sx, sin * sy, ox], [-sin * sx, cos * sy, oy]]
    }
}

/// How a material's base colour texture is looked up by renderers and written by the glTF
/// export: its sampler's wrap modes and its `KHR_texture_transform` (OBJ: repeat, none).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sampling {
    /// The wrap modes along u and v.
    pub wrap: [Wrap; 2],
    pub transform: Option<TextureTransform>,
}

impl Sampling {
    /// The transform's affine map, the identity without one.
    pub fn matrix(&self) -> [[f32; 3]; 2] {
        self.transform.map_or(Alpha::IDENTITY, |t| t.matrix())
    }
}

/// Where a material's coverage comes from and what it decides.
#[derive(Clone, Debug, PartialEq)]
pub struct Alpha {
    pub mode: AlphaMode,
    /// The base colour factor's alpha (1 for OBJ).
    pub factor: f32,
    /// The texture whose `channel` (3: alpha, 0: red, for grey maps) multiplies `factor`,
    /// an index into [`Scene::textures`].
    pub texture: Option<usize>,
    pub channel: usize,
    /// The texture's wrap modes along u and v.
    pub wrap: [Wrap; 2],
    /// `KHR_texture_transform` as an affine map of glTF texture coordinates (v down from the
    /// image's top): rows `[a, b, c]` give `a·u + b·v + c`. Identity for OBJ.
    pub transform: [[f32; 3]; 2],
}

impl Alpha {
    pub const IDENTITY: [[f32; 3]; 2] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

    /// Whether it can make anything transparent: an opaque material keeps the tracers' fast
    /// path.
    pub fn cuts(&self) -> bool {
        match (self.mode, self.texture) {
            (AlphaMode::Mask { cutoff }, Some(_)) => cutoff > 0.0,
            (AlphaMode::Mask { cutoff }, None) => self.factor < cutoff,
            (AlphaMode::Blend, Some(_)) => true,
            (AlphaMode::Blend, None) => self.factor < 1.0,
        }
    }

    /// The coverage at a scene texture coordinate (OBJ convention, v up).
    pub fn coverage(&self, textures: &[Texture], uv: Vec2) -> f32 {
        let Some(t) = self.texture else {
            return self.factor;
        };
        // To glTF's convention, through the transform, then to texel space.
        let (u, v) = (uv.x, 1.0 - uv.y);
        let [[a, b, c], [d, e, f]] = self.transform;
        let (s, t_) = (a * u + b * v + c, d * u + e * v + f);
        self.factor * sample_channel(&textures[t], self.channel, s, t_, self.wrap)
    }
}

/// Bilinear lookup of one 8-bit channel (linear, as alpha is) at glTF coordinates (s, t),
/// t down from the top row, with the given wrap modes.
pub(super) fn sample_channel(
    texture: &Texture,
    channel: usize,
    s: f32,
    t: f32,
    wrap: [Wrap; 2],
) -> f32 {
    let (w, h) = (texture.width as i64, texture.height as i64);
    let x = s * w as f32 - 0.5;
    let y = t * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let index = |i: i64, size: i64, mode: Wrap| -> usize {
        let i = match mode {
            Wrap::Repeat => i.rem_euclid(size),
            Wrap::ClampToEdge => i.clamp(0, size - 1),
            Wrap::MirroredRepeat => {
                let period = i.rem_euclid(2 * size);
                if period < size {
                    period
                } else {
                    2 * size - 1 - period
                }
            }
        };
        i as usize
    };
    // Far-off coordinates (1e30) saturate to i64's ends, where every mode still answers.
    let (x0, y0) = (x0 as i64, y0 as i64);
    let value = |x: i64, y: i64| {
        let (x, y) = (index(x, w, wrap[0]), index(y, h, wrap[1]));
        f32::from(texture.srgb8[y * w as usize + x][channel]) / 255.0
    };
    let top = value(x0, y0) * (1.0 - fx) + value(x0.saturating_add(1), y0) * fx;
    let y1 = y0.saturating_add(1);
    let bottom = value(x0, y1) * (1.0 - fx) + value(x0.saturating_add(1), y1) * fx;
    let result = top * (1.0 - fy) + bottom * fy;
    if result.is_finite() { result } else { 0.0 }
}

/// The cut-out triangles of a scene, owned, for the tracers: at a hit on one, whether the
/// ray goes on.
#[derive(Clone, Debug)]
pub struct Cutouts {
    /// Per scene triangle, its index in `cut`, or [`Cutouts::OPAQUE`].
    slot: Vec<u32>,
    cut: Vec<CutTriangle>,
    alphas: Vec<Alpha>,
    textures: Vec<Texture>,
}

#[derive(Clone, Copy, Debug)]
struct CutTriangle {
    uvs: [Vec2; 3],
    alpha: u32,
}

impl Cutouts {
    const OPAQUE: u32 = u32::MAX;

    /// The cut-out triangles of a scene ([`super::Scene::cutouts`]), or `None` when every
    /// material is opaque: per material its alpha, per vertex its material, and the scene's
    /// triangles, texture coordinates and textures.
    pub fn new(
        material_alpha: &[Option<&Alpha>],
        vertex_material: &[u32],
        triangles: &[[u32; 3]],
        uvs: &[Vec2],
        textures: &[Texture],
    ) -> Option<Cutouts> {
        let mut alphas = Vec::new();
        let mut alpha_of_material = vec![None; material_alpha.len()];
        for (m, alpha) in material_alpha.iter().enumerate() {
            if let Some(alpha) = alpha.filter(|a| a.cuts()) {
                alpha_of_material[m] = Some(alphas.len() as u32);
                alphas.push(alpha.clone());
            }
        }
        if alphas.is_empty() {
            return None;
        }
        let mut slot = vec![Self::OPAQUE; triangles.len()];
        let mut cut = Vec::new();
        for (t, tri) in triangles.iter().enumerate() {
            let material = vertex_material[tri[0] as usize] as usize;
            if let Some(alpha) = alpha_of_material[material] {
                slot[t] = cut.len() as u32;
                cut.push(CutTriangle {
                    uvs: tri.map(|v| uvs[v as usize]),
                    alpha,
                });
            }
        }
        Some(Cutouts {
            slot,
            cut,
            alphas,
            textures: textures.to_vec(),
        })
    }

    /// Whether triangle `t` may let rays through.
    #[inline]
    pub fn is_cut(&self, triangle: u32) -> bool {
        self.slot[triangle as usize] != Self::OPAQUE
    }

    /// Whether a hit at barycentrics (u, v) of `triangle` by the ray (origin, dir) counts:
    /// always on opaque triangles.
    pub fn stops(&self, triangle: u32, u: f32, v: f32, origin: Vec3, dir: Vec3) -> bool {
        let slot = self.slot[triangle as usize];
        if slot == Self::OPAQUE {
            return true;
        }
        let cut = &self.cut[slot as usize];
        let [a, b, c] = cut.uvs;
        let uv = a * (1.0 - u - v) + b * u + c * v;
        let alpha = &self.alphas[cut.alpha as usize];
        let coverage = alpha.coverage(&self.textures, uv);
        match alpha.mode {
            AlphaMode::Mask { cutoff } => coverage >= cutoff,
            AlphaMode::Blend => ray_hash(triangle, origin, dir) < coverage,
        }
    }
}

/// A number in [0, 1) from the ray and the triangle it hit, the same on every backend and
/// thread: the stochastic coverage of `BLEND` surfaces.
fn ray_hash(triangle: u32, origin: Vec3, dir: Vec3) -> f32 {
    let words = [origin.to_array(), dir.to_array()];
    let mut h = triangle.wrapping_mul(0x9E37_79B9) ^ 0x85EB_CA6B;
    for w in words.iter().flatten() {
        h = (h ^ w.to_bits()).wrapping_mul(0x2C1B_3C6D);
        h ^= h >> 15;
        h = h.wrapping_mul(0x297A_2D39);
        h ^= h >> 13;
    }
    (h >> 8) as f32 / (1u32 << 24) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey_alpha(width: u32, height: u32, alpha: &[u8]) -> Texture {
        Texture {
            path: "alpha".into(),
            width,
            height,
            srgb8: alpha.iter().map(|&a| [255, 255, 255, a]).collect(),
        }
    }

    fn alpha(wrap: [Wrap; 2], transform: [[f32; 3]; 2]) -> Alpha {
        Alpha {
            mode: AlphaMode::Mask { cutoff: 0.5 },
            factor: 1.0,
            texture: Some(0),
            channel: 3,
            wrap,
            transform,
        }
    }

    #[test]
    fn coverage_follows_wrap_modes_and_transform() {
        // 2×1: left transparent, right opaque. Scene v is up: v = 0.5 is the middle row.
        let textures = [grey_alpha(2, 1, &[0, 255])];
        let repeat = alpha([Wrap::Repeat; 2], Alpha::IDENTITY);
        assert_eq!(repeat.coverage(&textures, Vec2::new(0.25, 0.5)), 0.0);
        assert_eq!(repeat.coverage(&textures, Vec2::new(0.75, 0.5)), 1.0);
        assert_eq!(repeat.coverage(&textures, Vec2::new(1.25, 0.5)), 0.0);
        assert_eq!(repeat.coverage(&textures, Vec2::new(-0.25, 0.5)), 1.0);
        let clamp = alpha([Wrap::ClampToEdge; 2], Alpha::IDENTITY);
        assert_eq!(clamp.coverage(&textures, Vec2::new(1.25, 0.5)), 1.0);
        assert_eq!(clamp.coverage(&textures, Vec2::new(-0.25, 0.5)), 0.0);
        let mirror = alpha([Wrap::MirroredRepeat; 2], Alpha::IDENTITY);
        assert_eq!(mirror.coverage(&textures, Vec2::new(1.25, 0.5)), 1.0);
        assert_eq!(mirror.coverage(&textures, Vec2::new(1.75, 0.5)), 0.0);
        // Offset by half the texture: the halves swap.
        let shifted = alpha([Wrap::Repeat; 2], [[1.0, 0.0, 0.5], [0.0, 1.0, 0.0]]);
        assert_eq!(shifted.coverage(&textures, Vec2::new(0.25, 0.5)), 1.0);
        // Far-off and non-finite coordinates answer without a panic.
        for uv in [Vec2::splat(1e30), Vec2::splat(-1e30), Vec2::splat(f32::NAN)] {
            let c = mirror.coverage(&textures, uv);
            assert!((0.0..=1.0).contains(&c), "{uv}: {c}");
        }
    }

    #[test]
    fn v_runs_down_the_image_in_gltf_coordinates() {
        // 1×2: top row opaque, bottom transparent; scene v = 0.75 is the top half.
        let textures = [grey_alpha(1, 2, &[255, 0])];
        let a = alpha([Wrap::ClampToEdge; 2], Alpha::IDENTITY);
        assert_eq!(a.coverage(&textures, Vec2::new(0.5, 0.75)), 1.0);
        assert_eq!(a.coverage(&textures, Vec2::new(0.5, 0.25)), 0.0);
    }

    #[test]
    fn ray_hash_is_uniform_enough() {
        let n = 100_000;
        let below = (0..n)
            .filter(|&i| ray_hash(i, Vec3::new(i as f32 * 1e-3, 0.0, 1.0), Vec3::Z) < 0.3)
            .count();
        assert!((below as f32 / n as f32 - 0.3).abs() < 0.01, "{below}");
    }
}
