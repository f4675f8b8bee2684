//! Texel (lightmap) bakes in shards and checkpoints (docs/guides/clusters.md, "Lightmap bakes"):
//! `bake --lightmap RES --shard K/N`, `merge`, and `bake --lightmap RES --checkpoint DIR`,
//! through the real `prt-bake` binary. The oracle is the whole bake: the merge of the parts,
//! and a checkpointed bake killed with SIGKILL and run again, must give its file byte for byte.

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::*;
use prt_baker::distribute::shard::Part;

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);
const TORUS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/torus/torus.scene");

/// Bakes the Cornell room's 40² lightmap whole and in 3 shards (shard k on k % 2 + 1 threads,
/// merged from the parts in reverse order), and checks the merge is the whole bake's file.
fn assert_texel_merge_is_the_whole_bake(s: &Scratch, name: &str, extra: &[&str]) {
    assert_merge_of(s, CORNELL, name, extra);
}

/// [`assert_texel_merge_is_the_whole_bake`] of `scene`.
fn assert_merge_of(s: &Scratch, scene: &str, name: &str, extra: &[&str]) {
    let base = [&["--lightmap", "40"], extra].concat();
    s.bake(scene, &format!("{name}.prt"), &base);
    let mut parts = Vec::new();
    for k in 0..3 {
        let part = format!("{name}-{k}.part.prt");
        let (shard, threads) = (format!("{k}/3"), format!("{}", k % 2 + 1));
        let args = [&base[..], &["--shard", &shard, "--threads", &threads]].concat();
        let run = s.bake(scene, &part, &args);
        assert!(
            run.stdout
                .contains(&format!("shard {k} of 3 (baked texels ")),
            "{}",
            run.stdout
        );
        parts.push(format!("out/{part}"));
    }
    parts.reverse();
    let merged = format!("out/{name}.merged.prt");
    let mut args = vec!["merge", "--quiet", "-o", &merged];
    args.extend(parts.iter().map(String::as_str));
    let run = s.run(&args).success();
    assert!(run.stdout.contains("40×40 texels"), "{}", run.stdout);
    assert!(
        s.read(&format!("out/{name}.prt")) == s.read(&merged),
        "{name}: the merge of 3 texel parts differs from the whole texel bake"
    );
}

