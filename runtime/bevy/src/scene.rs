//! Spawning an export: relit by PRT ([`spawn_prt`]), or as exported ([`spawn_exported`]):
//! COLOR_0 unlit for vertex bakes, Bevy's own [`Lightmap`] of the relit lightmap for texel
//! bakes (the plain-Lightmap baseline the frame times are measured against).

use bevy::pbr::Lightmap;
use bevy::prelude::*;

use crate::export::{PrtExport, PrtPart};
use crate::material::{PrtExtension, PrtMaterial};
use crate::texel::TexelTransfer;

/// Marks the entities spawned from an export.
#[derive(Component)]
pub struct PrtPartOf;

fn base_material(part: &PrtPart, images: &[Handle<Image>], unlit: bool) -> StandardMaterial {
    StandardMaterial {
        base_color: Color::LinearRgba(part.base_color),
        base_color_texture: part.base_color_texture.map(|i| images[i].clone()),
        unlit,
        // A sheet of a two-sided pair shows its own side only (docs/reference/gltf.md).
        cull_mode: if part.double_sided && !part.sheet {
            None
        } else {
            Some(bevy::render::render_resource::Face::Back)
        },
        double_sided: part.double_sided && !part.sheet,
        alpha_mode: part.alpha_mode,
        perceptual_roughness: 1.0,
        metallic: 0.0,
        reflectance: 0.0,
        ..default()
    }
}

/// The export's images as assets.
pub fn add_images(export: &PrtExport, images: &mut Assets<Image>) -> Vec<Handle<Image>> {
    export
        .images
        .iter()
        .map(|i| images.add(i.clone()))
        .collect()
}

/// Spawns every part relit by PRT: per vertex where the part carries transfer attributes, per
/// texel from `texel` otherwise. `clamp_shading` clamps Σ T·L to [0, 1] (as COLOR_0 is).
pub fn spawn_prt(
    commands: &mut Commands,
    export: &PrtExport,
    texel: Option<&TexelTransfer>,
    clamp_shading: bool,
    meshes: &mut Assets<Mesh>,
    images: &mut Assets<Image>,
    materials: &mut Assets<PrtMaterial>,
) -> Result<Vec<Entity>, String> {
    let image_handles = add_images(export, images);
    let transfer = texel.map(|t| images.add(t.image.clone()));
    let mut spawned = Vec::new();
    for part in &export.parts {
        let extension = if part.vertex_transfer {
            PrtExtension::new(
                export.order,
                export.channels == 3,
                None,
                false,
                clamp_shading,
            )
        } else {
            let (Some(t), Some(handle)) = (texel, &transfer) else {
                return Err(format!(
                    "mesh '{}' has no transfer attributes: a texel bake needs its `export --exr` folder",
                    part.name
                ));
            };
            PrtExtension::new(
                t.order,
                t.channels == 3,
                Some(handle.clone()),
                t.z_up,
                clamp_shading,
            )
        };
        let material = materials.add(PrtMaterial {
            base: base_material(part, &image_handles, true),
            extension,
        });
        let entity = commands
            .spawn((
                Mesh3d(meshes.add(part.mesh.clone())),
                MeshMaterial3d(material),
                PrtPartOf,
                Name::new(part.name.clone()),
            ))
            .id();
        spawned.push(entity);
    }
    Ok(spawned)
}

/// Spawns every part as exported: base colour × COLOR_0 unlit (vertex bakes exported with
/// `--lights`), or a lit [`StandardMaterial`] with Bevy's [`Lightmap`] holding the relit
/// lightmap (texel bakes). Scenes lit this way need no light but the lightmap: no ambient.
pub fn spawn_exported(
    commands: &mut Commands,
    export: &PrtExport,
    meshes: &mut Assets<Mesh>,
    images: &mut Assets<Image>,
    materials: &mut Assets<StandardMaterial>,
) -> Result<Vec<Entity>, String> {
    let image_handles = add_images(export, images);
    let mut spawned = Vec::new();
    for part in &export.parts {
        let mut mesh = part.mesh.clone();
        let mut entity = commands.spawn((PrtPartOf, Name::new(part.name.clone())));
        if let Some(colours) = &part.colours {
            mesh.insert_attribute(Mesh::ATTRIBUTE_COLOR, colours.clone());
            entity.insert(MeshMaterial3d(materials.add(base_material(
                part,
                &image_handles,
                true,
            ))));
        } else if let Some(lightmap) = part.lightmap {
            entity.insert((
                MeshMaterial3d(materials.add(StandardMaterial {
                    lightmap_exposure: 1.0,
                    ..base_material(part, &image_handles, false)
                })),
                Lightmap {
                    image: image_handles[lightmap].clone(),
                    uv_rect: Rect::new(0.0, 0.0, 1.0, 1.0),
                    bicubic_sampling: false,
                },
            ));
        } else {
            return Err(format!(
                "mesh '{}': neither COLOR_0 nor a relit lightmap (export with --lights)",
                part.name
            ));
        }
        entity.insert(Mesh3d(meshes.add(mesh)));
        spawned.push(entity.id());
    }
    Ok(spawned)
}
