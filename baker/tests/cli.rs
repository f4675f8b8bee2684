//! End-to-end tests of the `prt-bake` binary: every test runs the real executable on files it
//! writes into a scratch folder and checks what a user would see — the exit code, the error
//! message (which must name the file, and the line as `path:LINE` where there is one), and the
//! files left behind.
//!
//! Bad input files must exit with 3 (bad option values with 2), print one `prt-bake: error: …`
//! line and leave no output file, not even the writer's hidden `.NAME.tmp-PID` file. Each test
//! writes its outputs into an `out/` folder of its own scratch folder, so "nothing left behind"
//! is "`out/` holds exactly the expected names".
//!
//! The commands run inside the scratch folder with relative paths, so messages can be checked
//! exactly (`bad.obj:2: …`).
//!
//! The tests bake with the build's default backend (Embree, or obvhs in a build without the
//! `embree` feature), so they run in both builds; `make test` runs them in both.

mod common;

use std::io::Read;

use common::*;
use prt_baker::trace::Backend;
use prt_baker::{CoefficientFile, Scene};

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);

/// One triangle: 3 vertices.
const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// The same triangle, one corner moved: still 3 vertices, different geometry.
const MOVED_TRIANGLE: &str = "v 0 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\n";

/// A floor quad (4 vertices, each at the centre of one texel of a 2×2 texture) and a triangle
/// above it that shadows it (3 vertices): 7 vertices, small enough to bake in milliseconds.
const FLOOR_AND_OCCLUDER: &str = "\
o floor
v -1 0 -1
v 1 0 -1
v 1 0 1
v -1 0 1
vt 0.25 0.25
vt 0.75 0.25
vt 0.75 0.75
vt 0.25 0.75
vn 0 1 0
f 1/1/1 4/4/1 3/3/1 2/2/1
o occluder
v -0.5 0.5 -0.5
v -0.5 0.5 0.5
v 0.5 0.5 0
f 5 6 7
";
const FLOOR_AND_OCCLUDER_VERTICES: usize = 7;

/// A 2×2 uncompressed true-colour TGA.
fn tga_2x2() -> Vec<u8> {
    let mut bytes = vec![0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 2, 0, 24, 0x20];
    // BGR: red, green / blue, white.
    bytes.extend([0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255]);
    bytes
}

// ---------------------------------------------------------------------------------------------
// Bad scene input

#[test]
fn missing_scene_file_is_named() {
    let s = Scratch::new();
    s.run(&["bake", "nothere.scene", "-o", "out/x.prt"])
        .fails_with_bad_input(&["nothere.scene: ", "No such file"]);
    s.assert_out_holds(&[]);
}

#[test]
fn missing_object_in_scene_file_names_the_scene_line() {
    let s = Scratch::new();
    s.write("a.scene", "# objects\n\n\"nothere.obj\"\n");
    s.run(&["bake", "a.scene", "-o", "out/x.prt"])
        .fails_with_bad_input(&["a.scene:3: ", "cannot read object nothere.obj"]);
    s.assert_out_holds(&[]);
}

#[test]
fn malformed_obj_vertex_names_the_line() {
    let s = Scratch::new();
    s.write("bad.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n");
    s.run(&["bake", "bad.obj", "-o", "out/x.prt"])
        .fails_with_bad_input(&["bad.obj:2: ", "malformed vertex position"]);
    s.assert_out_holds(&[]);
}

#[test]
fn face_index_out_of_range_names_the_line() {
    let s = Scratch::new();
    s.write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n# comment\nf 1 2 4\n");
    s.run(&["bake", "bad.obj", "-o", "out/x.prt"])
        .fails_with_bad_input(&["bad.obj:5: ", "face index out of range"]);
    s.assert_out_holds(&[]);
}

#[test]
fn nan_coordinate_names_the_line() {
    let s = Scratch::new();
    s.write("bad.obj", "v 0 0 0\nv 1 0 0\nv nan 0 0\nf 1 2 3\n");
    s.run(&["bake", "bad.obj", "-o", "out/x.prt"])
        .fails_with_bad_input(&["bad.obj:3: ", "non-finite number", "v nan 0 0"]);
    s.assert_out_holds(&[]);
}

