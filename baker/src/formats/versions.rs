//! Reading a coefficient file of any version: version 1 by [`crate::formats::coefficient_file`]
//! itself, version 2 (CPCA-compressed) as the version-1 file it reconstructs
//! ([`crate::formats::cpca_block`]). Kept apart so that neither of the two imports the other.

use std::path::Path;

use crate::formats::coefficient_file::CoefficientFile;
use crate::formats::cpca_block;
use crate::support::error::{Error, Result};

impl CoefficientFile {
    /// Reads and validates the file at `path`, whatever its version.
    pub fn read(path: &Path) -> Result<CoefficientFile> {
        let bytes = crate::support::limits::read_file(path)?;
        CoefficientFile::from_bytes(&bytes)
            .map_err(|message| Error::coefficient_file(path, message))
    }

    /// Parses and validates a file's bytes, whatever its version; the error is a sentence
    /// for the user.
    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<CoefficientFile, String> {
        if cpca_block::is_compressed(bytes) {
            return cpca_block::from_bytes(bytes).map(|c| c.file);
        }
        CoefficientFile::from_version1_bytes(bytes)
    }
}
