//! End-to-end tests of bakes that outgrow one machine (docs/guides/clusters.md): `bake --shard`,
//! `merge`, and `bake --checkpoint`, run through the real `prt-bake` binary. The oracle is the
//! single-machine bake: a merge of parts, and a checkpointed bake killed with SIGKILL and run
//! again, must give the same file byte for byte.

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::*;

const CORNELL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../scenes/cornell/cornell.scene"
);
const TORUS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/torus/torus.scene");

/// Bakes `scene` whole and in `count` shards (merged from the parts given in reverse order),
/// and checks the merge equals the whole bake byte for byte.
fn assert_merge_is_the_whole_bake(
    s: &Scratch,
    scene: &str,
    name: &str,
    count: u32,
    extra: &[&str],
) {
    s.bake(scene, &format!("{name}.prt"), extra);
    let mut parts = Vec::new();
    for k in 0..count {
        let part = format!("{name}-{k}.part.prt");
        let shard = format!("{k}/{count}");
        let mut args = extra.to_vec();
        args.extend(["--shard", &shard]);
        let run = s.bake(scene, &part, &args);
        assert!(
            run.stdout.contains(&format!("shard {k} of {count}")),
            "{}",
            run.stdout
        );
        parts.push(format!("out/{part}"));
    }
    parts.reverse();
    let merged = format!("out/{name}.merged.prt");
    let mut args = vec!["merge", "--quiet", "-o", &merged];
    args.extend(parts.iter().map(String::as_str));
    s.run(&args).success();
    assert!(
        s.read(&format!("out/{name}.prt")) == s.read(&merged),
        "{name}: the merge of {count} parts differs from the single-machine bake"
    );
}

