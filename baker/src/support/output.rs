//! The one output policy of every command: nothing the user owns is ever destroyed.
//!
//! [`Output::new`] checks a path before the work starts, and [`Output::write`] checks it again
//! and writes:
//!
//! * a path that is, or resolves through links (or hard links) to, an input of the run is
//!   refused: a bake must not replace its own OBJ;
//! * a directory, a block device, a socket or a link to nothing is refused;
//! * a regular file (new or existing) is written atomically: a temporary file beside it,
//!   flushed to disk, renamed over it. A link is followed, so the link stays and its target
//!   is replaced. The temporary file is removed on every error, on a panic (a drop guard) and on
//!   SIGINT, SIGTERM or SIGHUP ([`interrupt`]);
//! * a character device or a FIFO (`/dev/null`, a named pipe, `/dev/stdout`) is written
//!   through, never renamed over; `-` means standard output where the command allows it
//!   ([`Output::new_or_stdout`]). A short write (`/dev/full`: no space left) is an error, never
//!   a success.

use std::fs::{self, File, Metadata, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::support::error::{Error, Result};

/// Where a command's bytes go, checked against the policy above.
#[derive(Clone, Debug)]
pub struct Output {
    path: PathBuf,
    inputs: Vec<PathBuf>,
    allow_stdout: bool,
}

/// What a path names when it is written.
#[derive(Debug)]
enum Target {
    Stdout,
    /// A character device or FIFO, written through.
    Stream(PathBuf),
    /// A regular file: `path` has its links resolved; `existing` is its metadata if it exists.
    File {
        path: PathBuf,
        existing: Option<Metadata>,
    },
}

impl Output {
    /// An output at `path` that must not be any of `inputs`. `-` is refused (a command that
    /// prints to standard output cannot also write its file there); name `./-` for a file
    /// called `-`. Checks now, so a long bake fails before it starts; [`Output::write`] checks
    /// again.
    pub fn new(path: &Path, inputs: &[PathBuf]) -> Result<Output> {
        let output = Output {
            path: path.to_path_buf(),
            inputs: inputs.to_vec(),
            allow_stdout: false,
        };
        output.target()?;
        Ok(output)
    }

    /// As [`Output::new`], but `-` means standard output.
    pub fn new_or_stdout(path: &Path, inputs: &[PathBuf]) -> Result<Output> {
        let output = Output {
            path: path.to_path_buf(),
            inputs: inputs.to_vec(),
            allow_stdout: true,
        };
        output.target()?;
        Ok(output)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes all of `bytes` or reports why not; a regular file appears only complete.
    pub fn write(&self, bytes: &[u8]) -> Result<()> {
        self.write_parts(&[bytes])
    }

    /// [`Output::write`] of the bytes of `parts`, one after the other (a file's arrays need
    /// not be copied into one buffer first).
    pub fn write_parts(&self, parts: &[&[u8]]) -> Result<()> {
        match self.target()? {
            Target::Stdout => {
                let mut out = io::stdout().lock();
                write_all(&mut out, parts)
                    .and_then(|()| out.flush())
                    .map_err(|err| Error::io(Path::new("standard output"), err))
            }
            Target::Stream(path) => write_through(&path, parts),
            Target::File { path, existing } => {
                write_atomically(&path, existing.as_ref(), parts).map_err(|err| match err {
                    // Name the path the user gave, not the resolved one.
                    Error::Io { source, .. } => Error::io(&self.path, source),
                    other => other,
                })
            }
        }
    }

    fn refuse(&self, message: impl Into<String>) -> Error {
        Error::Output {
            path: self.path.clone(),
            message: message.into(),
        }
    }

    /// Applies the policy to the path as it is now.
    fn target(&self) -> Result<Target> {
        if self.path.as_os_str() == "-" {
            return match self.allow_stdout {
                true => Ok(Target::Stdout),
                false => Err(self.refuse(
                    "this command cannot write to standard output; name a file (./- for a file called -)",
                )),
            };
        }
        let metadata = match fs::metadata(&self.path) {
            Ok(metadata) => metadata,
            Err(err) if err.kind() == io::ErrorKind::NotFound => {
                if let Ok(link) = fs::read_link(&self.path) {
                    return Err(self.refuse(format!(
                        "is a link to {}, which does not exist",
                        link.display()
                    )));
                }
                check_folder(&self.path)?;
                return Ok(Target::File {
                    path: self.path.clone(),
                    existing: None,
                });
            }
            Err(err) => return Err(Error::io(&self.path, err)),
        };
        if let Some(input) = self.inputs.iter().find(|input| same_file(input, &metadata)) {
            return Err(self.refuse(match input == &self.path {
                true => "is an input of this command; choose another output".to_string(),
                false => format!(
                    "is the same file as the input {}; choose another output",
                    input.display()
                ),
            }));
        }
        let kind = metadata.file_type();
        if kind.is_file() {
            let path = fs::canonicalize(&self.path).map_err(|err| Error::io(&self.path, err))?;
            return Ok(Target::File {
                path,
                existing: Some(metadata),
            });
        }
        if kind.is_dir() {
            return Err(self.refuse("is a directory; name a file inside it"));
        }
        if is_stream(&metadata) {
            return Ok(Target::Stream(self.path.clone()));
        }
        Err(self.refuse(
            "is a block device or socket, not a file; refusing to write (it could destroy a disk)",
        ))
    }
}

/// Character devices and FIFOs: written through, in order, like a terminal.
#[cfg(unix)]
fn is_stream(metadata: &Metadata) -> bool {
    use std::os::unix::fs::FileTypeExt;
    let kind = metadata.file_type();
    kind.is_char_device() || kind.is_fifo()
}

#[cfg(not(unix))]
fn is_stream(_: &Metadata) -> bool {
    false
}

/// Whether `input` is the file `metadata` describes (same device and inode: links, hard
/// links and `..` detours included).
#[cfg(unix)]
fn same_file(input: &Path, metadata: &Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    fs::metadata(input).is_ok_and(|m| m.dev() == metadata.dev() && m.ino() == metadata.ino())
}

#[cfg(not(unix))]
fn same_file(input: &Path, _: &Metadata) -> bool {
    false
}

/// The folder a new file goes into must exist (reported as a missing file: exit code 3).
fn check_folder(path: &Path) -> Result<()> {
    let folder = folder_of(path);
    if !folder.is_dir() {
        return Err(Error::io(
            path,
            io::Error::new(
                io::ErrorKind::NotFound,
                format!("folder {} does not exist", folder.display()),
            ),
        ));
    }
    Ok(())
}

fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Writes each of `parts` whole, in order.
fn write_all(out: &mut impl Write, parts: &[&[u8]]) -> io::Result<()> {
    parts.iter().try_for_each(|part| out.write_all(part))
}

fn write_through(path: &Path, parts: &[&[u8]]) -> Result<()> {
    let fail = |err| Error::io(path, err);
    let mut file = OpenOptions::new().write(true).open(path).map_err(fail)?;
    let metadata = file.metadata().map_err(fail)?;
    if !is_stream(&metadata) {
        return Err(Error::Output {
            path: path.to_path_buf(),
            message: "changed from a device or FIFO into something else while being written".into(),
        });
    }
    write_all(&mut file, parts)
        .and_then(|()| file.flush())
        .map_err(fail)
}

/// Temporary file, fsync, rename over `path`; the [`TempFile`] guard removes the temporary
/// file on every way out but success.
fn write_atomically(path: &Path, existing: Option<&Metadata>, parts: &[&[u8]]) -> Result<()> {
    let fail = |err| Error::io(path, err);
    let mut temp = TempFile::create(path).map_err(fail)?;
    if let Some(existing) = existing {
        // Replacing a file keeps its permissions.
        let _ = temp.file.set_permissions(existing.permissions());
    }
    write_all(&mut temp.file, parts).map_err(fail)?;
    test_fault::mid_write();
    temp.file.sync_all().map_err(fail)?;
    // Last look before the rename: only a regular file (or nothing) may be replaced.
    match fs::symlink_metadata(path) {
        Ok(m) if !m.file_type().is_file() => {
            return Err(Error::Output {
                path: path.to_path_buf(),
                message: "is no longer a regular file; not replacing it".into(),
            });
        }
        _ => {}
    }
    fs::rename(&temp.path, path).map_err(fail)?;
    temp.committed = true;
    // The rename itself reaches the disk when the folder is synced (best effort: some file
    // systems refuse to sync a folder).
    if let Ok(folder) = File::open(folder_of(path)) {
        let _ = folder.sync_all();
    }
    Ok(())
}

/// A temporary file beside its destination: `.NAME.tmp-PID-N`, hidden, unique per process
/// and write, created exclusively (a planted link there is not followed).
struct TempFile {
    path: PathBuf,
    file: File,
    committed: bool,
}

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

impl TempFile {
    fn create(destination: &Path) -> io::Result<TempFile> {
        interrupt::install();
        let name = destination
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        loop {
            let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
            let path =
                destination.with_file_name(format!(".{name}.tmp-{}-{n}", std::process::id()));
            interrupt::register(&path);
            match OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(file) => {
                    return Ok(TempFile {
                        path,
                        file,
                        committed: false,
                    });
                }
                Err(err) => {
                    interrupt::unregister(&path);
                    if err.kind() != io::ErrorKind::AlreadyExists {
                        return Err(err);
                    }
                }
            }
        }
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_file(&self.path);
        }
        interrupt::unregister(&self.path);
    }
}