#[test]
fn mesh_without_faces_is_refused() {
    let s = Scratch::new();
    s.write("empty.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    s.run(&["bake", "empty.obj", "-o", "out/x.prt"])
        .fails_with_bad_input(&["empty.obj: ", "no faces"]);
    s.assert_out_holds(&[]);
}

#[test]
fn unbalanced_quote_in_scene_file_names_the_line() {
    let s = Scratch::new();
    s.write("tri.obj", TRIANGLE);
    s.write("a.scene", "# comment\n\"tri.obj\"\n\"tri.obj\n");
    s.run(&["bake", "a.scene", "-o", "out/x.prt"])
        .fails_with_bad_input(&["a.scene:3: ", "unbalanced quote"]);
    s.assert_out_holds(&[]);
}

#[test]
fn missing_texture_in_scene_file_names_the_scene_line() {
    let s = Scratch::new();
    s.write("tri.obj", TRIANGLE);
    s.write("a.scene", "# comment\n\"tri.obj\" \"nothere.tga\"\n");
    s.run(&["bake", "a.scene", "-o", "out/x.prt"])
        .fails_with_bad_input(&["a.scene:2: ", "texture nothere.tga does not exist"]);
    s.assert_out_holds(&[]);
}

#[test]
fn missing_map_kd_texture_names_the_mtl_line() {
    let s = Scratch::new();
    s.write(
        "a.obj",
        "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n",
    );
    s.write(
        "a.mtl",
        "# materials\nnewmtl red\nKd 1 0 0\nmap_Kd nothere.tga\n",
    );
    s.run(&["bake", "a.obj", "-o", "out/x.prt"])
        .fails_with_bad_input(&["a.mtl:4: ", "texture nothere.tga does not exist"]);
    s.assert_out_holds(&[]);
}

#[test]
fn missing_mtl_file_names_the_mtllib_line() {
    let s = Scratch::new();
    s.write(
        "a.obj",
        "# header\nmtllib nothere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    s.run(&["bake", "a.obj", "-o", "out/x.prt"])
        .fails_with_bad_input(&["a.obj:2: ", "cannot read material library nothere.mtl"]);
    s.assert_out_holds(&[]);
}

// ---------------------------------------------------------------------------------------------
// Bad coefficient files

#[test]
fn truncated_coefficient_file_is_refused_by_inspect_and_export() {
    let s = Scratch::new();
    s.write("tri.obj", TRIANGLE);
    s.bake("tri.obj", "tri.prt", &[]);
    let bytes = s.read("out/tri.prt");
    // Cut inside the coefficients, and inside the header.
    s.write("short.prt", &bytes[..bytes.len() - 4]);
    s.write("stub.prt", &bytes[..100]);
    s.write("empty.prt", b"");
    for (file, problem) in [
        ("short.prt", "truncated: the header announces"),
        ("stub.prt", "truncated: 100 bytes"),
        ("empty.prt", "not a PRT coefficient file"),
    ] {
        s.run(&["inspect", file])
            .fails_with_bad_input(&[&format!("{file}: {problem}")]);
        s.run(&["export", file, "--scene", "tri.obj", "--npz", "out/x.npz"])
            .fails_with_bad_input(&[&format!("{file}: {problem}")]);
    }
    s.assert_out_holds(&["tri.prt"]);
}

#[test]
fn flipped_byte_in_coefficients_or_header_fails_the_checksum() {
    let s = Scratch::new();
    s.write("tri.obj", TRIANGLE);
    s.bake("tri.obj", "tri.prt", &[]);
    let bytes = s.read("out/tri.prt");
    let flipped = |offset: usize| {
        let mut copy = bytes.clone();
        copy[offset] ^= 0x04;
        copy
    };
    // A byte of the first coefficient's mantissa; the seed field of the header.
    s.write(
        "data.prt",
        flipped(prt_baker::formats::coefficient_file::HEADER_SIZE + 1),
    );
    s.write("header.prt", flipped(48));
    for file in ["data.prt", "header.prt"] {
        let needles = [&format!("{file}: checksum mismatch")[..], "corrupted"];
        s.run(&["inspect", file]).fails_with_bad_input(&needles);
        s.run(&["export", file, "--scene", "tri.obj", "--npz", "out/x.npz"])
            .fails_with_bad_input(&needles);
    }
    s.assert_out_holds(&["tri.prt"]);
}

#[test]
fn export_refuses_a_file_baked_for_a_scene_with_another_vertex_count() {
    let s = Scratch::new();
    s.write("tri.obj", TRIANGLE);
    s.write("scene.obj", FLOOR_AND_OCCLUDER);
    s.bake("tri.obj", "tri.prt", &[]);
    s.run(&[
        "export",
        "out/tri.prt",
        "--scene",
        "scene.obj",
        "--npz",
        "out/x.npz",
    ])
    .fails_with_bad_input(&[
        "out/tri.prt: ",
        "baked for a scene with 3 vertices, but scene.obj has 7",
    ]);
    s.assert_out_holds(&["tri.prt"]);
}

#[test]
fn export_refuses_a_file_baked_for_moved_geometry_by_fingerprint() {
    let s = Scratch::new();
    s.write("tri.obj", TRIANGLE);
    s.write("moved.obj", MOVED_TRIANGLE);
    s.bake("tri.obj", "tri.prt", &[]);
    s.run(&[
        "export",
        "out/tri.prt",
        "--scene",
        "moved.obj",
        "--npz",
        "out/x.npz",
    ])
    .fails_with_bad_input(&["out/tri.prt: ", "baked for another scene: fingerprint"]);
    s.assert_out_holds(&["tri.prt"]);
}

// ---------------------------------------------------------------------------------------------
// Outputs

#[test]
fn failed_bake_leaves_the_existing_output_untouched() {
    let s = Scratch::new();
    s.write("tri.obj", TRIANGLE);
    s.write("bad.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n");
    s.bake("tri.obj", "x.prt", &[]);
    let before = s.read("out/x.prt");
    s.run(&["bake", "bad.obj", "-o", "out/x.prt", "--samples", "64"])
        .fails_with_bad_input(&["bad.obj:2: "]);
    assert_eq!(s.read("out/x.prt"), before, "the old output was changed");
    s.assert_out_holds(&["x.prt"]);
}

#[test]
fn missing_output_folder_is_reported_before_baking() {
    let s = Scratch::new();
    // A scene that would take a while to load and bake: the check must come first.
    s.run(&["bake", CORNELL, "-o", "nothere/x.prt", "--samples", "256"])
        .fails_with_bad_input(&["nothere/x.prt: ", "folder nothere does not exist"]);
    // Even before the scene is read.
    s.run(&["bake", "nothere.obj", "-o", "nothere/x.prt"])
        .fails_with_bad_input(&["folder nothere does not exist"]);
    s.write("tri.obj", TRIANGLE);
    s.bake("tri.obj", "tri.prt", &[]);
    s.run(&[
        "export",
        "out/tri.prt",
        "--scene",
        "tri.obj",
        "--npz",
        "nothere/x.npz",
    ])
    .fails_with_bad_input(&["nothere/x.npz: ", "folder nothere does not exist"]);
    assert!(!s.path("nothere").exists());
    s.assert_out_holds(&["tri.prt"]);
}

#[test]
fn bake_is_deterministic_across_thread_counts_and_depends_on_the_seed() {
    let s = Scratch::new();
    let bake = |output: &str, threads: &str, seed: &str| {
        s.bake(
            CORNELL,
            output,
            &["--samples", "256", "--threads", threads, "--seed", seed],
        );
        s.read(&format!("out/{output}"))
    };
    let one = bake("one.prt", "1", "5");
    let two = bake("two.prt", "2", "5");
    let other_seed = bake("other.prt", "2", "6");
    assert!(
        one == two,
        "--threads 1 and --threads 2 gave different files"
    );
    let header = prt_baker::formats::coefficient_file::HEADER_SIZE;
    assert_eq!(one.len(), other_seed.len());
    assert!(
        one[header..] != other_seed[header..],
        "another seed gave the same coefficients"
    );
    s.assert_out_holds(&["one.prt", "two.prt", "other.prt"]);
}

/// A `--samples` past a whole run of the Sobol points is noted (it adds more noise than it
/// takes away); whole runs are not, nor are probes (half their rays a hemisphere).
#[test]
fn samples_past_a_whole_sobol_run_are_noted() {
    let s = Scratch::new();
    let said = |samples: &str| s.bake(CORNELL, "n.prt", &["--samples", samples]).stderr;
    assert!(
        said("75").contains("prt-bake: note: --samples 75 is neither a power of two"),
        "{}",
        said("75")
    );
    assert!(!said("80").contains("note: --samples"), "{}", said("80"));
    let probes = s.bake(
        CORNELL,
        "p.prt",
        &["--samples", "6", "--probes", "grid:2,2,2"],
    );
    assert!(
        !probes.stderr.contains("note: --samples"),
        "{}",
        probes.stderr
    );
}

#[test]
fn inspect_prints_the_header_as_json() {
    let s = Scratch::new();
    s.write("scene.obj", FLOOR_AND_OCCLUDER);
    let fingerprint = Scene::load(&s.path("scene.obj")).unwrap().fingerprint();
    s.bake(
        "scene.obj",
        "shadowed.prt",
        &["--order", "3", "--seed", "42"],
    );
    s.bake(
        "scene.obj",
        "unshadowed.prt",
        &["--mode", "unshadowed", "--sampling", "thesis-random"],
    );

    let inspect = |file: &str| -> serde_json::Value {
        let run = s.run(&["inspect", file]).success();
        assert_eq!(run.stderr, "");
        serde_json::from_str(&run.stdout).expect("inspect prints JSON")
    };
    let shadowed = inspect("out/shadowed.prt");
    let expected = serde_json::json!({
        "version": 1,
        "order": 3,
        "channels": 1,
        "vertex_count": FLOOR_AND_OCCLUDER_VERTICES,
        "samples_per_vertex": 64,
        "mode": "shadowed",
        "bounces": 0,
        "backend": Backend::DEFAULT.name(),
        "sampling": "owen-sobol",
        "seed": 42,
        "scene_fingerprint": format!("{fingerprint:016x}"),
        "aux": [],
        "bounce_samples": 0,
        "up": "z",
        "checksum": shadowed["checksum"],
    });
    assert_eq!(shadowed, expected);
    let checksum = shadowed["checksum"].as_str().expect("checksum is a string");
    assert!(checksum.len() == 8 && checksum.chars().all(|c| c.is_ascii_hexdigit()));

    let unshadowed = inspect("out/unshadowed.prt");
    assert_eq!(unshadowed["order"], 4);
    assert_eq!(unshadowed["mode"], "unshadowed");
    assert_eq!(unshadowed["backend"], "none");
    assert_eq!(unshadowed["sampling"], "thesis-random");
    assert_eq!(unshadowed["seed"], 0);
    assert_eq!(
        unshadowed["scene_fingerprint"],
        expected["scene_fingerprint"]
    );
}

/// One float32 array read back from a `.npy` file.
struct Npy {
    shape: Vec<usize>,
    data: Vec<f32>,
}

/// Parses an `.npy` (format 1.0) holding a little-endian float32 C-order array.
fn parse_npy(bytes: &[u8]) -> Npy {
    assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00", "npy magic and version");
    let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    assert_eq!((10 + header_len) % 64, 0, "npy header is not padded to 64");
    let header = std::str::from_utf8(&bytes[10..10 + header_len]).unwrap();
    assert!(header.ends_with('\n'));
    assert!(header.contains("'descr': '<f4'"), "{header}");
    assert!(header.contains("'fortran_order': False"), "{header}");
    let shape = header
        .split("'shape': (")
        .nth(1)
        .and_then(|rest| rest.split(')').next())
        .unwrap_or_else(|| panic!("no shape in {header}"));
    let shape: Vec<usize> = shape
        .split(',')
        .map(str::trim)
        .filter(|d| !d.is_empty())
        .map(|d| d.parse().unwrap())
        .collect();
    let data: Vec<f32> = bytes[10 + header_len..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(data.len(), shape.iter().product::<usize>(), "npy data size");
    Npy { shape, data }
}

fn flat(values: &[glam::Vec3]) -> Vec<f32> {
    values.iter().flat_map(|v| v.to_array()).collect()
}

/// Compares floats bit for bit (so -0.0 ≠ 0.0 and any rounding shows).
fn assert_bits_eq(name: &str, found: &[f32], expected: &[f32]) {
    let bits = |x: &[f32]| x.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(found), bits(expected), "{name} differs");
}

#[test]
fn export_writes_npz_arrays_equal_to_the_scene_and_coefficients() {
    let s = Scratch::new();
    s.write("scene.obj", FLOOR_AND_OCCLUDER);
    s.write("checker.tga", tga_2x2());
    s.write("a.scene", "\"scene.obj\" \"checker.tga\"\n");
    s.bake("a.scene", "a.prt", &[]);
    let run = s
        .run(&[
            "export",
            "out/a.prt",
            "--scene",
            "a.scene",
            "--npz",
            "out/a.npz",
        ])
        .success();
    assert_eq!(run.stdout, "wrote out/a.npz (NumPy arrays of out/a.prt)\n");
    assert_eq!(run.stderr, "");
    s.assert_out_holds(&["a.prt", "a.npz"]);

    let scene = Scene::load(&s.path("a.scene")).unwrap();
    let coefficients = CoefficientFile::read(&s.path("out/a.prt")).unwrap();
    let v = FLOOR_AND_OCCLUDER_VERTICES;
    assert_eq!(scene.vertex_count(), v);

    let file = std::fs::File::open(s.path("out/a.npz")).unwrap();
    let mut zip = zip::ZipArchive::new(file).expect("the .npz is a zip archive");
    let mut names: Vec<String> = zip
        .file_names()
        .map(|name| name.unwrap().into_owned())
        .collect();
    names.sort_unstable();
    assert_eq!(
        names,
        [
            "albedo.npy",
            "normals.npy",
            "positions.npy",
            "transfer.npy",
            "triangles.npy",
            "uv.npy"
        ]
    );
    let mut array = |name: &str| {
        let mut bytes = Vec::new();
        zip.by_name(name).unwrap().read_to_end(&mut bytes).unwrap();
        parse_npy(&bytes)
    };

    let positions = array("positions.npy");
    assert_eq!(positions.shape, [v, 3]);
    assert_bits_eq("positions", &positions.data, &flat(&scene.positions));
    let normals = array("normals.npy");
    assert_eq!(normals.shape, [v, 3]);
    assert_bits_eq("normals", &normals.data, &flat(&scene.normals));
    let albedo = array("albedo.npy");
    assert_eq!(albedo.shape, [v, 3]);
    assert_bits_eq("albedo", &albedo.data, &flat(&scene.vertex_albedo()));
    // The texture reached the albedo: each floor corner sits on one texel (sRGB 255 decodes to
    // exactly 1). Vertices come in order of first use by the faces (v1 v4 v3 v2); v runs up
    // from the image's bottom row (blue, white) to its top row (red, green).
    let corners: Vec<[f32; 3]> = albedo.data[..12]
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    assert_eq!(
        corners,
        [
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 1.0]
        ]
    );
    let transfer = array("transfer.npy");
    assert_eq!(transfer.shape, [v, 1, 16]);
    assert_bits_eq("transfer", &transfer.data, &coefficients.coefficients);
    assert!(transfer.data.iter().any(|&c| c != 0.0));
}

#[test]
fn bake_summary_names_vertices_rays_rate_and_time() {
    let s = Scratch::new();
    s.write("scene.obj", FLOOR_AND_OCCLUDER);
    let run = s.bake("scene.obj", "a.prt", &[]);
    assert_eq!(run.stderr, "", "--quiet printed on stderr");
    let line = run
        .stdout
        .strip_suffix('\n')
        .expect("the summary ends with a newline");
    assert!(!line.contains('\n'), "more than one line:\n{}", run.stdout);

    let rays = FLOOR_AND_OCCLUDER_VERTICES * 64;
    let prefix = format!("baked {FLOOR_AND_OCCLUDER_VERTICES} vertices, {rays} rays, ");
    let rest = line
        .strip_prefix(&prefix)
        .unwrap_or_else(|| panic!("summary {line:?} does not start with {prefix:?}"));
    let (rate, rest) = rest.split_once(" Mrays/s, ").expect("Mrays/s");
    let (seconds, rest) = rest.split_once(" s (").expect("seconds");
    for number in [rate, seconds] {
        let value: f64 = number.parse().unwrap();
        assert!(value.is_finite() && value >= 0.0, "{line}");
    }
    assert_eq!(
        rest,
        format!(
            "order 4, shadowed, 64 samples, {}) -> out/a.prt",
            Backend::DEFAULT.name()
        ),
        "{line}"
    );
}

#[test]
fn bad_option_values_are_refused_before_anything_is_written() {
    let s = Scratch::new();
    s.write("tri.obj", TRIANGLE);
    for (option, value, message) in [
        ("--samples", "0", "--samples must be at least 1"),
        ("--order", "0", "--order 0 is outside 1..="),
        ("--order", "1000", "--order 1000 is outside 1..="),
        ("--threads", "0", "--threads must be at least 1"),
    ] {
        s.run(&["bake", "tri.obj", "-o", "out/x.prt", option, value])
            .fails_with(EXIT_BAD_COMMAND_LINE, &[message]);
    }
    s.assert_out_holds(&[]);
}

/// A red floor and a white wall meeting at a right angle, with materials: light bounces off
/// the red floor onto the wall in colour.
const RED_FLOOR_WHITE_WALL: &str = "\
mtllib room.mtl
o floor
usemtl red
v 0 0 0
v 2 0 0
v 2 2 0
v 0 2 0
vn 0 0 1
f 1//1 2//1 3//1 4//1
o wall
usemtl white
v 0 0 0
v 0 2 0
v 0 2 2
v 0 0 2
vn 1 0 0
f 5//2 6//2 7//2 8//2
";
const ROOM_MTL: &str = "newmtl red\nKd 0.8 0.1 0.1\n\nnewmtl white\nKd 0.7 0.7 0.7\n";

/// Reads every array of an `.npz` by name.
fn read_npz(path: &std::path::Path) -> std::collections::BTreeMap<String, Npy> {
    let mut zip = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).expect("a zip archive");
    let names: Vec<String> = zip.file_names().map(|n| n.unwrap().into_owned()).collect();
    names
        .into_iter()
        // The uint32 indices are checked in cli_gltf.rs.
        .filter(|name| name != "triangles.npy")
        .map(|name| {
            let mut bytes = Vec::new();
            zip.by_name(&name).unwrap().read_to_end(&mut bytes).unwrap();
            (name.trim_end_matches(".npy").to_string(), parse_npy(&bytes))
        })
        .collect()
}

