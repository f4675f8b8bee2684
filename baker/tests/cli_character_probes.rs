//! `prt-bake relight CHARACTER.glb FILE.ldprt --pose P --probes PROBES.prt`: the walking
//! character (scenes/cornell/walker.glb, y-up) lit through probes of a z-up scene
//! (docs/guides/characters.md, "A character walking through the room").
//!
//! * Under probes that see nothing (a speck of a scene 50 units below the grid: every matrix
//!   is the identity up to the 4,096 rays' quadrature, so the incident radiance is the rig) it must light
//!   as `relight` with the rig alone lights it: the probes' light is turned from the room's
//!   z-up to the character's y-up frame as the rig is.
//! * The position it is lit at is the centre of its posed bounds in the probes' frame: at
//!   walk@0 and walk@2 (the same phase of the stride) 0.7 apart along +x, at y = -0.82.
//! * Refusals: --turn, two --at, probes of another order.

mod common;

use common::{EXIT_BAD_COMMAND_LINE, Scratch};

const WALKER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cornell/walker.glb");
const RIG: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../viewer/src/default-rig.toml"
);

/// The position `relight` reports it lit the character at.
fn lit_at(stdout: &str) -> [f64; 3] {
    let inside = stdout
        .split(" at (")
        .nth(1)
        .unwrap()
        .split(')')
        .next()
        .unwrap();
    let v: Vec<f64> = inside.split(", ").map(|x| x.parse().unwrap()).collect();
    [v[0], v[1], v[2]]
}

#[test]
fn a_character_is_lit_through_the_probes_at_its_posed_position() {
    let s = Scratch::new();
    s.write(
        "speck.obj",
        "v 0 0 -50\nv 0.01 0 -50\nv 0 0.01 -50\nf 1 2 3\n",
    );
    let order = ["--order", "4"];
    s.bake(
        "speck.obj",
        "open.prt",
        &[
            &order[..],
            &["--probes", "grid:2,2,2:-1,-1,0,1,1,2", "--samples", "4096"],
        ]
        .concat(),
    );
    s.bake(
        WALKER,
        "walker.ldprt",
        &[
            &order[..],
            &["--transfer", "ldprt", "--lobes", "3", "--samples", "32"],
        ]
        .concat(),
    );
    let relight = |pose: &str, probes: Option<&str>, out: &str| {
        let mut args = vec![
            "relight",
            WALKER,
            "out/walker.ldprt",
            "--pose",
            pose,
            "--lights",
            RIG,
            "-o",
            out,
        ];
        if let Some(p) = probes {
            args.extend(["--probes", p]);
        }
        s.run(&args).success()
    };
    let through = relight("walk@1.5", Some("out/open.prt"), "out/probes.ply");
    relight("walk@1.5", None, "out/rig.ply");
    let (a, b) = (
        s.ply_radiance("out/probes.ply"),
        s.ply_radiance("out/rig.ply"),
    );
    let largest = b.iter().flatten().fold(0.0f32, |m, x| m.max(x.abs()));
    let worst = a
        .iter()
        .zip(&b)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .fold(0.0f32, f32::max);
    eprintln!(
        "open probes against the rig alone: largest difference {worst:.2e} (radiance up to {largest:.3})"
    );
    assert!(largest > 0.1, "the rig lights the character");
    assert!(
        worst < 2e-3 * largest,
        "open probes differ from the rig: {worst}"
    );

    let start = lit_at(&relight("walk@0", Some("out/open.prt"), "out/0.ply").stdout);
    let later = lit_at(&relight("walk@2", Some("out/open.prt"), "out/2.ply").stdout);
    let mid = lit_at(&through.stdout);
    eprintln!("lit at {start:?}, {mid:?}, {later:?}");
    assert!(
        (later[0] - start[0] - 0.7).abs() < 2e-3,
        "{start:?} {later:?}"
    );
    for p in [start, mid, later] {
        assert!(
            (p[1] + 0.82).abs() < 2e-3 && p[2] > 0.3 && p[2] < 0.5,
            "{p:?}"
        );
    }
    assert!(start[0] < mid[0] && mid[0] < later[0]);

    let refused = |extra: &[&str]| {
        let mut args = vec![
            "relight",
            WALKER,
            "out/walker.ldprt",
            "--lights",
            RIG,
            "--probes",
            "out/open.prt",
            "-o",
            "out/x.ply",
        ];
        args.extend(extra);
        s.run(&args)
    };
    refused(&["--turn", "0,0,1,30"]).fails_with(EXIT_BAD_COMMAND_LINE, &["no --turn"]);
    refused(&["--at", "0,0,1", "--at", "1,0,1"])
        .fails_with(EXIT_BAD_COMMAND_LINE, &["at most one --at"]);
    s.bake(
        "speck.obj",
        "open3.prt",
        &["--order", "3", "--probes", "grid:1,1,1", "--samples", "16"],
    );
    let mut args = vec![
        "relight",
        WALKER,
        "out/walker.ldprt",
        "--lights",
        RIG,
        "--probes",
        "out/open3.prt",
        "-o",
        "out/x.ply",
    ];
    args.extend(["--pose", "walk@1"]);
    s.run(&args)
        .fails_with(EXIT_BAD_COMMAND_LINE, &["probes of order 3"]);
    assert!(!s.path("out/x.ply").exists());
}