#[test]
fn merged_texel_shards_equal_the_whole_texel_bake() {
    let s = Scratch::new();
    assert_texel_merge_is_the_whole_bake(&s, "shadowed", &[]);
    assert_texel_merge_is_the_whole_bake(&s, "aux", &["--aux", "ao,bent-normal"]);
    assert_texel_merge_is_the_whole_bake(&s, "unshadowed", &["--mode", "unshadowed"]);
    // Denoised: the parts carry their texels' noise and guides, the merge denoises every
    // texel before placing the lightmap, as the whole bake does (and it did change the file).
    let denoised = ["--aux", "ao,bent-normal", "--denoise", "on"];
    assert_texel_merge_is_the_whole_bake(&s, "denoised", &denoised);
    assert!(s.read("out/denoised.prt") != s.read("out/aux.prt"));
    let header = s.run(&["inspect", "out/denoised.merged.prt"]).success();
    assert!(
        header.stdout.contains("\"denoised\": true"),
        "{}",
        header.stdout
    );
    // The torus's unwrapped charts meet at smooth seams, which the merge stitches as the
    // whole bake does (the room's boards meet at creases only).
    let stitched = ["--atlas", "unwrap", "--aux", "ao", "--samples", "256"];
    assert_merge_of(&s, TORUS, "torus-seams", &stitched);
    let denoised = [&stitched[..], &["--denoise", "on"]].concat();
    assert_merge_of(&s, TORUS, "torus-denoised", &denoised);
    let run = s
        .run(
            &[
                &[
                    "bake",
                    TORUS,
                    "-o",
                    "out/torus-seams-again.prt",
                    "--lightmap",
                    "40",
                ][..],
                &stitched[..],
            ]
            .concat(),
        )
        .success();
    assert!(run.stdout.contains("seams stitched at "), "{}", run.stdout);
    // Coloured walls: 3 channels, two bounces gathered by the merge over the dilated lightmap.
    let interreflected = ["--mode", "interreflected", "--bounces", "2", "--aux", "ao"];
    assert_texel_merge_is_the_whole_bake(&s, "rgb", &interreflected);
    // Denoised after the merge's bounces, as the whole bake denoises after its own.
    let denoised = [&interreflected[..], &["--denoise", "on"]].concat();
    assert_texel_merge_is_the_whole_bake(&s, "rgb-denoised", &denoised);
    let header = s.run(&["inspect", "out/rgb.merged.prt"]).success().stdout;
    assert!(header.contains("\"channels\": 3"), "{header}");
    assert!(header.contains("\"width\": 40"), "{header}");

    // Shards are balanced by baked texels (rays), not by objects or lightmap rows: each of
    // the 3 parts holds a third of the baked texels (±1).
    let mut counts = Vec::new();
    for k in 0..3 {
        let part = Part::read(&s.path(&format!("out/rgb-{k}.part.prt"))).unwrap();
        let lightmap = part.lightmap.as_ref().expect("a texel part");
        counts.push((part.id.vertices as u64, lightmap.receivers));
    }
    // More shards than baked texels: most parts are empty, and the merge is still the bake.
    s.write(
        "tri.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n",
    );
    let tiny = ["--lightmap", "8", "--mode", "interreflected"];
    s.bake("tri.obj", "tiny.prt", &tiny);
    let mut args = vec![
        "merge".to_string(),
        "-o".into(),
        "out/tiny.merged.prt".into(),
    ];
    for k in 0..16 {
        let shard = format!("{k}/16");
        s.bake(
            "tri.obj",
            &format!("tiny-{k}.prt"),
            &[&tiny[..], &["--shard", &shard]].concat(),
        );
        args.push(format!("out/tiny-{k}.prt"));
    }
    s.run(&args.iter().map(String::as_str).collect::<Vec<_>>())
        .success();
    assert!(s.read("out/tiny.prt") == s.read("out/tiny.merged.prt"));

    let total = counts[0].1;
    assert_eq!(counts.iter().map(|c| c.0).sum::<u64>(), total);
    for (held, _) in &counts {
        assert!(held.abs_diff(total / 3) <= 1, "{counts:?}");
    }
}

#[test]
fn a_texel_merge_without_rays_equals_a_whole_bake_that_re_traced_its_bounces() {
    let s = Scratch::new();
    let options = [
        "--lightmap",
        "40",
        "--mode",
        "interreflected",
        "--bounces",
        "2",
    ];
    let retraced = [&options[..], &["--hit-cache-mb", "0"]].concat();
    let run = s.bake(CORNELL, "retraced.prt", &retraced);
    assert!(run.stdout.contains("re-traced"), "{}", run.stdout);
    for k in 0..2 {
        let shard = format!("{k}/2");
        let args = [&options[..], &["--shard", &shard]].concat();
        s.bake(CORNELL, &format!("p{k}.prt"), &args);
    }
    s.run(&["merge", "out/p1.prt", "out/p0.prt", "-o", "out/merged.prt"])
        .success();
    assert!(s.read("out/retraced.prt") == s.read("out/merged.prt"));
}

