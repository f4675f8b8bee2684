//! End-to-end tests of `prt-bake bake --lightmap` and of exporting texel bakes.

mod common;

use std::io::Read;

use common::*;

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);

/// Each array's npy header (dtype and shape), by name.
fn npz_headers(path: &std::path::Path) -> std::collections::BTreeMap<String, String> {
    let mut zip = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).expect("a zip archive");
    let names: Vec<String> = zip.file_names().map(|n| n.unwrap().into_owned()).collect();
    names
        .into_iter()
        .map(|name| {
            let mut bytes = Vec::new();
            zip.by_name(&name).unwrap().read_to_end(&mut bytes).unwrap();
            let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
            let header = String::from_utf8(bytes[10..10 + len].to_vec()).unwrap();
            (name.trim_end_matches(".npy").to_string(), header)
        })
        .collect()
}

#[test]
fn texel_bakes_are_deterministic_and_export_texel_arrays() {
    let s = Scratch::new();
    let lightmap = ["--lightmap", "32", "--aux", "ao"];
    let one = s.bake(
        CORNELL,
        "one.prt",
        &[&lightmap[..], &["--threads", "1"]].concat(),
    );
    assert!(one.stdout.contains("of 32×32 texels"), "{}", one.stdout);
    s.bake(
        CORNELL,
        "two.prt",
        &[&lightmap[..], &["--threads", "2"]].concat(),
    );
    assert!(
        s.read("out/one.prt") == s.read("out/two.prt"),
        "--threads 1 and 2 gave different texel files"
    );
    let inspect = s.run(&["inspect", "out/one.prt"]).success();
    assert!(
        inspect.stdout.contains("\"width\": 32") && inspect.stdout.contains("baked_texels"),
        "{}",
        inspect.stdout
    );
    s.run(&[
        "export",
        "out/one.prt",
        "--scene",
        CORNELL,
        "--npz",
        "out/one.npz",
    ])
    .success();
    let headers = npz_headers(&s.path("out/one.npz"));
    let triangles = prt_baker::Scene::load(std::path::Path::new(CORNELL))
        .unwrap()
        .triangles
        .len();
    for (name, descr, shape) in [
        ("texel_positions", "<f4", "(32, 32, 3)".to_string()),
        ("texel_normals", "<f4", "(32, 32, 3)".to_string()),
        ("texel_valid", "|b1", "(32, 32)".to_string()),
        ("texel_dilated", "|b1", "(32, 32)".to_string()),
        ("transfer", "<f4", "(32, 32, 1, 16)".to_string()),
        ("uv1", "<f4", format!("({triangles}, 3, 2)")),
        ("ao", "<f4", "(32, 32)".to_string()),
    ] {
        let header = headers.get(name).unwrap_or_else(|| panic!("no {name}"));
        assert!(
            header.contains(&format!("'descr': '{descr}'")),
            "{name}: {header}"
        );
        assert!(
            header.contains(&format!("'shape': {shape}")),
            "{name}: {header}"
        );
    }
    // Relit, a texel bake is a PNG lightmap; not a PLY mesh.
    s.write(
        "rig.toml",
        include_str!("../../viewer/src/default-rig.toml"),
    );
    let relight = |output: &str| {
        s.run(&[
            "relight",
            CORNELL,
            "out/one.prt",
            "--lights",
            "rig.toml",
            "-o",
            output,
        ])
    };
    relight("out/x.ply").fails_with(2, &["relights to a .png"]);
    relight("out/lit.png").success();
    let png = image::load_from_memory(&s.read("out/lit.png")).expect("a PNG");
    assert_eq!((png.width(), png.height()), (32, 32));
    let lit = png.to_rgb8().pixels().filter(|p| p.0 != [0, 0, 0]).count();
    let file = prt_baker::CoefficientFile::read(&s.path("out/one.prt")).unwrap();
    let block = file.lightmap.unwrap();
    let filled = (0..32 * 32)
        .filter(|&i| block.valid[i] || block.dilated[i])
        .count();
    assert!(
        lit > filled / 2 && lit <= filled,
        "{lit} lit pixels, {filled} filled texels"
    );
    s.assert_out_holds(&["one.prt", "two.prt", "one.npz", "lit.png"]);
}

#[test]
fn lightmap_options_are_checked() {
    let s = Scratch::new();
    let bake = |extra: &[&str]| {
        let mut args = vec!["bake", CORNELL, "-o", "out/x.prt", "--quiet"];
        args.extend(extra);
        s.run(&args)
    };
    bake(&["--texel-size", "0.1"]).fails_with(2, &["--lightmap"]);
    bake(&["--lightmap", "0"]).fails_with(2, &["--lightmap 0"]);
    bake(&["--lightmap", "64", "--texel-size", "0.001"]).fails_with(2, &["do not fit"]);
    // Refused before the atlas is made: the memory is stated, nothing is allocated.
    bake(&["--lightmap", "16384", "--max-memory", "1024"])
        .fails_with(3, &["268435456 texels", "over the memory limit"]);
    s.assert_out_holds(&[]);
}

