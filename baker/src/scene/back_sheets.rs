//! Back sheets of glTF `doubleSided` objects (docs/guides/production-assets.md, "Two-sided surfaces").
//!
//! Transfer is baked for the side a receiver's normal faces, so a surface an engine shades on
//! both sides needs a second set of receivers: the same positions with the shading normals
//! flipped and the winding reversed, as a user would model twin sheets by hand. Each back
//! sheet is an ordinary object, appended after every object of the file, so vertex order,
//! lightmaps, exports and renderers need nothing new; only the tracers leave them out
//! ([`super::Scene::traced_triangles`]): the front sheet already stops rays from both sides.
//! The [`super::Scene`] methods that add, drop and find them are in `scene/mod.rs`.

use std::collections::HashMap;

use glam::Vec3;

/// Which objects are back sheets: the last `fronts.len()` objects, each the twin of the
/// object `fronts[k]` names.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BackSheets {
    pub fronts: Vec<u32>,
}

/// Whether every edge of a mesh (vertices welded by position) joins two triangles or
/// more: a closed surface, whose back faces are inside it.
pub fn is_closed(positions: &[Vec3], triangles: &[[u32; 3]]) -> bool {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
    for t in triangles {
        let w = t.map(|v| {
            let next = ids.len() as u32;
            *ids.entry(positions[v as usize].to_array().map(f32::to_bits))
                .or_insert(next)
        });
        for k in 0..3 {
            let (a, b) = (w[k], w[(k + 1) % 3]);
            if a != b {
                *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
    }
    uses.values().all(|&n| n >= 2)
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::scene::{Material, Mesh, Scene};

    fn scene(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Scene {
        let mesh = Mesh {
            name: "m".into(),
            positions,
            triangles,
            material: Material {
                double_sided: true,
                ..Material::default()
            },
            ..Mesh::default()
        };
        Scene::from_meshes(std::path::Path::new("t"), vec![mesh], Vec::new()).unwrap()
    }

    /// An open sheet gets a back sheet, which `drop_back_sheets` takes away again; a
    /// closed tetrahedron gets none.
    #[test]
    fn open_double_sided_objects_get_a_back_sheet_and_closed_ones_do_not() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let mut open = scene(p.clone(), vec![[0, 1, 2], [0, 2, 3]]);
        let before = open.fingerprint();
        open.add_back_sheets().unwrap();
        assert_eq!(open.objects.len(), 2);
        assert_eq!(open.objects[1].name, "m (back)");
        assert_eq!(open.triangles[2], [4, 6, 5]);
        assert_eq!(open.normals[4], -open.normals[0]);
        assert_eq!(open.traced_triangles().len(), 2);
        assert_eq!(open.front_of(1), Some(0));
        open.drop_back_sheets();
        assert_eq!(open.fingerprint(), before);
        let mut closed = scene(p, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]);
        closed.add_back_sheets().unwrap();
        assert_eq!(closed.objects.len(), 1);
    }
}