#[test]
fn interreflected_bake_records_bounces_colour_and_aux_arrays() {
    let s = Scratch::new();
    s.write("room.obj", RED_FLOOR_WHITE_WALL);
    s.write("room.mtl", ROOM_MTL);
    let extra = [
        "--mode",
        "interreflected",
        "--bounces",
        "2",
        "--aux",
        "ao,bent-normal",
        "--samples",
        "256",
    ];
    let run = s.bake("room.obj", "a.prt", &extra);
    assert!(
        run.stdout
            .contains("interreflected, 2 bounces from 64 rays, 3 channels, hit cache"),
        "{}",
        run.stdout
    );

    let json: serde_json::Value =
        serde_json::from_str(&s.run(&["inspect", "out/a.prt"]).success().stdout).unwrap();
    assert_eq!(json["mode"], "interreflected");
    assert_eq!(json["bounces"], 2);
    assert_eq!(
        json["bounce_samples"], 64,
        "a quarter of the 256 samples by default"
    );
    assert_eq!(json["channels"], 3);
    assert_eq!(json["aux"], serde_json::json!(["ao", "bent-normal"]));

    s.run(&[
        "export",
        "out/a.prt",
        "--scene",
        "room.obj",
        "--npz",
        "out/a.npz",
    ])
    .success();
    let file = CoefficientFile::read(&s.path("out/a.prt")).unwrap();
    let arrays = read_npz(&s.path("out/a.npz"));
    let v = 8;
    assert_eq!(
        arrays.keys().collect::<Vec<_>>(),
        [
            "albedo",
            "ao",
            "bent_normal",
            "normals",
            "positions",
            "transfer"
        ]
    );
    assert_eq!(arrays["transfer"].shape, [v, 3, 16]);
    assert_bits_eq("transfer", &arrays["transfer"].data, &file.coefficients);
    assert_eq!(arrays["ao"].shape, [v]);
    assert_bits_eq("ao", &arrays["ao"].data, file.ao.as_ref().unwrap());
    assert_eq!(arrays["bent_normal"].shape, [v, 3]);
    assert_bits_eq(
        "bent_normal",
        &arrays["bent_normal"].data,
        &flat(file.bent_normal.as_ref().unwrap()),
    );
    // The wall (vertices 4..8) receives light bounced off the red floor: more red than green.
    let n = 16;
    for vertex in 4..v {
        let dc = |c: usize| file.coefficients[(vertex * 3 + c) * n];
        assert!(
            dc(0) > dc(1),
            "wall vertex {vertex}: red {} green {}",
            dc(0),
            dc(1)
        );
    }
    // Each quad hides part of the other's sky: a lot from the shared edge (floor vertices 0
    // and 3, wall vertices 4 and 5), little from the far corners.
    let ao = &arrays["ao"].data;
    for (vertex, &a) in ao.iter().enumerate() {
        let on_edge = [0, 3, 4, 5].contains(&vertex);
        assert!(
            if on_edge {
                a > 0.5 && a < 0.7
            } else {
                a > 0.9 && a < 0.99
            },
            "vertex {vertex}: {ao:?}"
        );
    }
}

