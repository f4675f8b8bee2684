//! Back sheets of glTF `doubleSided` objects (docs/scenes.md, "Two-sided surfaces").
//!
//! Transfer is baked for the side a receiver's normal faces, so a surface an engine shades on
//! both sides needs a second set of receivers: the same positions with the shading normals
//! flipped and the winding reversed, as a user would model twin sheets by hand. Each back
//! sheet is an ordinary object, appended after every object of the file, so vertex order,
//! lightmaps, exports and renderers need nothing new; only the tracers leave them out
//! ([`Scene::traced_triangles`]): the front sheet already stops rays from both sides.

use std::collections::HashMap;

use glam::Vec4;

use super::{Object, Scene};

/// Which objects are back sheets: the last `fronts.len()` objects, each the twin of the
/// object `fronts[k]` names.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BackSheets {
    pub fronts: Vec<u32>,
}

impl Scene {
    /// Appends a back sheet for every open object whose material is `doubleSided` (none for
    /// OBJ and scene files, which have no such flag). A closed object's inside is never seen
    /// (Blender's exporter marks every material `doubleSided` unless backface culling is on,
    /// so a Suzanne or a cube would otherwise bake twice the receivers, half of them shut in). The glTF loader calls it; a scene that
    /// already has them is left as it is. Refuses to pass 2^32 vertices.
    pub fn add_back_sheets(&mut self) -> std::result::Result<(), String> {
        if !self.back_sheets.fronts.is_empty() {
            return Ok(());
        }
        let fronts: Vec<u32> = (0..self.objects.len() as u32)
            .filter(|&o| {
                let object = &self.objects[o as usize];
                let first = object.vertices.start as usize;
                !object.triangles.is_empty()
                    && self
                        .vertex_material
                        .get(first)
                        .is_some_and(|&m| self.materials[m as usize].double_sided)
                    && !self.is_closed(object)
            })
            .collect();
        let added: usize = fronts
            .iter()
            .map(|&o| self.objects[o as usize].vertices.len())
            .sum();
        if u32::try_from(self.positions.len() + added).is_err() {
            return Err(format!(
                "more than 2^32 vertices with the back sheets of its doubleSided materials ({added} vertices); bake with --double-sided off"
            ));
        }
        for &front in &fronts {
            let object = self.objects[front as usize].clone();
            let vertices = object.vertices.start as usize..object.vertices.end as usize;
            let base = self.positions.len() as u32;
            let first_triangle = self.triangles.len() as u32;
            self.positions.extend_from_within(vertices.clone());
            self.normals.extend(
                self.normals[vertices.clone()]
                    .iter()
                    .map(|n| -*n)
                    .collect::<Vec<_>>(),
            );
            self.uvs.extend_from_within(vertices.clone());
            self.vertex_material.extend_from_within(vertices.clone());
            if let Some(uvs) = &mut self.lightmap_uvs {
                uvs.extend_from_within(vertices.clone());
            }
            // The whole tangent frame turned over, so a normal-mapped back shades with the
            // front's perturbed normal negated, as engines draw a back face.
            if let Some(tangents) = &mut self.tangents {
                let flipped: Vec<Vec4> = tangents[vertices.clone()]
                    .iter()
                    .map(|t| Vec4::new(-t.x, -t.y, -t.z, -t.w))
                    .collect();
                tangents.extend(flipped);
            }
            let shift = base - object.vertices.start;
            let triangles = object.triangles.start as usize..object.triangles.end as usize;
            let reversed: Vec<[u32; 3]> = self.triangles[triangles]
                .iter()
                .map(|&[a, b, c]| [a + shift, c + shift, b + shift])
                .collect();
            self.triangles.extend(reversed);
            if let Some(h) = &mut self.hierarchy
                && let Some(&node) = h.object_node.get(front as usize)
            {
                h.object_node.push(node);
            }
            self.objects.push(Object {
                name: format!("{} (back)", object.name),
                vertices: base..self.positions.len() as u32,
                triangles: first_triangle..self.triangles.len() as u32,
            });
        }
        self.back_sheets = BackSheets { fronts };
        Ok(())
    }

    /// Removes the back sheets (`bake --double-sided off`, or a reader of a file baked
    /// without them): the scene is then the one bakes before them saw, fingerprint and all.
    pub fn drop_back_sheets(&mut self) {
        let Some(first) = self.first_back_sheet() else {
            return;
        };
        let object = &self.objects[first];
        let (vertices, triangles) = (
            object.vertices.start as usize,
            object.triangles.start as usize,
        );
        self.positions.truncate(vertices);
        self.normals.truncate(vertices);
        self.uvs.truncate(vertices);
        self.vertex_material.truncate(vertices);
        if let Some(uvs) = &mut self.lightmap_uvs {
            uvs.truncate(vertices);
        }
        if let Some(tangents) = &mut self.tangents {
            tangents.truncate(vertices);
        }
        self.triangles.truncate(triangles);
        if let Some(h) = &mut self.hierarchy {
            h.object_node.truncate(first);
        }
        self.objects.truncate(first);
        self.back_sheets = BackSheets::default();
    }

    /// Whether every edge of `object` (vertices welded by position) joins two triangles or
    /// more: a closed surface, whose back faces are inside it.
    fn is_closed(&self, object: &Object) -> bool {
        let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
        let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
        let triangles = object.triangles.start as usize..object.triangles.end as usize;
        for t in &self.triangles[triangles] {
            let w = t.map(|v| {
                let next = ids.len() as u32;
                *ids.entry(self.positions[v as usize].to_array().map(f32::to_bits))
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

    /// The index of the first back-sheet object, if there are any.
    pub fn first_back_sheet(&self) -> Option<usize> {
        let count = self.back_sheets.fronts.len();
        (count > 0).then(|| self.objects.len() - count)
    }

    /// The object whose back sheet object `o` is, or `None` for a front (or single) sheet.
    pub fn front_of(&self, o: usize) -> Option<usize> {
        let first = self.first_back_sheet()?;
        o.checked_sub(first)
            .map(|k| self.back_sheets.fronts[k] as usize)
    }

    /// The triangles the tracers occlude with: every triangle but the back sheets', which
    /// lie after them (their fronts stop rays from both sides).
    pub fn traced_triangles(&self) -> &[[u32; 3]] {
        match self.first_back_sheet() {
            Some(first) => &self.triangles[..self.objects[first].triangles.start as usize],
            None => &self.triangles,
        }
    }
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
