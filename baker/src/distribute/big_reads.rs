//! Reading the staged pipeline's large files (a texel shard's part is 0.8 GB at 2048²)
//! without faulting in fresh memory for them: every 4 KB page of a fresh buffer costs a page
//! fault as `read` fills it (a gather's 1.5 GB part took 375,000 of them, most of its system
//! time). Files read once are mapped ([`map`]); buffers are advised as transparent huge pages.

use std::io::Read;
use std::ops::Deref;
use std::path::Path;

use crate::support::error::{Error, Result};

/// Bytes of a huge page (x86-64, aarch64 with 4 KB pages).
const HUGE_PAGE: usize = 2 << 20;

/// The bytes of the file at `path`, in memory advised as huge pages.
pub fn read(path: &Path) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    read_into(path, &mut bytes)?;
    Ok(bytes)
}

/// Reads the file at `path` into `buffer` (cleared first; its memory kept for the next file).
pub fn read_into(path: &Path, buffer: &mut Vec<u8>) -> Result<()> {
    let fail = |err| Error::io(path, err);
    let mut file = std::fs::File::open(path).map_err(fail)?;
    let len = file.metadata().map_err(fail)?.len() as usize;
    buffer.clear();
    if buffer.capacity() < len {
        // A fresh allocation (not yet touched): advise it before `read` faults it in. One
        // byte more, so that `read_to_end` finds the end without growing the buffer.
        *buffer = Vec::with_capacity(len + 1);
        advise_huge_pages(buffer);
    }
    file.read_to_end(buffer).map_err(fail)?;
    Ok(())
}

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

/// Asks the kernel to back `buffer`'s whole huge pages with huge pages (only advice: a kernel
/// without THP, or with THP off, ignores it).
fn advise_huge_pages(buffer: &mut Vec<u8>) {
    let start = buffer.as_mut_ptr() as usize;
    let first = start.next_multiple_of(HUGE_PAGE);
    let end = (start + buffer.capacity()) & !(HUGE_PAGE - 1);
    if end > first {
        // SAFETY: the range lies within `buffer`'s allocation, and MADV_HUGEPAGE changes
        // how its pages are backed, never their contents.
        #[cfg(target_os = "linux")]
        unsafe {
            libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_read_whole_into_a_reused_buffer() {
        let dir = std::env::temp_dir().join(format!("prt-big-reads-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (large, small) = (dir.join("large.bin"), dir.join("small.bin"));
        let bytes: Vec<u8> = (0..5 * HUGE_PAGE + 7).map(|i| (i % 251) as u8).collect();
        std::fs::write(&large, &bytes).unwrap();
        std::fs::write(&small, b"seven b").unwrap();
        assert!(read(&large).unwrap() == bytes);
        let mut buffer = Vec::new();
        read_into(&large, &mut buffer).unwrap();
        assert!(buffer == bytes);
        read_into(&small, &mut buffer).unwrap();
        assert_eq!(buffer, b"seven b");
        assert!(read(&dir.join("missing")).is_err());
        assert!(*map(&large).unwrap() == bytes[..]);
        assert_eq!(&*map(&small).unwrap(), b"seven b");
        std::fs::write(&small, b"").unwrap();
        assert!(map(&small).unwrap().is_empty());
        assert!(map(&dir).is_err() && map(&dir.join("missing")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