#[test]
fn the_atlas_unwrapper_is_chosen_with_atlas() {
    let s = Scratch::new();
    let lightmap = ["--lightmap", "32", "--samples", "16"];
    s.bake(CORNELL, "default.prt", &lightmap);
    s.bake(
        CORNELL,
        "unwrap.prt",
        &[&lightmap[..], &["--atlas", "unwrap"]].concat(),
    );
    s.bake(
        CORNELL,
        "planar.prt",
        &[&lightmap[..], &["--atlas", "planar"]].concat(),
    );
    assert!(s.read("out/default.prt") == s.read("out/unwrap.prt"));
    assert!(s.read("out/default.prt") != s.read("out/planar.prt"));
    let bake = |extra: &[&str]| {
        let mut args = vec!["bake", CORNELL, "-o", "out/x.prt", "--quiet"];
        args.extend(extra);
        s.run(&args)
    };
    bake(&["--atlas", "planar"]).fails_with(2, &["--lightmap"]);
    // clap's own usage error (several lines, listing the values).
    let unknown = bake(&["--lightmap", "32", "--atlas", "xatlas"]);
    assert_eq!(unknown.code, Some(2));
    assert!(
        unknown.stderr.contains("unwrap, planar"),
        "{}",
        unknown.stderr
    );
    s.assert_out_holds(&["default.prt", "unwrap.prt", "planar.prt"]);
}

#[test]
fn interreflected_texel_bakes_are_colour_and_deterministic() {
    // The Cornell room's coloured walls: an interreflected texel bake is accepted, stored
    // with 3 channels, and bit-identical for --threads 1 and 2.
    let s = Scratch::new();
    let args = [
        "--lightmap",
        "24",
        "--mode",
        "interreflected",
        "--samples",
        "64",
    ];
    let one = s.bake(
        CORNELL,
        "one.prt",
        &[&args[..], &["--threads", "1"]].concat(),
    );
    assert!(one.stdout.contains("3 channels"), "{}", one.stdout);
    s.bake(
        CORNELL,
        "two.prt",
        &[&args[..], &["--threads", "2"]].concat(),
    );
    assert!(
        s.read("out/one.prt") == s.read("out/two.prt"),
        "--threads 1 and 2 gave different interreflected texel files"
    );
    let inspect = s.run(&["inspect", "out/one.prt"]).success();
    for field in [
        "\"mode\": \"interreflected\"",
        "\"channels\": 3",
        "\"width\": 24",
    ] {
        assert!(inspect.stdout.contains(field), "{}", inspect.stdout);
    }
}

#[test]
fn whole_lightmap_bakes_are_denoised_by_default_and_say_so() {
    let s = Scratch::new();
    let lightmap = ["--lightmap", "32", "--samples", "16", "--order", "3"];
    s.bake(
        CORNELL,
        "auto.prt",
        &[&lightmap[..], &["--denoise", "auto"]].concat(),
    );
    s.bake(
        CORNELL,
        "off.prt",
        &[&lightmap[..], &["--denoise", "off"]].concat(),
    );
    let inspect = |name: &str| s.run(&["inspect", &format!("out/{name}")]).success().stdout;
    assert!(inspect("auto.prt").contains("\"denoised\": true"));
    assert!(!inspect("off.prt").contains("denoised"));
    assert!(s.read("out/auto.prt") != s.read("out/off.prt"));
    // A vertex bake stays raw unless asked; an unshadowed bake has nothing to denoise;
    // probes are not denoised (shards and checkpoints are: cli_lightmap_shards.rs,
    // cli_distributed.rs, cli_lightmap_stages.rs).
    s.bake(CORNELL, "vertex.prt", &["--samples", "16"]);
    assert!(!inspect("vertex.prt").contains("denoised"));
    s.bake(
        CORNELL,
        "vertex-on.prt",
        &["--samples", "16", "--denoise", "on"],
    );
    assert!(inspect("vertex-on.prt").contains("\"denoised\": true"));
    let bake = |extra: &[&str]| {
        let mut args = vec!["bake", CORNELL, "-o", "out/x.prt", "--quiet"];
        args.extend(extra);
        s.run(&args)
    };
    bake(&["--mode", "unshadowed", "--denoise", "on"]).fails_with(2, &["--denoise on"]);
    bake(&["--probes", "grid:2,2,2", "--denoise", "on"]).fails_with(2, &["--denoise on"]);

    // Without --samples a denoised bake casts 64 rays a receiver, a raw one 1,024, and an
    // adaptive one (denoised too) keeps 1,024 as its cap.
    let rays_of = |extra: &[&str]| {
        let base = [
            "bake",
            CORNELL,
            "-o",
            "out/x.prt",
            "--quiet",
            "--order",
            "2",
        ];
        let summary = s.run(&[&base[..], extra].concat()).success().stdout;
        let samples = |n: u32| summary.contains(&format!(" {n} samples,"));
        assert!(samples(64) != samples(1024), "{summary}");
        if samples(64) { 64 } else { 1024 }
    };
    assert_eq!(rays_of(&["--lightmap", "16"]), 64);
    assert_eq!(rays_of(&["--lightmap", "16", "--denoise", "off"]), 1024);
    assert_eq!(rays_of(&["--threads", "1", "--denoise", "on"]), 64);
    assert_eq!(
        rays_of(&["--lightmap", "16", "--target-error", "0.5"]),
        1024
    );
    assert_eq!(rays_of(&["--mode", "unshadowed"]), 1024);
    std::fs::remove_file(s.path("out/x.prt")).unwrap();

    s.assert_out_holds(&["auto.prt", "off.prt", "vertex.prt", "vertex-on.prt"]);
}
