//! Resource limits, checked before anything is allocated.
//!
//! A header that declares 65535×65535 pixels, a coefficient file of 2³² vertices or an
//! absurd `--samples` would otherwise make the process ask for gigabytes, and be killed by
//! the system or take the machine down with it. Every such size is turned into the bytes it
//! needs and compared with one process-wide limit, [`max_memory`]: `--max-memory`, by default
//! three quarters of the physical memory (`/proc/meminfo`). What is refused is a
//! [`Error::TooLarge`] that says what was asked, what it needs and what the limit is.

use std::io::Read;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::support::error::{Error, Result};

/// The limit when the physical memory cannot be read (not Linux): 4 GiB.
const FALLBACK_MAX_MEMORY: u64 = 4 << 30;

/// 0 until set or first read.
static MAX_MEMORY: AtomicU64 = AtomicU64::new(0);

/// The physical memory in bytes (`MemTotal` of `/proc/meminfo`), if known.
pub fn physical_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The default limit: three quarters of the physical memory.
pub fn default_max_memory() -> u64 {
    physical_memory().map_or(FALLBACK_MAX_MEMORY, |m| m / 4 * 3)
}

/// The memory one command may use, in bytes.
pub fn max_memory() -> u64 {
    match MAX_MEMORY.load(Ordering::Relaxed) {
        0 => {
            let limit = default_max_memory();
            MAX_MEMORY.store(limit, Ordering::Relaxed);
            limit
        }
        limit => limit,
    }
}

/// Sets the limit for the rest of the process (`--max-memory`).
pub fn set_max_memory(bytes: u64) {
    MAX_MEMORY.store(bytes.max(1), Ordering::Relaxed);
}

/// `1.5 GiB`, `12.0 MiB`, `512 bytes`.
pub fn human(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["KiB", "MiB", "GiB", "TiB", "PiB"];
    if bytes < 1024 {
        return format!("{bytes} bytes");
    }
    let mut value = bytes as f64 / 1024.0;
    let mut unit = 0;
    while value >= 1024.0 && unit < UNITS.len() - 1 {
        value /= 1024.0;
        unit += 1;
    }
    format!("{value:.1} {}", UNITS[unit])
}

/// Refuses `needed` bytes (None: more than 2⁶⁴) over the limit; `what` names the input or
/// option, `asked` says what it asked for.
pub fn check(what: impl Into<String>, asked: &str, needed: Option<u64>) -> Result<()> {
    let limit = max_memory();
    match needed {
        Some(bytes) if bytes <= limit => Ok(()),
        _ => Err(Error::TooLarge {
            what: what.into(),
            message: format!(
                "{asked} needs {}, over the memory limit of {} (--max-memory; the default is 3/4 of the physical memory)",
                needed.map_or_else(|| "more than 2^64 bytes".into(), human),
                human(limit)
            ),
        }),
    }
}

/// The most read from an input that is not a regular file (a pipe, a device such as
/// `/dev/zero`), whose size cannot be known first.
pub const MAX_STREAM_INPUT: u64 = 256 << 20;

/// Reads a whole input file, refusing one larger than the memory limit before reading it;
/// a pipe or device is read up to [`MAX_STREAM_INPUT`] (or the limit, if lower).
pub fn read_file(path: &Path) -> Result<Vec<u8>> {
    let file = std::fs::File::open(path).map_err(|err| Error::io(path, err))?;
    let mut limit = max_memory();
    match file.metadata() {
        Ok(metadata) if metadata.is_file() => check(
            path.display().to_string(),
            "reading the file",
            Some(metadata.len()),
        )?,
        _ => limit = limit.min(MAX_STREAM_INPUT),
    }
    let mut bytes = Vec::new();
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|err| Error::io(path, err))?;
    if bytes.len() as u64 > limit {
        return Err(Error::TooLarge {
            what: path.display().to_string(),
            message: format!(
                "not a regular file, and longer than the {} read from one",
                human(limit)
            ),
        });
    }
    Ok(bytes)
}

