//! The scene's up axis: +z (the demo scenes, OBJ and scene files by default) or +y (glTF, by
//! its specification).
//!
//! Light rigs, the hemisphere sky, environment maps and the viewer are written for a z-up
//! world. For a y-up scene they are turned by one fixed rotation, [`Up::from_z_up`], that
//! takes +z to +y: (x, y, z) ↦ (x, z, −y), the conversion Blender and other z-up tools apply
//! when they write glTF. So a rig's θ is measured from the scene's up axis, and the same rig
//! lights a z-up OBJ and the y-up glTF of the same geometry identically.

use glam::{DMat3, DVec3};

/// A scene's up axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Up {
    /// +z is up (OBJ and scene files unless `--up y`).
    #[default]
    Z,
    /// +y is up (glTF).
    Y,
}

impl Up {
    /// The name used on command lines and in `prt-bake inspect`: `z` or `y`.
    pub fn name(self) -> &'static str {
        match self {
            Up::Z => "z",
            Up::Y => "y",
        }
    }

    /// The coefficient file's code (header bytes 84..88): 0 = +z, 1 = +y.
    pub fn code(self) -> u32 {
        match self {
            Up::Z => 0,
            Up::Y => 1,
        }
    }

    pub fn from_code(code: u32) -> Option<Up> {
        match code {
            0 => Some(Up::Z),
            1 => Some(Up::Y),
            _ => None,
        }
    }

    /// The rotation taking directions of the z-up frame (rigs, skies, the viewer's camera)
    /// into the scene's own coordinates: the identity for z-up, (x, y, z) ↦ (x, z, −y) for
    /// y-up.
    pub fn from_z_up(self) -> DMat3 {
        match self {
            Up::Z => DMat3::IDENTITY,
            Up::Y => DMat3::from_cols(DVec3::X, DVec3::NEG_Z, DVec3::Y),
        }
    }

    /// The scene's up direction in its own coordinates.
    pub fn vector(self) -> DVec3 {
        self.from_z_up() * DVec3::Z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn y_up_is_a_proper_rotation_taking_z_to_y() {
        let r = Up::Y.from_z_up();
        assert!((r.determinant() - 1.0).abs() < 1e-12);
        assert!((r * r.transpose() - DMat3::IDENTITY).abs_diff_eq(DMat3::ZERO, 1e-12));
        assert_eq!(r * DVec3::Z, DVec3::Y);
        assert_eq!(r * DVec3::Y, DVec3::NEG_Z);
        assert_eq!(Up::Z.vector(), DVec3::Z);
        for up in [Up::Z, Up::Y] {
            assert_eq!(Up::from_code(up.code()), Some(up));
        }
        assert_eq!(Up::from_code(2), None);
    }
}