/// Removal of temporary files when the process is interrupted (SIGINT, SIGTERM, SIGHUP).
///
/// The handler may only make async-signal-safe calls, so the paths live in a fixed table of
/// C strings that it walks, unlinking each; then it restores the default action and raises
/// the signal again, so the process ends exactly as it would have (shells see the signal).
/// It is installed at the first temporary file, and only over the default action: a program
/// with its own handler keeps it.
#[cfg(unix)]
pub mod interrupt {
    use std::ffi::CString;
    use std::os::unix::ffi::OsStrExt;
    use std::path::Path;
    use std::ptr::null_mut;
    use std::sync::Once;
    use std::sync::atomic::{AtomicPtr, Ordering};

    const SLOTS: usize = 64;
    const SIGNALS: [libc::c_int; 3] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP];
    static PATHS: [AtomicPtr<libc::c_char>; SLOTS] = [const { AtomicPtr::new(null_mut()) }; SLOTS];

    /// Installs the handler for the signals whose action is still the default.
    pub fn install() {
        static ONCE: Once = Once::new();
        ONCE.call_once(|| {
            for signal in SIGNALS {
                // SAFETY: sigaction with a zeroed struct reads the current action; the new one
                // points at an extern "C" function that only makes async-signal-safe calls.
                unsafe {
                    let mut old: libc::sigaction = std::mem::zeroed();
                    if libc::sigaction(signal, std::ptr::null(), &mut old) != 0
                        || old.sa_sigaction != libc::SIG_DFL
                    {
                        continue;
                    }
                    let mut action: libc::sigaction = std::mem::zeroed();
                    action.sa_sigaction = on_signal as extern "C" fn(libc::c_int) as usize;
                    libc::sigemptyset(&mut action.sa_mask);
                    libc::sigaction(signal, &action, std::ptr::null_mut());
                }
            }
        });
    }

    /// Adds a path to the table (a full table only loses the cleanup of the extra paths).
    pub fn register(path: &Path) {
        let Ok(c) = CString::new(path.as_os_str().as_bytes()) else {
            return;
        };
        let raw = c.into_raw();
        for slot in &PATHS {
            if slot
                .compare_exchange(null_mut(), raw, Ordering::SeqCst, Ordering::SeqCst)
                .is_ok()
            {
                return;
            }
        }
        // SAFETY: `raw` came from `into_raw` above and was stored nowhere.
        drop(unsafe { CString::from_raw(raw) });
    }

    /// Takes a path out of the table. The string is leaked, not freed: a handler running on
    /// another thread may still be reading it (a few bytes per write).
    pub fn unregister(path: &Path) {
        let bytes = path.as_os_str().as_bytes();
        for slot in &PATHS {
            let p = slot.load(Ordering::SeqCst);
            // SAFETY: non-null entries are NUL-terminated strings from `register`, never freed.
            if !p.is_null() && unsafe { std::ffi::CStr::from_ptr(p) }.to_bytes() == bytes {
                let _ = slot.compare_exchange(p, null_mut(), Ordering::SeqCst, Ordering::SeqCst);
                return;
            }
        }
    }

    extern "C" fn on_signal(signal: libc::c_int) {
        for slot in &PATHS {
            let p = slot.load(Ordering::SeqCst);
            if !p.is_null() {
                // SAFETY: unlink, signal and raise are async-signal-safe; p is a valid C string.
                unsafe {
                    libc::unlink(p);
                }
            }
        }
        // SAFETY: as above.
        unsafe {
            libc::signal(signal, libc::SIG_DFL);
            libc::raise(signal);
        }
    }
}