#[test]
fn grey_scenes_keep_one_channel_when_interreflected() {
    let s = Scratch::new();
    s.write("a.obj", FLOOR_AND_OCCLUDER);
    let run = s.bake("a.obj", "a.prt", &["--mode", "interreflected"]);
    assert!(
        run.stdout
            .contains("interreflected, 1 bounce from 16 rays, 1 channels"),
        "{}",
        run.stdout
    );
    let file = CoefficientFile::read(&s.path("out/a.prt")).unwrap();
    assert_eq!((file.header.channels, file.header.bounces), (1, 1));
}

#[test]
fn the_hit_cache_limit_changes_memory_never_the_result() {
    // --hit-cache-mb 0 cannot hold one bounce row, so every bounce re-traces its rays.
    let s = Scratch::new();
    s.write("room.obj", RED_FLOOR_WHITE_WALL);
    s.write("room.mtl", ROOM_MTL);
    let common = [
        "--mode",
        "interreflected",
        "--bounces",
        "3",
        "--samples",
        "128",
    ];
    let cached = s.bake("room.obj", "cached.prt", &common);
    let retraced = s.bake(
        "room.obj",
        "retraced.prt",
        &[&common[..], &["--hit-cache-mb", "0"]].concat(),
    );
    assert!(cached.stdout.contains("hit cache"), "{}", cached.stdout);
    assert!(retraced.stdout.contains("re-traced"), "{}", retraced.stdout);
    assert_eq!(s.read("out/cached.prt"), s.read("out/retraced.prt"));
}

