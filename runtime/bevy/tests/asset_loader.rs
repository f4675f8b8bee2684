//! The asset loaders through Bevy's asset server (headless: MinimalPlugins + AssetPlugin +
//! PrtAssetsPlugin) read exactly what `load_export` and `load_texel_transfer` read, for every
//! form of export; bad files fail with the loader's typed error naming the file, never panic.
//!
//! Reads the exports `make bevy` writes (scripts/bevy/test.sh): BEVY_PRT_EXPORTS=target/bevy/test.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use bevy::asset::{AssetLoadError, AssetMetaCheck, LoadState};
use bevy::prelude::*;
use bevy_prt::{
    ExportError, PrtAssetsPlugin, PrtExport, TexelError, TexelTransfer, load_export,
    load_texel_transfer,
};

fn exports() -> PathBuf {
    let dir = std::env::var("BEVY_PRT_EXPORTS").expect(
        "BEVY_PRT_EXPORTS: the folder of make bevy's exports (scripts/bevy/test.sh sets it)",
    );
    std::fs::canonicalize(&dir).unwrap_or_else(|e| panic!("{dir}: {e}"))
}

fn app(root: &Path) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin {
            file_path: root.display().to_string(),
            meta_check: AssetMetaCheck::Never,
            ..default()
        },
        PrtAssetsPlugin,
    ));
    app
}

/// Updates the app until the asset has loaded (Ok) or failed (its error).
fn wait<A: Asset>(app: &mut App, handle: &Handle<A>) -> Result<(), Arc<AssetLoadError>> {
    for _ in 0..20_000 {
        app.update();
        match app.world().resource::<AssetServer>().load_state(handle) {
            LoadState::Loaded => return Ok(()),
            LoadState::Failed(e) => return Err(e),
            _ => std::thread::sleep(Duration::from_millis(1)),
        }
    }
    panic!("{:?}: not loaded after 20 000 updates", handle.path());
}