/// Reads a file an input names (a glTF buffer or image, a material library, a texture, an
/// environment map): only a regular file, and never more than `bound` + 1 bytes of it, so a
/// file that grew after it was checked cannot make the read unbounded. `bound` is a declared
/// length (a glTF buffer's byteLength) or the memory limit; it is checked against the limit
/// first. The file is opened without blocking, so a FIFO put in its place cannot hang the
/// open; it is then refused as not a regular file.
pub fn read_regular(path: &Path, bound: u64) -> Result<Vec<u8>> {
    check(path.display().to_string(), "reading the file", Some(bound))?;
    let mut open = std::fs::OpenOptions::new();
    open.read(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::custom_flags(&mut open, libc::O_NONBLOCK);
    let file = open.open(path).map_err(|err| Error::io(path, err))?;
    let metadata = file.metadata().map_err(|err| Error::io(path, err))?;
    if !metadata.is_file() {
        return Err(Error::InputPath {
            location: crate::support::error::Location::file(path),
            message: format!("{}; only regular files are read", file_kind(&metadata)),
        });
    }
    check(
        path.display().to_string(),
        "reading the file",
        Some(metadata.len().min(bound)),
    )?;
    let mut bytes = Vec::with_capacity(metadata.len().min(bound) as usize);
    file.take(bound.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|err| Error::io(path, err))?;
    Ok(bytes)
}

/// Refuses an image whose header declares more pixels than fit, before it is decoded:
/// `bytes_per_pixel` is what decoding and keeping one pixel costs in all.
pub fn check_image(path: &Path, width: u32, height: u32, bytes_per_pixel: u64) -> Result<()> {
    let needed = (u64::from(width) * u64::from(height)).checked_mul(bytes_per_pixel);
    check(
        path.display().to_string(),
        &format!("decoding its declared {width}×{height} pixels"),
        needed,
    )
}

/// The `image` crate's own limits, as a second line behind [`check_image`]: no single
/// allocation above the memory limit, whatever the decoder finds further into the file.
pub fn image_limits() -> image::Limits {
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(max_memory());
    limits
}

/// What a file is, for a refusal: "a character device", "a FIFO", …
pub fn file_kind(metadata: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let kind = metadata.file_type();
        if kind.is_char_device() {
            return "a character device";
        } else if kind.is_block_device() {
            return "a block device";
        } else if kind.is_fifo() {
            return "a FIFO (named pipe)";
        } else if kind.is_socket() {
            return "a socket";
        }
    }
    if metadata.is_dir() {
        "a directory"
    } else if metadata.is_file() {
        "a regular file"
    } else {
        "not a regular file"
    }
}

/// Refuses an OpenEXR file whose layers would make the `exr` crate allocate more than
/// `--max-memory` before `image`'s own limits apply: it sizes a block's buffer by the size
/// the header allows (a mutated tile or line size asks for gigabytes from a 500-byte file),
/// and its offset tables by the header's chunk count. Other files, and headers `exr` cannot
/// read (decoding reports those), pass.
pub fn check_exr(path: &Path, bytes: &[u8]) -> Result<()> {
    const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
    if !bytes.starts_with(&EXR_MAGIC) {
        return Ok(());
    }
    let Ok(meta) = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
    else {
        return Ok(());
    };
    for (i, header) in meta.headers.iter().enumerate() {
        let block = header.max_block_byte_size() as u64;
        let offsets = (header.chunk_count as u64).saturating_mul(8);
        check(
            path.display().to_string(),
            &format!("decoding OpenEXR layer {i}"),
            block.checked_add(offsets),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_endless_device_is_not_read_to_the_end() {
        if Path::new("/dev/zero").exists() {
            let err = read_file(Path::new("/dev/zero")).unwrap_err();
            assert!(err.to_string().contains("not a regular file"), "{err}");
        }
    }

    #[test]
    fn a_referenced_file_is_read_one_byte_past_its_bound_at_most() {
        let dir = std::env::temp_dir().join(format!("prt-read-regular-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("ten.bin");
        std::fs::write(&file, [7u8; 10]).unwrap();
        assert_eq!(read_regular(&file, 4).unwrap().len(), 5);
        assert_eq!(read_regular(&file, 64).unwrap().len(), 10);
        // Devices and directories are refused, not read.
        let err = read_regular(Path::new("/dev/zero"), 4).unwrap_err();
        assert!(err.to_string().contains("a character device"), "{err}");
        let err = read_regular(&dir, 4).unwrap_err();
        assert!(err.to_string().contains("a directory"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn human_sizes() {
        assert_eq!(human(512), "512 bytes");
        assert_eq!(human(3 << 20), "3.0 MiB");
        assert_eq!(human(65535 * 65535 * 16), "64.0 GiB");
    }

    #[test]
    fn physical_memory_is_read_on_linux() {
        if cfg!(target_os = "linux") {
            let m = physical_memory().expect("/proc/meminfo has MemTotal");
            assert!(m > 64 << 20, "{m}");
            assert_eq!(default_max_memory(), m / 4 * 3);
        }
    }

    #[test]
    fn a_huge_image_is_refused_with_its_size_and_the_limit() {
        if max_memory() < 65535 * 65535 * 16 {
            let err = check_image(Path::new("big.tga"), 65535, 65535, 16).unwrap_err();
            let text = err.to_string();
            let expected = "big.tga: decoding its declared 65535×65535 pixels needs 64.0 GiB, \
                            over the memory limit of";
            assert!(text.contains(expected), "{text}");
        }
        assert!(check_image(Path::new("small.tga"), 64, 64, 16).is_ok());
    }
}