#[test]
fn bounce_and_aux_options_must_fit_the_mode() {
    let s = Scratch::new();
    s.write("tri.obj", TRIANGLE);
    for (args, message) in [
        (
            &["--bounces", "2"][..],
            "--bounces 2 needs --mode interreflected",
        ),
        (
            &["--mode", "interreflected", "--bounces", "0"][..],
            "--bounces must be at least 1",
        ),
        (
            &["--mode", "unshadowed", "--aux", "ao"][..],
            "--aux needs rays",
        ),
        (
            &["--bounce-samples", "8"][..],
            "--bounce-samples needs --mode interreflected",
        ),
        (
            &[
                "--mode",
                "interreflected",
                "--samples",
                "64",
                "--bounce-samples",
                "65",
            ][..],
            "--bounce-samples 65 must be in 1..=64",
        ),
    ] {
        let mut all = vec!["bake", "tri.obj", "-o", "out/x.prt"];
        all.extend(args);
        s.run(&all).fails_with(EXIT_BAD_COMMAND_LINE, &[message]);
    }
    s.assert_out_holds(&[]);
}

// ---------------------------------------------------------------------------------------------
// Backends

#[test]
fn obvhs_backend_bakes_and_is_recorded_in_the_header() {
    let s = Scratch::new();
    s.write("scene.obj", FLOOR_AND_OCCLUDER);
    let run = s.bake("scene.obj", "a.prt", &["--backend", "obvhs"]);
    assert!(
        run.stdout.contains(", obvhs) -> out/a.prt"),
        "{}",
        run.stdout
    );
    let file = CoefficientFile::read(&s.path("out/a.prt")).unwrap();
    assert_eq!(file.header.backend, Backend::Obvhs);
    let json = s.run(&["inspect", "out/a.prt"]).success().stdout;
    let header: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(header["backend"], "obvhs");
    // The occluder shadows the floor (vertices 0..4): the rays were really traced.
    s.bake("scene.obj", "b.prt", &["--mode", "unshadowed"]);
    let unshadowed = CoefficientFile::read(&s.path("out/b.prt")).unwrap();
    let floor_t00 = |f: &CoefficientFile| (0..4).map(|v| f.vertex(v, 0)[0]).sum::<f32>();
    assert!(floor_t00(&file) < floor_t00(&unshadowed));
}