#[test]
fn merged_shards_equal_the_single_machine_bake_in_every_mode() {
    let s = Scratch::new();
    assert_merge_is_the_whole_bake(&s, CORNELL, "shadowed", 3, &[]);
    assert_merge_is_the_whole_bake(&s, CORNELL, "aux", 4, &["--aux", "ao,bent-normal"]);
    assert_merge_is_the_whole_bake(&s, CORNELL, "unshadowed", 2, &["--mode", "unshadowed"]);
    // The Cornell box's coloured walls: three channels, two bounces gathered by the merge.
    let interreflected = ["--mode", "interreflected", "--bounces", "2", "--aux", "ao"];
    assert_merge_is_the_whole_bake(&s, CORNELL, "rgb", 5, &interreflected);
    // Denoised: the parts carry their vertices' noise and guides, and the merge denoises
    // every vertex (after the bounces) as the whole bake does.
    let denoised = ["--aux", "ao,bent-normal", "--denoise", "on"];
    assert_merge_is_the_whole_bake(&s, CORNELL, "denoised", 4, &denoised);
    assert!(s.read("out/denoised.prt") != s.read("out/aux.prt"));
    let denoised = [&interreflected[..], &["--denoise", "on"]].concat();
    assert_merge_is_the_whole_bake(&s, CORNELL, "rgb-denoised", 3, &denoised);
    let thesis = [
        "--mode",
        "interreflected",
        "--sampling",
        "thesis-random",
        "--bounces",
        "2",
    ];
    assert_merge_is_the_whole_bake(&s, CORNELL, "thesis", 2, &thesis);
    let header = s.run(&["inspect", "out/rgb.prt"]).success().stdout;
    assert!(header.contains("\"channels\": 3"), "{header}");
    // More shards than vertices of some shards' share: a shard may be empty.
    s.write("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    assert_merge_is_the_whole_bake(&s, "tri.obj", "tiny", 5, &[]);
}

#[test]
fn the_merge_without_rays_equals_a_bake_that_re_traced_its_bounces() {
    // A whole bake over its hit-cache budget re-traces the bounce rays; parts always carry
    // their rows and the merge gathers them: the same file.
    let s = Scratch::new();
    let options = [
        "--mode",
        "interreflected",
        "--bounces",
        "2",
        "--hit-cache-mb",
        "0",
    ];
    let run = s.bake(CORNELL, "retraced.prt", &options);
    assert!(run.stdout.contains("re-traced"), "{}", run.stdout);
    let parts = ["--mode", "interreflected", "--bounces", "2"];
    for k in 0..2 {
        s.bake(
            CORNELL,
            &format!("p{k}.prt"),
            &[&parts[..], &["--shard", &format!("{k}/2")]].concat(),
        );
    }
    s.run(&["merge", "out/p0.prt", "out/p1.prt", "-o", "out/merged.prt"])
        .success();
    assert!(s.read("out/retraced.prt") == s.read("out/merged.prt"));

    // A part cannot fall back to re-tracing: over the budget, it is refused.
    let run = s.run(&[
        "bake",
        CORNELL,
        "-o",
        "out/over.prt",
        "--samples",
        "64",
        "--mode",
        "interreflected",
        "--hit-cache-mb",
        "0",
        "--shard",
        "0/2",
    ]);
    run.fails_with(
        EXIT_BAD_COMMAND_LINE,
        &["exceed --hit-cache-mb 0", "use more shards"],
    );
    s.assert_out_holds(&["retraced.prt", "p0.prt", "p1.prt", "merged.prt"]);
}

#[test]
fn merge_refuses_missing_duplicated_and_foreign_parts_and_writes_nothing() {
    let s = Scratch::new();
    for k in 0..3 {
        s.bake(
            CORNELL,
            &format!("p{k}.prt"),
            &["--shard", &format!("{k}/3")],
        );
    }
    s.bake(CORNELL, "seed1.prt", &["--shard", "2/3", "--seed", "1"]);
    s.bake(TORUS, "torus.prt", &["--shard", "2/3"]);
    s.bake(CORNELL, "of4.prt", &["--shard", "2/4"]);
    s.bake(CORNELL, "whole.prt", &[]);
    // A denoised bake's part among raw ones: its guides could not denoise the others.
    s.bake(
        CORNELL,
        "denoised.prt",
        &["--shard", "2/3", "--denoise", "on"],
    );
    let parts = [
        "p0.prt",
        "p1.prt",
        "p2.prt",
        "seed1.prt",
        "torus.prt",
        "of4.prt",
        "whole.prt",
        "denoised.prt",
    ];
    let cases: [(&[&str], &[&str]); 7] = [
        (&["out/p0.prt", "out/p2.prt"], &["shard 1 of 3 missing"]),
        (
            &["out/p0.prt", "out/p1.prt", "out/p1.prt", "out/p2.prt"],
            &["out/p1.prt and out/p1.prt: both are shard 1 of 3"],
        ),
        (
            &["out/p0.prt", "out/p1.prt", "out/seed1.prt"],
            &[
                "out/seed1.prt: a part of another bake than out/p0.prt",
                "seed 1 instead of 0",
            ],
        ),
        (
            &["out/p0.prt", "out/p1.prt", "out/torus.prt"],
            &[
                "out/torus.prt: a part of another bake",
                "scene fingerprint (another scene)",
            ],
        ),
        (
            &["out/p0.prt", "out/p1.prt", "out/of4.prt"],
            &["out/of4.prt: shard 2 of 4 of a bake split 4 ways"],
        ),
        (
            &["out/p0.prt", "out/p1.prt", "out/whole.prt"],
            &["out/whole.prt: a whole bake, not a shard part"],
        ),
        (
            &["out/p0.prt", "out/p1.prt", "out/denoised.prt"],
            &["out/denoised.prt: a part of another bake", "denoised true"],
        ),
    ];
    for (given, needles) in cases {
        let mut args = vec!["merge", "-o", "out/merged.prt"];
        args.extend(given);
        s.run(&args).fails_with_bad_input(needles);
        s.assert_out_holds(&parts);
    }
    // A corrupted or truncated part is refused by its checksum and size.
    let mut bytes = s.read("out/p1.prt");
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    s.write("out/corrupt.prt", &bytes);
    s.write("out/short.prt", &bytes[..last]);
    for (name, needle) in [("corrupt", "checksum mismatch"), ("short", "truncated")] {
        let path = format!("out/{name}.prt");
        s.run(&[
            "merge",
            "out/p0.prt",
            &path,
            "out/p2.prt",
            "-o",
            "out/merged.prt",
        ])
        .fails_with_bad_input(&[&format!("{path}: "), needle]);
    }
    let parts = [&parts[..], &["corrupt.prt", "short.prt"]].concat();
    s.assert_out_holds(&parts);
    // A part is not a bake: readers of whole files say what to do with it.
    s.run(&[
        "export",
        "out/p0.prt",
        "--scene",
        CORNELL,
        "--npz",
        "out/p0.npz",
    ])
    .fails_with_bad_input(&[
        "out/p0.prt: a shard part (shard 0 of 3, vertices 0..981)",
        "prt-bake merge",
    ]);
    // But inspect shows it, with its identity.
    let run = s.run(&["inspect", "out/p1.prt"]).success();
    for needle in [
        "\"shard\"",
        "\"first_vertex\": 981",
        "\"vertices\": 981",
        "\"count\": 3",
    ] {
        assert!(run.stdout.contains(needle), "{needle}: {}", run.stdout);
    }
}

/// Runs `prt-bake` in `s` with extra environment variables.
fn run_with_env(s: &Scratch, args: &[&str], env: &[(&str, &str)]) -> Run {
    let output = Command::new(env!("CARGO_BIN_EXE_prt-bake"))
        .args(args)
        .current_dir(s.path(""))
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .envs(env.iter().copied())
        .output()
        .expect("start prt-bake");
    Run {
        args: args.join(" "),
        code: output.status.code(),
        stdout: String::from_utf8(output.stdout).unwrap(),
        stderr: String::from_utf8(output.stderr).unwrap(),
    }
}

#[test]
fn shard_auto_reads_slurm_arrays_and_kubernetes_indexed_jobs() {
    let s = Scratch::new();
    s.bake(CORNELL, "explicit.prt", &["--shard", "2/4"]);
    let bake = ["bake", CORNELL, "--quiet", "--samples", "64", "-o"];
    let slurm = [
        ("SLURM_ARRAY_TASK_ID", "2"),
        ("SLURM_ARRAY_TASK_COUNT", "4"),
        ("SLURM_ARRAY_TASK_MIN", "0"),
    ];
    run_with_env(
        &s,
        &[&bake[..], &["out/slurm.prt", "--shard", "auto"]].concat(),
        &slurm,
    )
    .success();
    let kubernetes = [("JOB_COMPLETION_INDEX", "2")];
    run_with_env(
        &s,
        &[&bake[..], &["out/k8s.prt", "--shard", "auto/4"]].concat(),
        &kubernetes,
    )
    .success();
    let counted = [("JOB_COMPLETION_INDEX", "2"), ("PRT_SHARD_COUNT", "4")];
    run_with_env(
        &s,
        &[&bake[..], &["out/count.prt", "--shard", "auto"]].concat(),
        &counted,
    )
    .success();
    for name in ["slurm", "k8s", "count"] {
        assert!(
            s.read("out/explicit.prt") == s.read(&format!("out/{name}.prt")),
            "{name}"
        );
    }
    run_with_env(
        &s,
        &[&bake[..], &["out/no.prt", "--shard", "auto"]].concat(),
        &[],
    )
    .fails_with(
        EXIT_BAD_COMMAND_LINE,
        &["--shard auto: neither a Slurm array task"],
    );
    run_with_env(
        &s,
        &[&bake[..], &["out/no.prt", "--shard", "auto"]].concat(),
        &kubernetes,
    )
    .fails_with(
        EXIT_BAD_COMMAND_LINE,
        &["--shard auto/N or set PRT_SHARD_COUNT"],
    );
    run_with_env(
        &s,
        &[&bake[..], &["out/no.prt", "--shard", "4/4"]].concat(),
        &[],
    )
    .fails_with(
        EXIT_BAD_COMMAND_LINE,
        &["shard index 4 is not below the count 4"],
    );
    s.assert_out_holds(&["explicit.prt", "slurm.prt", "k8s.prt", "count.prt"]);
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
fn a_checkpointed_bake_killed_with_sigkill_resumes_to_the_same_file() {
    let s = Scratch::new();
    // 13,500 vertices in 54 blocks of 250, on one thread: seconds of work, so the kill
    // lands mid-bake.
    let args = [
        "bake",
        TORUS,
        "-o",
        "out/resumed.prt",
        "--quiet",
        "--samples",
        "512",
        "--threads",
        "1",
        "--mode",
        "interreflected",
        "--aux",
        "ao",
        // Denoised once the blocks are joined, as the uninterrupted bake is.
        "--denoise",
        "on",
        "--checkpoint",
        "out/checkpoint",
        "--checkpoint-vertices",
        "250",
    ];
    let total_blocks = 13_500usize.div_ceil(250);
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
    child.kill().expect("SIGKILL the bake"); // Child::kill is SIGKILL on Unix
    child.wait().unwrap();
    let kept = blocks_in(&checkpoint);
    assert!(
        (3..total_blocks).contains(&kept),
        "{kept} of {total_blocks} blocks after the kill"
    );
    assert!(
        !s.path("out/resumed.prt").exists(),
        "a killed bake left an output"
    );

    let run = s.run(&args).success();
    let resumed = format!("{total_blocks} blocks ({kept} resumed from out/checkpoint)");
    assert!(
        run.stdout.contains(&resumed),
        "expected {resumed:?} in {}",
        run.stdout
    );

    let uninterrupted: Vec<&str> = args[..args.len() - 4]
        .iter()
        .map(|a| {
            if *a == "out/resumed.prt" {
                "out/whole.prt"
            } else {
                a
            }
        })
        .collect();
    s.run(&uninterrupted).success();
    assert!(
        s.read("out/resumed.prt") == s.read("out/whole.prt"),
        "the resumed bake differs from the uninterrupted one"
    );
}

#[test]
fn a_checkpoint_of_other_options_or_another_scene_is_refused() {
    let s = Scratch::new();
    let base = ["--checkpoint", "out/ck", "--checkpoint-vertices", "500"];
    s.bake(CORNELL, "a.prt", &base);
    let cases: [(&str, &[&str], &[&str]); 4] = [
        (
            CORNELL,
            &["--samples", "32"],
            &[
                "a checkpoint of another bake",
                "samples_per_vertex 64 instead of 32",
            ],
        ),
        (
            TORUS,
            &[],
            &[
                "a checkpoint of another bake",
                "scene fingerprint (another scene)",
            ],
        ),
        (
            CORNELL,
            &["--shard", "1/2"],
            &["which is not a block of this bake"],
        ),
        (CORNELL, &["--seed", "3"], &["seed 0 instead of 3"]),
    ];
    for (scene, extra, needles) in cases {
        let mut args = vec!["bake", scene, "-o", "out/b.prt", "--quiet"];
        args.extend(base);
        args.extend(extra);
        if !extra.contains(&"--samples") {
            args.extend(["--samples", "64"]);
        }
        s.run(&args)
            .fails_with_bad_input(&[&["out/ck/block-0000"][..], needles].concat());
    }
    // --checkpoint-vertices without --checkpoint is a usage error (clap's).
    let run = s.run(&[
        "bake",
        CORNELL,
        "-o",
        "out/b.prt",
        "--checkpoint-vertices",
        "9",
    ]);
    assert_eq!(run.code, Some(EXIT_BAD_COMMAND_LINE), "{}", run.stderr);
    s.assert_out_holds(&["a.prt", "ck"]);
}