#[cfg(not(unix))]
pub mod interrupt {
    use std::path::Path;
    pub fn install() {}
    pub fn register(_: &Path) {}
    pub fn unregister(_: &Path) {}
}

/// Faults injected by the tests through the environment variable `PRT_TEST_FAULT`, to prove
/// that a panic or a signal in the middle of a write leaves no partial output. Test-only: one
/// environment lookup per file written.
mod test_fault {
    pub fn mid_write() {
        match std::env::var("PRT_TEST_FAULT").as_deref() {
            Ok("panic-mid-write") => panic!("PRT_TEST_FAULT=panic-mid-write"),
            Ok("pause-mid-write") => {
                eprintln!("prt: paused mid-write (PRT_TEST_FAULT)");
                std::thread::sleep(std::time::Duration::from_secs(60));
            }
            _ => {}
        }
    }
}

/// Makes a panic (a bug) end with one clear line, `PROGRAM: error: internal error (a bug at
/// FILE:LINE: MESSAGE); no output was written`, instead of Rust's backtrace hint. The binaries
/// install it and catch the unwind to exit with code 1; an output's temporary file is removed
/// as the panic unwinds (the drop guard above).
pub fn install_panic_hook(program: &'static str) {
    std::panic::set_hook(Box::new(move |info| {
        let location = info
            .location()
            .map_or(String::new(), |l| format!(" at {}:{}", l.file(), l.line()));
        let message = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_default();
        eprintln!(
            "{program}: error: internal error (a bug{location}: {message}); no output was written"
        );
    }));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder() -> tempfile::TempDir {
        tempfile::tempdir().unwrap()
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn writes_a_new_file_and_replaces_an_old_one_keeping_its_mode() {
        let dir = folder();
        let path = dir.path().join("a.bin");
        Output::new(&path, &[]).unwrap().write(b"one").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"one");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            fs::set_permissions(&path, fs::Permissions::from_mode(0o640)).unwrap();
            Output::new(&path, &[]).unwrap().write(b"two").unwrap();
            let mode = fs::metadata(&path).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o640);
        }
        assert_eq!(fs::read(&path).unwrap(), b"two");
        assert_eq!(names(dir.path()), ["a.bin"]);
    }

    #[test]
    fn refuses_inputs_also_through_links() {
        let dir = folder();
        let input = dir.path().join("scene.obj");
        fs::write(&input, b"v 0 0 0").unwrap();
        let err = Output::new(&input, std::slice::from_ref(&input)).unwrap_err();
        assert!(err.to_string().contains("is an input"), "{err}");
        #[cfg(unix)]
        {
            let link = dir.path().join("link.prt");
            std::os::unix::fs::symlink(&input, &link).unwrap();
            let err = Output::new(&link, std::slice::from_ref(&input)).unwrap_err();
            assert!(err.to_string().contains("scene.obj"), "{err}");
            let hard = dir.path().join("hard.prt");
            fs::hard_link(&input, &hard).unwrap();
            assert!(Output::new(&hard, std::slice::from_ref(&input)).is_err());
            let detour = dir.path().join("..").join(dir.path().file_name().unwrap());
            assert!(Output::new(&detour.join("scene.obj"), std::slice::from_ref(&input)).is_err());
        }
        assert_eq!(fs::read(&input).unwrap(), b"v 0 0 0");
    }

    #[test]
    fn a_link_stays_and_its_target_is_replaced() {
        let dir = folder();
        let target = dir.path().join("real.json");
        fs::write(&target, b"old").unwrap();
        #[cfg(unix)]
        {
            let link = dir.path().join("link.json");
            std::os::unix::fs::symlink("real.json", &link).unwrap();
            Output::new(&link, &[]).unwrap().write(b"new").unwrap();
            assert!(
                fs::symlink_metadata(&link)
                    .unwrap()
                    .file_type()
                    .is_symlink()
            );
            assert_eq!(fs::read(&target).unwrap(), b"new");
            let dangling = dir.path().join("dangling.json");
            std::os::unix::fs::symlink("nothere/x.json", &dangling).unwrap();
            let err = Output::new(&dangling, &[]).unwrap_err();
            assert!(err.to_string().contains("does not exist"), "{err}");
        }
    }

    #[test]
    fn refuses_directories_and_standard_output_where_not_allowed() {
        let dir = folder();
        let err = Output::new(dir.path(), &[]).unwrap_err();
        assert!(err.to_string().contains("is a directory"), "{err}");
        assert!(dir.path().is_dir());
        let err = Output::new(Path::new("-"), &[]).unwrap_err();
        assert!(err.to_string().contains("standard output"), "{err}");
        assert!(Output::new_or_stdout(Path::new("-"), &[]).is_ok());
    }

    #[test]
    fn missing_folder_is_a_missing_file() {
        let err = Output::new(Path::new("nothere/x.prt"), &[]).unwrap_err();
        assert!(err.is_bad_input());
        assert!(err.to_string().contains("folder nothere does not exist"));
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn devices_are_written_through_and_a_full_one_fails() {
        use std::os::unix::fs::FileTypeExt;
        Output::new(Path::new("/dev/null"), &[])
            .unwrap()
            .write(b"nothing")
            .unwrap();
        let err = Output::new(Path::new("/dev/full"), &[])
            .unwrap()
            .write(&[0; 4096])
            .unwrap_err();
        assert!(err.to_string().contains("/dev/full"), "{err}");
        for device in ["/dev/null", "/dev/full"] {
            let kind = fs::symlink_metadata(device).unwrap().file_type();
            assert!(kind.is_char_device(), "{device} is no longer a device");
        }
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_fifo_is_written_through() {
        let dir = folder();
        let fifo = dir.path().join("pipe");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid C string.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || fs::read(fifo).unwrap())
        };
        Output::new(&fifo, &[]).unwrap().write(b"through").unwrap();
        assert_eq!(reader.join().unwrap(), b"through");
        assert_eq!(names(dir.path()), ["pipe"]);
    }
}
