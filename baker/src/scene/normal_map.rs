//! Tangent-space normal maps (glTF `normalTexture`): the normal a texel bake turns each
//! texel's lobe to (`docs/guides/lightmaps.md`, "Normal maps").
//!
//! A texel (r, g, b) of the map is the tangent-space normal (2r − 1, 2g − 1, 2b − 1) read as
//! linear 8-bit data (never sRGB-decoded), its x and y multiplied by the material's `scale`
//! and the result normalised, as the glTF specification defines it. The frame is the
//! vertex's tangent t, bitangent b = w·(n × t) and normal n, interpolated over the triangle.

use glam::{Vec2, Vec3, Vec4};

use super::alpha::{Wrap, sample_channel};
use super::texture::Texture;

/// A material's tangent-space normal map.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalMap {
    /// Index into [`super::Scene::textures`] (its bytes are read as data, not colour).
    pub texture: usize,
    /// glTF `normalTexture.scale`: the factor on the map's x and y.
    pub scale: f32,
    /// The texture's wrap modes along u and v.
    pub wrap: [Wrap; 2],
}

impl NormalMap {
    /// The map's unit tangent-space normal at a scene texture coordinate (v up); +z where
    /// the texel decodes to no direction (a black texel).
    pub fn tangent_space(&self, textures: &[Texture], uv: Vec2) -> Vec3 {
        let texture = &textures[self.texture];
        let (s, t) = (uv.x, 1.0 - uv.y);
        let c = |k| sample_channel(texture, k, s, t, self.wrap) * 2.0 - 1.0;
        Vec3::new(c(0) * self.scale, c(1) * self.scale, c(2))
            .try_normalize()
            .unwrap_or(Vec3::Z)
    }

    /// The mapped unit normal at `uv` of a surface with unit normal `normal` and tangent
    /// `tangent` (xyz, and w = ±1 the bitangent's sign); `normal` where the tangent is
    /// degenerate (parallel to the normal, or zero).
    pub fn perturb(&self, textures: &[Texture], uv: Vec2, normal: Vec3, tangent: Vec4) -> Vec3 {
        let local = self.tangent_space(textures, uv);
        to_world(local, normal, tangent).unwrap_or(normal)
    }
}

/// `local` (tangent space) in world space about `normal`, with the tangent made orthogonal
/// to the normal (Gram–Schmidt, as interpolated tangents drift); `None` where it cannot be.
pub fn to_world(local: Vec3, normal: Vec3, tangent: Vec4) -> Option<Vec3> {
    let t = (tangent.truncate() - normal * normal.dot(tangent.truncate())).try_normalize()?;
    let sign = if tangent.w < 0.0 { -1.0 } else { 1.0 };
    let b = normal.cross(t) * sign;
    (t * local.x + b * local.y + normal * local.z).try_normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_texel_keeps_the_normal_and_a_tilted_one_turns_toward_the_tangent() {
        // One texel (255, 128, 128): x = 1, y ≈ 0, z ≈ 0 — lies along the tangent.
        let flat = Texture {
            path: "flat".into(),
            width: 1,
            height: 1,
            srgb8: vec![[128, 128, 255, 255]],
        };
        let map = NormalMap {
            texture: 0,
            scale: 1.0,
            wrap: [Wrap::Repeat; 2],
        };
        let n = map.perturb(
            &[flat],
            Vec2::splat(0.5),
            Vec3::Z,
            Vec4::new(1.0, 0.0, 0.0, 1.0),
        );
        assert!(n.angle_between(Vec3::Z) < 0.01, "{n}");
        // 45° toward +x: (r, b) both encode 1/√2.
        let code = ((std::f32::consts::FRAC_1_SQRT_2 + 1.0) * 0.5 * 255.0).round() as u8;
        let tilted = Texture {
            path: "tilted".into(),
            width: 1,
            height: 1,
            srgb8: vec![[code, 128, code, 255]],
        };
        let n = map.perturb(
            std::slice::from_ref(&tilted),
            Vec2::ZERO,
            Vec3::Z,
            Vec4::new(0.0, 1.0, 0.0, 1.0),
        );
        // Tangent +y: the lobe turns toward +y by 45°.
        assert!(
            (n.angle_between(Vec3::Z).to_degrees() - 45.0).abs() < 0.5,
            "{n}"
        );
        assert!(n.y > 0.6, "{n}");
        // Scale 0 flattens the map.
        let flat_scale = NormalMap { scale: 0.0, ..map };
        let n = flat_scale.perturb(
            &[tilted],
            Vec2::ZERO,
            Vec3::Z,
            Vec4::new(0.0, 1.0, 0.0, 1.0),
        );
        assert!(n.angle_between(Vec3::Z) < 1e-6, "{n}");
    }

    #[test]
    fn the_bitangent_sign_mirrors_green() {
        // Green 255: y = 1, along the bitangent n × t (w = 1) or its opposite (w = −1).
        let local = Vec3::new(0.0, 1.0, 1.0).normalize();
        let up = to_world(local, Vec3::Z, Vec4::new(1.0, 0.0, 0.0, 1.0)).unwrap();
        let down = to_world(local, Vec3::Z, Vec4::new(1.0, 0.0, 0.0, -1.0)).unwrap();
        assert!(up.y > 0.7 && down.y < -0.7, "{up} {down}");
        assert!(to_world(local, Vec3::Z, Vec4::new(0.0, 0.0, 1.0, 1.0)).is_none());
    }
}