#[test]
fn robust_mode_is_refused_for_obvhs() {
    let s = Scratch::new();
    s.write("tri.obj", TRIANGLE);
    s.run(&[
        "bake",
        "tri.obj",
        "-o",
        "out/x.prt",
        "--backend",
        "obvhs",
        "--robust",
    ])
    .fails_with(
        EXIT_BAD_COMMAND_LINE,
        &["--robust", "does not apply to --backend obvhs"],
    );
    s.assert_out_holds(&[]);
}

#[cfg(not(feature = "embree"))]
#[test]
fn embree_backend_is_refused_by_a_build_without_it() {
    let s = Scratch::new();
    s.write("tri.obj", TRIANGLE);
    s.run(&["bake", "tri.obj", "-o", "out/x.prt", "--backend", "embree"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["built without Embree"]);
    s.assert_out_holds(&[]);
}

#[test]
fn adaptive_bake_is_deterministic_and_inspect_reports_its_rays_and_errors() {
    let s = Scratch::new();
    let bake = |output: &str, threads: &str| {
        let args = ["--samples", "4096", "--target-error", "2e-3"];
        let run = s.bake(
            CORNELL,
            output,
            &[&args[..], &["--threads", threads]].concat(),
        );
        assert!(
            run.stdout.contains("adaptive to 2e-3"),
            "summary: {}",
            run.stdout
        );
        s.read(&format!("out/{output}"))
    };
    let one = bake("one.prt", "1");
    let two = bake("two.prt", "2");
    assert!(
        one == two,
        "--threads 1 and --threads 2 gave different adaptive files"
    );

    let file = CoefficientFile::read(&s.path("out/one.prt")).unwrap();
    let adaptive = file.header.adaptive.expect("an adaptive header");
    assert_eq!(adaptive.target_error, 2e-3);
    assert_eq!(adaptive.replicates, 4);
    let rays = file.rays.as_deref().expect("per-vertex rays");
    let errors = file.error_estimate.as_deref().expect("per-vertex errors");
    assert_eq!(
        rays.iter().map(|&r| u64::from(r)).sum::<u64>(),
        adaptive.rays_cast
    );
    // Open walls stop after the pilot (4 blocks × 64 points); contact shadows cast more
    // (only near their edges: the other answers are inferred); every vertex stops at or
    // below the target or at --samples.
    assert_eq!(rays.iter().min(), Some(&256));
    assert!(rays.iter().any(|&r| r > 384), "no vertex needed more rays");
    for (&r, &e) in rays.iter().zip(errors) {
        assert!(e <= 2e-3 || r == 4096, "stopped at {r} rays with error {e}");
    }

    let run = s.run(&["inspect", "out/one.prt"]).success();
    let json: serde_json::Value = serde_json::from_str(&run.stdout).expect("inspect prints JSON");
    assert_eq!(json["adaptive"]["rays_cast"], adaptive.rays_cast);
    assert_eq!(json["adaptive"]["replicates"], 4);
    let per_vertex = &json["per_vertex"];
    assert_eq!(per_vertex["rays_per_vertex"]["min"], 256.0);
    for quantity in ["rays_per_vertex", "estimated_error"] {
        for stat in ["min", "median", "p95", "max", "mean"] {
            assert!(
                per_vertex[quantity][stat].is_number(),
                "inspect lacks {quantity}.{stat}: {}",
                run.stdout
            );
        }
    }
    assert!(per_vertex["vertices_above_target"].is_number());

    s.run(&[
        "export",
        "out/one.prt",
        "--scene",
        CORNELL,
        "--npz",
        "out/one.npz",
    ])
    .success();
    let arrays = read_npz(&s.path("out/one.npz"));
    let exported: Vec<u32> = arrays["rays"].data.iter().map(|&r| r as u32).collect();
    assert_eq!(exported, rays);
    assert_bits_eq("error_estimate", &arrays["error_estimate"].data, errors);

    // Texels: the same estimator per baked texel, deterministic too; inspect summarises the
    // baked texels only.
    let texels = |output: &str, threads: &str| {
        let args = [
            "--samples",
            "4096",
            "--target-error",
            "2e-3",
            "--lightmap",
            "32",
        ];
        let run = s.bake(
            CORNELL,
            output,
            &[&args[..], &["--threads", threads]].concat(),
        );
        assert!(
            run.stdout.contains("rays per texel on average"),
            "summary: {}",
            run.stdout
        );
        s.read(&format!("out/{output}"))
    };
    assert!(
        texels("t1.prt", "1") == texels("t2.prt", "2"),
        "--threads 1 and --threads 2 gave different adaptive texel files"
    );
    let file = CoefficientFile::read(&s.path("out/t1.prt")).unwrap();
    let valid = &file.lightmap.as_ref().expect("a texel file").valid;
    let rays = file.rays.as_deref().expect("per-texel rays");
    for (&r, &v) in rays.iter().zip(valid) {
        assert_eq!(r > 0, v, "rays {r}, baked {v}");
    }
    let run = s.run(&["inspect", "out/t1.prt"]).success();
    let json: serde_json::Value = serde_json::from_str(&run.stdout).expect("inspect prints JSON");
    assert_eq!(json["per_texel"]["rays_per_vertex"]["min"], 256.0);
    // The reader refuses rays at a texel that was not baked (the total kept).
    let mut bad = file.clone();
    let rays = bad.rays.as_mut().expect("rays");
    let (empty, baked) = (
        valid.iter().position(|&v| !v).expect("an empty texel"),
        valid.iter().position(|&v| v).expect("a baked texel"),
    );
    rays[empty] = 5;
    rays[baked] -= 5;
    bad.write(&s.path("out/bad.prt")).unwrap();
    let Err(err) = CoefficientFile::read(&s.path("out/bad.prt")) else {
        panic!("rays at texel {empty}, which was not baked, were accepted");
    };
    assert!(
        err.to_string()
            .contains(&format!("texel {empty} cast 5 rays but is not baked")),
        "{err}"
    );
}

#[test]
fn target_error_is_refused_where_it_is_not_supported() {
    let s = Scratch::new();
    s.write("tri.obj", TRIANGLE);
    for (extra, message) in [
        (
            &["--mode", "interreflected"][..],
            "--target-error needs --mode shadowed",
        ),
        (
            &["--mode", "unshadowed"],
            "--target-error needs --mode shadowed",
        ),
        (
            &["--sampling", "thesis-random"],
            "--target-error needs --sampling owen-sobol",
        ),
        (&["--samples", "100"], "needs --samples of at least 256"),
    ] {
        let mut args = vec![
            "bake",
            "tri.obj",
            "-o",
            "out/x.prt",
            "--target-error",
            "1e-3",
        ];
        args.extend(extra);
        s.run(&args).fails_with(EXIT_BAD_COMMAND_LINE, &[message]);
    }
    s.run(&["bake", "tri.obj", "-o", "out/x.prt", "--target-error", "0"])
        .fails_with(
            EXIT_BAD_COMMAND_LINE,
            &["--target-error 0 must be a positive number"],
        );
    s.assert_out_holds(&[]);
}