/// Every attribute (by id, as bytes) and the indices of a mesh.
fn mesh_data(mesh: &Mesh) -> (Vec<(&'static str, Vec<u8>)>, Vec<usize>) {
    let mut attributes: Vec<_> = mesh
        .attributes()
        .map(|(a, v)| (a.name, v.get_bytes().to_vec()))
        .collect();
    attributes.sort();
    let indices = mesh
        .indices()
        .map(|i| i.iter().collect())
        .unwrap_or_default();
    (attributes, indices)
}

fn assert_same_export(a: &PrtExport, b: &PrtExport, file: &str) {
    assert_eq!((a.order, a.channels), (b.order, b.channels), "{file}");
    assert_eq!(
        a.light.as_ref().map(|l| l.rgb.clone()),
        b.light.as_ref().map(|l| l.rgb.clone()),
        "{file}: light"
    );
    assert_eq!(a.parts.len(), b.parts.len(), "{file}: parts");
    for (p, q) in a.parts.iter().zip(&b.parts) {
        assert_eq!(p.name, q.name, "{file}");
        assert_eq!(
            mesh_data(&p.mesh),
            mesh_data(&q.mesh),
            "{file}: mesh '{}'",
            p.name
        );
        assert_eq!(p.vertex_transfer, q.vertex_transfer, "{file}: '{}'", p.name);
        assert_eq!(p.colours, q.colours, "{file}: COLOR_0 of '{}'", p.name);
        assert_eq!(p.base_color, q.base_color, "{file}: '{}'", p.name);
        assert_eq!(
            (p.lightmap, p.base_color_texture),
            (q.lightmap, q.base_color_texture)
        );
    }
    assert_eq!(a.images.len(), b.images.len(), "{file}: images");
    for (i, j) in a.images.iter().zip(&b.images) {
        assert_eq!(i.data, j.data, "{file}: image");
    }
}

#[test]
fn the_asset_server_loads_what_load_export_reads() {
    let root = exports();
    let mut app = app(&root);
    let files = [
        "torus.glb",
        "torus-q16.glb",
        "cornell-rgb.glb",
        "cornell-cpca.glb",
        "cornell-lm.glb",
    ];
    for file in files {
        let handle: Handle<PrtExport> = app.world().resource::<AssetServer>().load(file);
        wait(&mut app, &handle).unwrap_or_else(|e| panic!("{file}: {e}"));
        let assets = app.world().resource::<Assets<PrtExport>>();
        let loaded = assets.get(&handle).expect("loaded");
        let direct = load_export(&root.join(file)).expect("load_export");
        assert!(!direct.parts.is_empty(), "{file}: no parts");
        assert_same_export(loaded, &direct, file);
    }
    let handle: Handle<TexelTransfer> = app
        .world()
        .resource::<AssetServer>()
        .load("cornell-lm-exr/manifest.json");
    wait(&mut app, &handle).unwrap_or_else(|e| panic!("manifest: {e}"));
    let loaded = app
        .world()
        .resource::<Assets<TexelTransfer>>()
        .get(&handle)
        .expect("loaded");
    let direct = load_texel_transfer(&root.join("cornell-lm-exr")).expect("load_texel_transfer");
    assert_eq!(
        (loaded.order, loaded.channels, loaded.z_up),
        (direct.order, direct.channels, direct.z_up)
    );
    assert_eq!(
        loaded.image.texture_descriptor,
        direct.image.texture_descriptor
    );
    assert!(
        direct
            .image
            .data
            .as_ref()
            .is_some_and(|d| d.iter().any(|&b| b != 0))
    );
    assert_eq!(loaded.image.data, direct.image.data, "texel transfer");
}

/// The loader's own error for `file`, checked to be of type E and to name the file.
fn loader_error<E: std::error::Error + 'static>(error: Arc<AssetLoadError>, file: &str) -> String {
    let AssetLoadError::AssetLoaderError(e) = error.as_ref() else {
        panic!("{file}: not the loader's error: {error}");
    };
    let typed = e
        .error()
        .downcast_ref::<E>()
        .unwrap_or_else(|| panic!("{file}: not a {}: {e}", std::any::type_name::<E>()));
    let message = typed.to_string();
    assert!(
        message.contains(file),
        "{file}: the error does not name it: {message}"
    );
    message
}

#[test]
fn bad_files_fail_with_a_typed_error_naming_them() {
    let root = exports();
    let dir = std::env::temp_dir().join(format!("bevy_prt_loader_{}", std::process::id()));
    std::fs::create_dir_all(dir.join("no-images")).expect("temp dir");
    std::fs::write(dir.join("junk.glb"), b"not a glb at all").expect("write");
    // A valid glTF, but not a prt-bake export (no asset.extras.prt).
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cutout/card.glb"),
        dir.join("plain.glb"),
    )
    .expect("copy card.glb");
    std::fs::copy(
        root.join("cornell-lm-exr/manifest.json"),
        dir.join("no-images/manifest.json"),
    )
    .expect("copy manifest");
    std::fs::write(dir.join("broken.json"), b"{\"order\": 3").expect("write");
    let mut app = app(&dir);
    let mut messages = Vec::new();
    for file in ["junk.glb", "plain.glb"] {
        let handle: Handle<PrtExport> = app.world().resource::<AssetServer>().load(file);
        let error = wait(&mut app, &handle).expect_err(file);
        messages.push(loader_error::<ExportError>(error, file));
    }
    assert!(
        messages[1].contains("not a prt-bake export"),
        "{}",
        messages[1]
    );
    for (file, named) in [
        ("no-images/manifest.json", "transfer_"),
        ("broken.json", "broken.json"),
    ] {
        let handle: Handle<TexelTransfer> = app.world().resource::<AssetServer>().load(file);
        let error = wait(&mut app, &handle).expect_err(file);
        let message = loader_error::<TexelError>(error, named);
        messages.push(message);
    }
    for m in &messages {
        println!("{m}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
