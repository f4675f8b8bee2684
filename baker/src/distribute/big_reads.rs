//! Reading the staged pipeline's large files (a texel shard's part is 0.8 GB at 2048²)
//! without faulting in fresh memory for them: every 4 KB page of a fresh buffer costs a page
//! fault as `read` fills it (a gather's 1.5 GB part took 375,000 of them, most of its system
//! time), so they are mapped ([`map`]). Advising fresh buffers as transparent huge pages cut
//! the faults too but not the system time (the kernel compacts memory for them).

use std::ops::Deref;
use std::path::Path;

use crate::support::error::{Error, Result};

/// A file's bytes mapped read-only (private, populated up front). The pipeline replaces a
/// file by renaming a new one over it, which leaves a mapping of the old one intact; only
/// truncating a file in place while it is mapped would fault (SIGBUS).
pub struct Mapped {
    ptr: *const u8,
    len: usize,
}

// SAFETY: the mapping is read-only and owned by this value alone.
unsafe impl Send for Mapped {}
unsafe impl Sync for Mapped {}

impl Deref for Mapped {
    type Target = [u8];

    fn deref(&self) -> &[u8] {
        match self.len {
            0 => &[],
            // SAFETY: `ptr` maps `len` readable bytes until `drop`.
            len => unsafe { std::slice::from_raw_parts(self.ptr, len) },
        }
    }
}

impl Drop for Mapped {
    fn drop(&mut self) {
        if self.len > 0 {
            // SAFETY: `ptr` and `len` are the mapping `map` made, unmapped once.
            unsafe {
                libc::munmap(self.ptr as *mut libc::c_void, self.len);
            }
        }
    }
}

/// The bytes of the file at `path`, mapped: the page cache's own pages, neither copied nor
/// zeroed first.
pub fn map(path: &Path) -> Result<Mapped> {
    use std::os::fd::AsRawFd;
    let fail = |err| Error::io(path, err);
    let file = std::fs::File::open(path).map_err(fail)?;
    let metadata = file.metadata().map_err(fail)?;
    if !metadata.is_file() {
        return Err(Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file"),
        ));
    }
    let len = metadata.len() as usize;
    if len == 0 {
        return Ok(Mapped {
            ptr: std::ptr::null(),
            len,
        });
    }
    // SAFETY: a fresh read-only private mapping of an open regular file; checked below.
    let ptr = unsafe {
        libc::mmap(
            std::ptr::null_mut(),
            len,
            libc::PROT_READ,
            libc::MAP_PRIVATE | libc::MAP_POPULATE,
            file.as_raw_fd(),
            0,
        )
    };
    if ptr == libc::MAP_FAILED {
        return Err(fail(std::io::Error::last_os_error()));
    }
    Ok(Mapped {
        ptr: ptr as *const u8,
        len,
    })
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
