//! Reading the staged pipeline's large files (a texel shard's part is 0.8 GB at 2048²)
//! without faulting in fresh memory for them: every 4 KB page of a fresh buffer costs a page
//! fault as `read` fills it (a gather's 1.5 GB part took 375,000 of them, most of its system
//! time), so they are mapped ([`map`]). Advising fresh buffers as transparent huge pages cut
//! the faults too but not the system time (the kernel compacts memory for them).

use std::path::Path;

use crate::support::error::{Error, Result};

/// A file's bytes mapped read-only (populated up front), by `memmap2`. The pipeline replaces
/// a file by renaming a new one over it, which leaves a mapping of the old one intact; only
/// truncating a file in place while it is mapped would fault (SIGBUS).
pub type Mapped = memmap2::Mmap;

/// The bytes of the file at `path`, mapped: the page cache's own pages, neither copied nor
/// zeroed first.
pub fn map(path: &Path) -> Result<Mapped> {
    let fail = |err| Error::io(path, err);
    let file = std::fs::File::open(path).map_err(fail)?;
    if !file.metadata().map_err(fail)?.is_file() {
        return Err(Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file"),
        ));
    }
    // SAFETY: a read-only mapping of a regular file that the pipeline never truncates or
    // writes in place (its outputs are renamed over old files, see [`Mapped`]).
    unsafe { memmap2::MmapOptions::new().populate().map(&file) }.map_err(fail)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_map_whole() {
        let dir = std::env::temp_dir().join(format!("prt-big-reads-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (large, small) = (dir.join("large.bin"), dir.join("small.bin"));
        let bytes: Vec<u8> = (0..(10 << 20) + 7).map(|i| (i % 251) as u8).collect();
        std::fs::write(&large, &bytes).unwrap();
        std::fs::write(&small, b"seven b").unwrap();
        assert!(*map(&large).unwrap() == bytes[..]);
        assert_eq!(&*map(&small).unwrap(), b"seven b");
        std::fs::write(&small, b"").unwrap();
        assert!(map(&small).unwrap().is_empty());
        assert!(map(&dir).is_err() && map(&dir.join("missing")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
