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

/// The [`StandardMaterial`] of a part (matte: roughness 1, no metal, no reflectance), `unlit`
/// or lit by Bevy.
pub fn standard_material(
    part: &PrtPart,
    images: &[Handle<Image>],
    unlit: bool,
) -> StandardMaterial {
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

/// How [`spawn_prt`] draws the parts.
#[derive(Clone, Copy, Debug, Default)]
pub struct PrtStyle {
    /// Clamps Σ T·L to [0, 1] (as an export's COLOR_0 and lightmap are).
    pub clamp_shading: bool,
    /// Bevy's specular from the scene's Bevy lights on top of T·L ([`PrtExtension::specular`]).
    pub specular: Option<Specular>,
}

/// The StandardMaterial parameters of [`PrtStyle::specular`] (an export's materials are matte).
#[derive(Clone, Copy, Debug)]
pub struct Specular {
    pub perceptual_roughness: f32,
    pub metallic: f32,
    pub reflectance: f32,
}

/// Spawns every part relit by PRT: per vertex where the part carries transfer attributes, per
/// texel from `texel` otherwise.
pub fn spawn_prt(
    commands: &mut Commands,
    export: &PrtExport,
    texel: Option<&TexelTransfer>,
    style: PrtStyle,
    meshes: &mut Assets<Mesh>,
    images: &mut Assets<Image>,
    materials: &mut Assets<PrtMaterial>,
) -> Result<Vec<Entity>, String> {
    let image_handles = add_images(export, images);
    let transfer = texel.map(|t| images.add(t.image.clone()));
    let mut spawned = Vec::new();
    let clamp_shading = style.clamp_shading;
    for part in &export.parts {
        let mut extension = if part.vertex_transfer {
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
        let mut base = standard_material(part, &image_handles, true);
        if let Some(s) = style.specular {
            extension.specular = true;
            // Bevy's shader reads roughness, metallic and reflectance of lit materials only.
            base.unlit = false;
            base.perceptual_roughness = s.perceptual_roughness;
            base.metallic = s.metallic;
            base.reflectance = s.reflectance;
        }
        let material = materials.add(PrtMaterial { base, extension });
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
            entity.insert(MeshMaterial3d(materials.add(standard_material(
                part,
                &image_handles,
                true,
            ))));
        } else if let Some(lightmap) = part.lightmap {
            entity.insert((
                MeshMaterial3d(materials.add(StandardMaterial {
                    lightmap_exposure: 1.0,
                    ..standard_material(part, &image_handles, false)
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