#[test]
fn texel_merges_refuse_parts_of_other_atlases_scenes_and_options() {
    let s = Scratch::new();
    let lm = ["--lightmap", "40"];
    for k in 0..3 {
        let shard = format!("{k}/3");
        s.bake(
            CORNELL,
            &format!("p{k}.prt"),
            &[&lm[..], &["--shard", &shard]].concat(),
        );
    }
    let other = |name: &str, extra: &[&str]| {
        let args = [extra, &["--shard", "2/3"]].concat();
        s.bake(CORNELL, name, &args);
    };
    other("planar.prt", &["--lightmap", "40", "--atlas", "planar"]);
    other("res.prt", &["--lightmap", "48"]);
    other("seed.prt", &["--lightmap", "40", "--seed", "3"]);
    other("vertex.prt", &[]);
    s.bake(TORUS, "torus.prt", &["--lightmap", "40", "--shard", "2/3"]);
    // The same part with only its atlas fingerprint changed (what two shards that computed
    // different atlases or leak tests would write).
    let mut forged = Part::read(&s.path("out/p2.prt")).unwrap();
    forged.lightmap.as_mut().unwrap().fingerprint ^= 1;
    s.write("out/forged.prt", forged.to_bytes());

    let cases: [(&str, &[&str]); 6] = [
        (
            "planar",
            &[
                "a part of another bake than out/p0.prt",
                "atlas fingerprint",
            ],
        ),
        ("res", &["vertex_count 2304 instead of 1600"]),
        ("seed", &["seed 3 instead of 0"]),
        (
            "vertex",
            &["a part of another bake than out/p0.prt", "vertex_count"],
        ),
        ("torus", &["scene fingerprint (another scene)"]),
        (
            "forged",
            &[
                "out/forged.prt: a part of another bake than out/p0.prt",
                "another lightmap atlas or set of baked texels: atlas fingerprint",
            ],
        ),
    ];
    for (name, needles) in cases {
        let path = format!("out/{name}.prt");
        s.run(&[
            "merge",
            "out/p0.prt",
            "out/p1.prt",
            &path,
            "-o",
            "out/m.prt",
        ])
        .fails_with_bad_input(needles);
        assert!(
            !s.path("out/m.prt").exists(),
            "{name}: a refused merge wrote"
        );
    }
    s.run(&["merge", "out/p0.prt", "out/p2.prt", "-o", "out/m.prt"])
        .fails_with_bad_input(&["shard 1 of 3 missing"]);
    // Shard 0's part carries the atlas for every part; the others leave it out (they are
    // smaller by it), and a shard 0 part without it is refused.
    let (p0, p1) = (
        Part::read(&s.path("out/p0.prt")).unwrap(),
        Part::read(&s.path("out/p1.prt")).unwrap(),
    );
    let (l0, l1) = (p0.lightmap.as_ref().unwrap(), p1.lightmap.as_ref().unwrap());
    assert!(l0.carried && !l0.uv1.is_empty());
    assert!(!l1.carried && l1.in_shard_zero && l1.uv1.is_empty());
    let mut bare = p0.clone();
    bare.lightmap = Some(l0.in_shard_zero());
    s.write("out/bare.prt", bare.to_bytes());
    s.run(&[
        "merge",
        "out/bare.prt",
        "out/p1.prt",
        "out/p2.prt",
        "-o",
        "out/m.prt",
    ])
    .fails_with_bad_input(&[
        "shard 0 of 3",
        "shard 0's part without its lightmap's atlas",
    ]);
    // A part that leaves the atlas out but is not marked as leaving it to shard 0 is a
    // checkpoint block.
    let mut block = p1.clone();
    block.lightmap = Some(l1.without_arrays());
    s.write("out/block.prt", block.to_bytes());
    s.run(&[
        "merge",
        "out/p0.prt",
        "out/block.prt",
        "out/p2.prt",
        "-o",
        "out/m.prt",
    ])
    .fails_with_bad_input(&["a checkpoint block (without its lightmap's atlas)"]);
    assert!(!s.path("out/m.prt").exists(), "a refused merge wrote");
    // A texel part is not a bake, and inspect says what it holds.
    s.run(&[
        "export",
        "out/p0.prt",
        "--scene",
        CORNELL,
        "--npz",
        "out/p0.npz",
    ])
    .fails_with_bad_input(&["a shard part (shard 0 of 3", "prt-bake merge"]);
    let run = s.run(&["inspect", "out/p1.prt"]).success();
    for needle in ["\"atlas_fingerprint\"", "\"baked_texels\"", "\"count\": 3"] {
        assert!(run.stdout.contains(needle), "{needle}: {}", run.stdout);
    }
    // Adaptive texel bakes are whole bakes: no shards.
    s.run(&[
        "bake",
        CORNELL,
        "-o",
        "out/a.prt",
        "--lightmap",
        "40",
        "--target-error",
        "0.01",
        "--shard",
        "0/3",
    ])
    .fails_with(EXIT_BAD_COMMAND_LINE, &["--target-error"]);
}

