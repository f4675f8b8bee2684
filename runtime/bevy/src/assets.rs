//! The exports through Bevy's asset server: [`PrtExportLoader`] reads a `.glb` export as a
//! [`PrtExport`], [`TexelTransferLoader`] a texel bake's `export --exr` manifest (and the
//! images beside it) as a [`TexelTransfer`]. Both are typed loads:
//!
//! ```ignore
//! let scene: Handle<PrtExport> = asset_server.load("cornell-lm.glb");
//! let texel: Handle<TexelTransfer> = asset_server.load("cornell-lm-exr/manifest.json");
//! ```
//!
//! Neither claims a file extension: Bevy's glTF loader keeps `.glb` (a `Scene`, or an
//! untyped load, still reads the file as glTF), and `.json` stays free. Bevy picks the loader
//! of the asset type asked for.

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, LoadContext};
use bevy::prelude::*;

use crate::export::{ExportError, PrtExport, parse_export};
use crate::texel::{TexelError, TexelTransfer, assemble, parse_manifest};

/// Registers the [`PrtExport`] and [`TexelTransfer`] assets and their loaders (needs only
/// Bevy's `AssetPlugin`; [`crate::PrtPlugin`] adds it).
pub struct PrtAssetsPlugin;

impl Plugin for PrtAssetsPlugin {
    fn build(&self, app: &mut App) {
        app.init_asset::<PrtExport>()
            .init_asset::<TexelTransfer>()
            .register_asset_loader(PrtExportLoader)
            .register_asset_loader(TexelTransferLoader);
    }
}

/// Loads a prt-bake `.glb` export: vertex transfer (float or `--quantize`d), CPCA-compressed
/// (reconstructed on load), or a texel bake's meshes and relit lightmap.
#[derive(Default, TypePath)]
pub struct PrtExportLoader;

impl AssetLoader for PrtExportLoader {
    type Asset = PrtExport;
    type Settings = ();
    type Error = ExportError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        load_context: &mut LoadContext<'_>,
    ) -> Result<PrtExport, ExportError> {
        let path = load_context.path().path().to_path_buf();
        let mut bytes = Vec::new();
        reader
            .read_to_end(&mut bytes)
            .await
            .map_err(|e| ExportError::Content {
                path: path.clone(),
                message: e.to_string(),
            })?;
        parse_export(&bytes, &path)
    }
}

/// Loads a texel bake's transfer from the `manifest.json` of `prt-bake export --exr DIR`,
/// reading the `transfer_*.exr` images it names from beside it.
#[derive(Default, TypePath)]
pub struct TexelTransferLoader;

impl AssetLoader for TexelTransferLoader {
    type Asset = TexelTransfer;
    type Settings = ();
    type Error = TexelError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        load_context: &mut LoadContext<'_>,
    ) -> Result<TexelTransfer, TexelError> {
        let manifest_path = load_context.path().path().to_path_buf();
        let read_error = |path: &std::path::Path, message: String| TexelError::Read {
            path: path.to_path_buf(),
            message,
        };
        let mut bytes = Vec::new();
        reader
            .read_to_end(&mut bytes)
            .await
            .map_err(|e| read_error(&manifest_path, e.to_string()))?;
        let text =
            String::from_utf8(bytes).map_err(|e| read_error(&manifest_path, e.to_string()))?;
        let manifest = parse_manifest(&text, &manifest_path)?;
        let mut files = Vec::new();
        for file in manifest.files() {
            let asset = load_context
                .path()
                .resolve_embed_str(file)
                .map_err(|e| read_error(&manifest_path, format!("{file}: {e}")))?;
            let path = asset.path().to_path_buf();
            let bytes = load_context
                .read_asset_bytes(asset)
                .await
                .map_err(|e| read_error(&path, e.to_string()))?;
            files.push((path, bytes));
        }
        assemble(&manifest, &manifest_path, &files)
    }
}
