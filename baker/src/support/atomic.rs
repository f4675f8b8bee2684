//! Writing output files so that a reader never sees half of one.

use std::path::Path;

use crate::support::error::Result;
use crate::support::output::Output;

/// Writes `bytes` to `path` under the output policy ([`crate::support::output`]): a regular file is
/// written to a temporary file beside it, flushed to disk and renamed over it (on any failure
/// the temporary file is removed and `path` is left as it was); a directory or block device is
/// refused; a character device or FIFO is written through. Commands that read input files
/// use [`Output::new`] with them, so an output can never replace one of its inputs.
pub fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    Output::new(path, &[])?.write(bytes)
}
