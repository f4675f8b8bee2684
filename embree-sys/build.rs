//! Generates the raw bindings from the Embree headers installed on this machine.
//!
//! Where the headers are, in order of precedence:
//! 1. `EMBREE_INCLUDE_DIR`: a folder holding `rtcore.h`, or holding `embree4/` or `embree3/`;
//! 2. `EMBREE_DIR`: an install prefix with `include/embree{4,3}/` and `lib/`;
//! 3. `/usr/include/embree4`, then `/usr/include/embree3` (Debian's `libembree-dev`).
//!
//! The major version is read from `rtcore_config.h` (not guessed from the folder name), linked
//! as `embree4` or `embree3`, and exposed to the safe layer as `cfg(embree_v4)` / `cfg(embree_v3)`.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};

fn main() {
    println!("cargo::rerun-if-env-changed=EMBREE_INCLUDE_DIR");
    println!("cargo::rerun-if-env-changed=EMBREE_DIR");
    println!("cargo::rustc-check-cfg=cfg(embree_v3)");
    println!("cargo::rustc-check-cfg=cfg(embree_v4)");

    let (include_dir, lib_dir) = match locate() {
        Ok(found) => found,
        Err(message) => {
            eprintln!("embree-sys: {message}");
            panic!("{message}");
        }
    };
    let major = read_major_version(&include_dir).unwrap_or_else(|message| panic!("{message}"));
    let header = include_dir.join("rtcore.h");
    println!("cargo::rerun-if-changed={}", header.display());
    println!(
        "cargo::rerun-if-changed={}",
        include_dir.join("rtcore_config.h").display()
    );

    match major {
        3 => println!("cargo::rustc-cfg=embree_v3"),
        4 => println!("cargo::rustc-cfg=embree_v4"),
        other => panic!(
            "embree-sys: {} declares Embree {other}; only Embree 3 and 4 are supported",
            include_dir.join("rtcore_config.h").display()
        ),
    }
    // Lets dependents (through `DEP_EMBREE_MAJOR`) and diagnostics know what was found.
    println!("cargo::metadata=major={major}");
    println!("cargo::metadata=include={}", include_dir.display());
    if let Some(lib_dir) = lib_dir {
        println!("cargo::rustc-link-search=native={}", lib_dir.display());
    }
    println!("cargo::rustc-link-lib=dylib=embree{major}");

    let bindings = bindgen::Builder::default()
        .header(header.to_string_lossy())
        .clang_arg(format!("-I{}", include_dir.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        // C enums become plain integer constants: a value Embree adds later can never be UB.
        .prepend_enum_name(false)
        .derive_default(true)
        .layout_tests(true)
        .generate_comments(false)
        .generate()
        .unwrap_or_else(|err| {
            panic!(
                "embree-sys: bindgen failed on {} ({err}); is libclang-dev installed?",
                header.display()
            )
        });
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    bindings
        .write_to_file(out.join("bindings.rs"))
        .expect("embree-sys: cannot write bindings.rs into OUT_DIR");
}

/// Finds the folder holding `rtcore.h`, and a library folder when a prefix names one.
fn locate() -> Result<(PathBuf, Option<PathBuf>), String> {
    if let Some(dir) = env::var_os("EMBREE_INCLUDE_DIR") {
        let dir = PathBuf::from(dir);
        return header_dir_in(&dir).map(|d| (d, None)).ok_or_else(|| {
            format!(
                "EMBREE_INCLUDE_DIR={} holds neither rtcore.h nor embree4/rtcore.h nor embree3/rtcore.h",
                dir.display()
            )
        });
    }
    if let Some(prefix) = env::var_os("EMBREE_DIR") {
        let prefix = PathBuf::from(prefix);
        let include = header_dir_in(&prefix.join("include")).ok_or_else(|| {
            format!(
                "EMBREE_DIR={} has no include/embree4/rtcore.h or include/embree3/rtcore.h",
                prefix.display()
            )
        })?;
        let lib = ["lib", "lib64"]
            .iter()
            .map(|l| prefix.join(l))
            .find(|l| l.is_dir());
        return Ok((include, lib));
    }
    header_dir_in(Path::new("/usr/include"))
        .map(|d| (d, None))
        .ok_or_else(|| {
            "no Embree headers found in /usr/include/embree4 or /usr/include/embree3: \
         install them (`apt-get install libembree-dev`) or set EMBREE_INCLUDE_DIR / EMBREE_DIR"
                .to_string()
        })
}

fn header_dir_in(dir: &Path) -> Option<PathBuf> {
    [dir.to_path_buf(), dir.join("embree4"), dir.join("embree3")]
        .into_iter()
        .find(|d| d.join("rtcore.h").is_file())
}

fn read_major_version(include_dir: &Path) -> Result<u32, String> {
    let config = include_dir.join("rtcore_config.h");
    let text = fs::read_to_string(&config)
        .map_err(|err| format!("embree-sys: cannot read {}: {err}", config.display()))?;
    text.lines()
        .filter_map(|line| line.trim().strip_prefix("#define RTC_VERSION_MAJOR"))
        .find_map(|rest| rest.trim().parse().ok())
        .ok_or_else(|| format!("embree-sys: {} has no RTC_VERSION_MAJOR", config.display()))
}
