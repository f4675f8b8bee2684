//! Which files an input may name, and how they are read.
//!
//! The paths inside a scene, OBJ, MTL, glTF or light rig are not the user's word: the file may
//! come from anywhere. `"uri": "../../../../etc/passwd"` would bake a file the user never
//! meant to hand over into an output they may share, and `/dev/zero` or a FIFO would hang the
//! baker. So every path an input names (glTF buffer and image uris, OBJ `mtllib`, MTL
//! `map_Kd`, scene-file entries, rig environment maps) goes through [`AssetFolder::admit`]:
//!
//! * it must be relative and resolve (symbolic links followed, `..` applied) inside the folder
//!   of the file given on the command line, unless `--allow-outside-uris`
//!   ([`set_allow_outside`]) is given;
//! * it must be a regular file: devices, FIFOs, sockets and directories are refused, with or
//!   without the option;
//! * it is then read with a bound ([`crate::support::limits::read_regular`]).
//!
//! The file named on the command line itself is the user's choice and is not confined.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use crate::support::error::{Error, Location, Result};
use crate::support::limits::file_kind;

/// The option that lets inputs name files outside their folder.
pub const ALLOW_OPTION: &str = "--allow-outside-uris";

static ALLOW_OUTSIDE: AtomicBool = AtomicBool::new(false);

/// Lets inputs name files anywhere (`--allow-outside-uris`), for the rest of the process.
pub fn set_allow_outside(allow: bool) {
    ALLOW_OUTSIDE.store(allow, Ordering::Relaxed);
}

/// Whether `--allow-outside-uris` was given.
pub fn allow_outside() -> bool {
    ALLOW_OUTSIDE.load(Ordering::Relaxed)
}

/// The folder an asset's references must stay in: that of the file the user named, with
/// symbolic links resolved.
#[derive(Clone, Debug)]
pub struct AssetFolder {
    canonical: PathBuf,
}

impl AssetFolder {
    /// The folder of `asset`. If it cannot be resolved (it does not exist), reading the
    /// asset fails first; the folder is then kept as written.
    pub fn of(asset: &Path) -> AssetFolder {
        let parent = match asset.parent() {
            Some(parent) if !parent.as_os_str().is_empty() => parent,
            _ => Path::new("."),
        };
        AssetFolder {
            canonical: parent
                .canonicalize()
                .unwrap_or_else(|_| parent.to_path_buf()),
        }
    }

    /// Checks the file that an input names and returns its path: `written` is the reference
    /// as the input spells it (for the message), `reference` what it decodes to (a glTF uri is
    /// percent-decoded), relative to `base_dir` (the folder of the file that names it); `what`
    /// says what names it (`buffer 0's uri`) and `at` where. A file that does not exist is let
    /// through, for the read to report it as it always has.
    pub fn admit(
        &self,
        at: &Location,
        what: &str,
        written: &str,
        reference: &Path,
        base_dir: &Path,
    ) -> Result<PathBuf> {
        let refuse = |message: String| Error::InputPath {
            location: at.clone(),
            message: format!("{what} {written:?} {message}"),
        };
        let allowed = allow_outside();
        if !allowed && reference.has_root() {
            return Err(refuse(format!(
                "is an absolute path, and inputs may only name files inside their own folder ({}); {ALLOW_OPTION} allows it",
                self.canonical.display()
            )));
        }
        let path = base_dir.join(reference);
        let Ok(resolved) = path.canonicalize() else {
            return Ok(path);
        };
        if !allowed && !resolved.starts_with(&self.canonical) {
            return Err(refuse(format!(
                "resolves to {}, outside the asset's folder {}; {ALLOW_OPTION} allows it",
                resolved.display(),
                self.canonical.display()
            )));
        }
        match std::fs::metadata(&resolved) {
            Ok(metadata) if !metadata.is_file() => Err(refuse(format!(
                "names {}, {}; only regular files are read",
                resolved.display(),
                file_kind(&metadata)
            ))),
            _ => Ok(path),
        }
    }
}

/// Reads a file an input names, already admitted: a regular file no larger than the memory
/// limit.
pub fn read(path: &Path) -> Result<Vec<u8>> {
    let limit = crate::support::limits::max_memory();
    let bytes = crate::support::limits::read_regular(path, limit)?;
    within_limit(path, bytes, limit)
}

/// Refuses what [`crate::support::limits::read_regular`] read past `limit` (the file grew after it
/// was checked).
pub fn within_limit(path: &Path, bytes: Vec<u8>, limit: u64) -> Result<Vec<u8>> {
    if bytes.len() as u64 > limit {
        return Err(Error::TooLarge {
            what: path.display().to_string(),
            message: format!(
                "grew past the memory limit of {} while it was read",
                crate::support::limits::human(limit)
            ),
        });
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_that_grew_past_the_limit_while_read_is_refused() {
        let err = within_limit(Path::new("big.png"), vec![0; 5], 4).unwrap_err();
        assert!(
            err.to_string()
                .starts_with("big.png: grew past the memory limit of 4 bytes"),
            "{err}"
        );
        assert_eq!(
            within_limit(Path::new("ok.png"), vec![0; 4], 4)
                .unwrap()
                .len(),
            4
        );
    }

    #[test]
    fn kinds_of_special_files_are_named() {
        let dev = std::fs::metadata("/dev/null").unwrap();
        assert_eq!(file_kind(&dev), "a character device");
        let dir = std::fs::metadata("/").unwrap();
        assert_eq!(file_kind(&dir), "a directory");
    }
}
