//! NumPy `.npz` output: a zip archive (stored, uncompressed) of `.npy` arrays, readable with
//! `numpy.load`. Only little-endian float32 arrays are needed here.

use std::io::{Cursor, Write};
use std::path::Path;

use crate::error::{Error, Result};

/// A named float32 array of the given shape (C order).
pub struct Array<'a> {
    pub name: &'a str,
    pub shape: Vec<usize>,
    pub data: &'a [f32],
}

/// The `.npy` (format 1.0) encoding of one array.
pub fn npy_bytes(shape: &[usize], data: &[f32]) -> Vec<u8> {
    assert_eq!(
        shape.iter().product::<usize>(),
        data.len(),
        "shape does not match data"
    );
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape = match dims.len() {
        1 => format!("({},)", dims[0]),
        _ => format!("({})", dims.join(", ")),
    };
    let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {shape}, }}");
    // Magic (6) + version (2) + length (2) + header + '\n' is padded to a multiple of 64.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    header.push('\n');
    let mut bytes = Vec::with_capacity(10 + header.len() + data.len() * 4);
    bytes.extend(b"\x93NUMPY\x01\x00");
    bytes.extend((header.len() as u16).to_le_bytes());
    bytes.extend(header.as_bytes());
    bytes.extend(data.iter().flat_map(|x| x.to_le_bytes()));
    bytes
}

/// Writes the arrays into `path` atomically.
pub fn write(path: &Path, arrays: &[Array<'_>]) -> Result<()> {
    crate::atomic::write(
        path,
        &to_bytes(arrays).map_err(|err| match err {
            Error::Io { source, .. } => Error::io(path, source),
            other => other,
        })?,
    )
}

/// The `.npz` file's bytes.
pub fn to_bytes(arrays: &[Array<'_>]) -> Result<Vec<u8>> {
    let path = Path::new("npz archive");
    let mut zip = zip::ZipWriter::new(Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Stored)
        .large_file(true);
    let zip_error = |err: zip::result::ZipError| Error::io(path, std::io::Error::other(err));
    for array in arrays {
        zip.start_file(format!("{}.npy", array.name), options)
            .map_err(zip_error)?;
        zip.write_all(&npy_bytes(&array.shape, array.data))
            .map_err(|err| Error::io(path, err))?;
    }
    Ok(zip.finish().map_err(zip_error)?.into_inner())
}