fn blocks_in(dir: &Path) -> usize {
    std::fs::read_dir(dir).map_or(0, |entries| {
        entries
            .filter(|e| {
                let name = e.as_ref().unwrap().file_name();
                let name = name.to_string_lossy();
                name.starts_with("block-") && name.ends_with(".prt")
            })
            .count()
    })
}

#[test]
fn a_checkpointed_texel_bake_killed_with_sigkill_resumes_to_the_same_file() {
    let s = Scratch::new();
    // About 12,000 baked texels in blocks of 128 on one thread, interreflected: the kill
    // lands mid-bake.
    let args = [
        "bake",
        CORNELL,
        "-o",
        "out/resumed.prt",
        "--quiet",
        "--lightmap",
        "128",
        "--samples",
        "256",
        "--threads",
        "1",
        "--mode",
        "interreflected",
        "--bounces",
        "2",
        "--aux",
        "ao,bent-normal",
        // --denoise auto: a checkpointed texel bake is denoised once its blocks are joined,
        // as the uninterrupted bake below (which drops the checkpoint) is.
        "--checkpoint",
        "out/checkpoint",
        "--checkpoint-vertices",
        "128",
    ];
    let mut child = Command::new(env!("CARGO_BIN_EXE_prt-bake"))
        .args(args)
        .current_dir(s.path(""))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start prt-bake");
    let checkpoint = s.path("out/checkpoint");
    let started = Instant::now();
    while blocks_in(&checkpoint) < 3 {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "no checkpoint blocks after two minutes"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "the bake ended before it was killed"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().expect("SIGKILL the bake");
    child.wait().unwrap();
    let kept = blocks_in(&checkpoint);
    assert!(
        !s.path("out/resumed.prt").exists(),
        "a killed bake left an output"
    );

    let run = s.run(&args).success();
    let resumed = format!(" blocks ({kept} resumed from out/checkpoint)");
    assert!(
        run.stdout.contains(&resumed),
        "expected {resumed:?} in {}",
        run.stdout
    );
    let total: usize = run
        .stdout
        .split(" blocks (")
        .next()
        .unwrap()
        .rsplit(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!((3..total).contains(&kept), "{kept} of {total} blocks");

    let whole: Vec<&str> = args[..args.len() - 4]
        .iter()
        .map(|a| match *a {
            "out/resumed.prt" => "out/whole.prt",
            a => a,
        })
        .collect();
    s.run(&whole).success();
    assert!(
        s.read("out/resumed.prt") == s.read("out/whole.prt"),
        "the resumed texel bake differs from the uninterrupted one"
    );
    let header = s.run(&["inspect", "out/resumed.prt"]).success().stdout;
    assert!(header.contains("\"denoised\": true"), "{header}");

    // A block carries its texels, not the atlas (flag bit 0 at byte 180), and is no part.
    let block = s.read("out/checkpoint/block-000000.prt");
    assert_eq!(block[180..184], [1, 0, 0, 0], "a block carries the atlas");
    s.run(&[
        "merge",
        "out/checkpoint/block-000000.prt",
        "-o",
        "out/block.prt",
    ])
    .fails_with_bad_input(&["block-000000.prt", "a checkpoint block"]);

    // A checkpoint folder of another atlas is refused, never overwritten.
    let mut planar: Vec<&str> = args
        .iter()
        .map(|a| match *a {
            "out/resumed.prt" => "out/planar.prt",
            a => a,
        })
        .collect();
    planar.extend(["--atlas", "planar"]);
    s.run(&planar).fails_with_bad_input(&[
        "a checkpoint of another bake",
        "use another --checkpoint folder",
    ]);
}

/// A `.gltf` of two objects whose lightmap UVs (TEXCOORD_1) both cover [0, 1]: a 4×4 floor
/// and a 2×1 wall standing on it, 6×6 cells each. The bake packs them per object.
fn overlapping_objects_gltf() -> String {
    use serde_json::json;
    let (mut bin, mut views, mut accessors, mut meshes) = (vec![], vec![], vec![], vec![]);
    let mut add = |bytes: Vec<u8>, count: usize, kind: &str, component: u32| {
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend(bytes);
        let mut accessor = json!({"bufferView": views.len() - 1, "count": count, "type": kind, "componentType": component});
        if kind == "VEC3" {
            accessor["min"] = json!([-2.0, 0.0, -2.0]);
            accessor["max"] = json!([2.0, 1.0, 2.0]);
        }
        accessors.push(accessor);
        accessors.len() - 1
    };
    let cells = 6;
    let walls: [([f32; 3], [f32; 3], [f32; 3]); 2] = [
        ([-2.0, 0.0, 2.0], [4.0, 0.0, 0.0], [0.0, 0.0, -4.0]),
        ([-1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ];
    for (name, (origin, u, v)) in ["Floor", "Wall"].iter().zip(walls) {
        let (mut positions, mut uv1, mut indices) = (vec![], vec![], vec![]);
        for j in 0..=cells {
            for i in 0..=cells {
                let (a, b) = (i as f32 / cells as f32, j as f32 / cells as f32);
                positions.extend((0..3).map(|k| origin[k] + a * u[k] + b * v[k]));
                uv1.extend([a, 1.0 - b]);
            }
        }
        for j in 0..cells {
            for i in 0..cells {
                let at = |i: u32, j: u32| j * (cells + 1) + i;
                indices.extend([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                indices.extend([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        let count = positions.len() / 3;
        let floats = |x: &[f32]| x.iter().flat_map(|f| f.to_le_bytes()).collect::<Vec<u8>>();
        let p = add(floats(&positions), count, "VEC3", 5126);
        let t = add(floats(&uv1), count, "VEC2", 5126);
        let i = add(
            indices.iter().flat_map(|i| i.to_le_bytes()).collect(),
            indices.len(),
            "SCALAR",
            5125,
        );
        meshes.push(json!({"name": name, "primitives": [{"attributes": {"POSITION": p, "TEXCOORD_1": t}, "indices": i}]}));
    }
    json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"name": "Floor", "mesh": 0}, {"name": "Wall", "mesh": 1}],
        "meshes": meshes, "accessors": accessors, "bufferViews": views,
        "buffers": [{"byteLength": bin.len(), "uri": format!("data:application/octet-stream;base64,{}", base64(&bin))}],
    })
    .to_string()
}

/// Objects whose own lightmap UVs overlap each other are packed per object; their parts
/// carry the placements, so shards merge, and a checkpointed bake resumes, to the whole
/// bake's file (placements included), shadowed and interreflected.
#[test]
fn per_object_atlases_shard_and_checkpoint_like_whole_bakes() {
    let s = Scratch::new();
    s.write("objects.gltf", overlapping_objects_gltf());
    assert_merge_of(&s, "objects.gltf", "objects", &["--aux", "ao"]);
    let bounces = ["--mode", "interreflected", "--bounces", "2"];
    assert_merge_of(&s, "objects.gltf", "objects-rgb", &bounces);
    let inspected = s.run(&["inspect", "out/objects.merged.prt"]).success();
    let placements = inspected.stdout.matches("\"scale\"").count();
    assert_eq!(placements, 2, "{}", inspected.stdout);

    // A checkpointed bake over blocks of 64 texels, run to the end, is the whole bake;
    // both denoised by default (--denoise auto), the objects' texels kept apart.
    let auto = ["--lightmap", "40", "--aux", "ao", "--denoise", "auto"];
    s.bake("objects.gltf", "objects-auto.prt", &auto);
    s.run(&[
        "bake",
        "objects.gltf",
        "-o",
        "out/checkpointed.prt",
        "--quiet",
        "--lightmap",
        "40",
        "--samples",
        "64",
        "--aux",
        "ao",
        "--checkpoint",
        "out/objects-checkpoint",
        "--checkpoint-vertices",
        "64",
    ])
    .success();
    assert!(s.read("out/checkpointed.prt") == s.read("out/objects-auto.prt"));
    assert!(s.read("out/checkpointed.prt") != s.read("out/objects.prt"));
}
