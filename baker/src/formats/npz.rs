//! NumPy `.npz` output: a zip archive (stored, uncompressed) of `.npy` arrays, readable with
//! `numpy.load`. Little-endian float32 arrays, and uint32 ones for indices.

use std::io::{Cursor, Write};
use std::path::Path;

use crate::support::error::{Error, Result};

/// A named float32 array of the given shape (C order).
pub struct Array<'a> {
    pub name: &'a str,
    pub shape: Vec<usize>,
    pub data: &'a [f32],
}

/// A named uint32 array of the given shape (C order).
pub struct IndexArray<'a> {
    pub name: &'a str,
    pub shape: Vec<usize>,
    pub data: &'a [u32],
}

/// A named boolean array (NumPy `|b1`, one byte per element).
pub struct BoolArray<'a> {
    pub name: &'a str,
    pub shape: Vec<usize>,
    pub data: &'a [bool],
}

/// The `.npy` (format 1.0) encoding of one array.
pub fn npy_bytes(shape: &[usize], data: &[f32]) -> Vec<u8> {
    assert_eq!(
        shape.iter().product::<usize>(),
        data.len(),
        "shape does not match data"
    );
    let payload: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
    npy_encode("<f4", shape, &payload)
}

/// The `.npy` (format 1.0) encoding of one uint32 array.
pub fn npy_bytes_u32(shape: &[usize], data: &[u32]) -> Vec<u8> {
    assert_eq!(
        shape.iter().product::<usize>(),
        data.len(),
        "shape does not match data"
    );
    let payload: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
    npy_encode("<u4", shape, &payload)
}

/// The `.npy` encoding of a boolean array.
pub fn npy_bool_bytes(shape: &[usize], data: &[bool]) -> Vec<u8> {
    assert_eq!(shape.iter().product::<usize>(), data.len());
    let payload: Vec<u8> = data.iter().map(|&b| u8::from(b)).collect();
    npy_encode("|b1", shape, &payload)
}

fn npy_encode(descr: &str, shape: &[usize], data: &[u8]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape = match dims.len() {
        1 => format!("({},)", dims[0]),
        _ => format!("({})", dims.join(", ")),
    };
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    // Magic (6) + version (2) + length (2) + header + '\n' is padded to a multiple of 64.
    let unpadded = 10 + header.len() + 1;
    header.push_str(&" ".repeat(unpadded.next_multiple_of(64) - unpadded));
    header.push('\n');
    let mut bytes = Vec::with_capacity(10 + header.len() + data.len());
    bytes.extend(b"\x93NUMPY\x01\x00");
    bytes.extend((header.len() as u16).to_le_bytes());
    bytes.extend(header.as_bytes());
    bytes.extend(data);
    bytes
}

/// Writes the arrays into `path` atomically.
pub fn write(path: &Path, arrays: &[Array<'_>]) -> Result<()> {
    crate::support::atomic::write(
        path,
        &to_bytes(arrays, &[], &[]).map_err(|err| match err {
            Error::Io { source, .. } => Error::io(path, source),
            other => other,
        })?,
    )
}

/// The `.npz` file's bytes: the float arrays, then the index arrays, then the boolean masks.
pub fn to_bytes(
    arrays: &[Array<'_>],
    index_arrays: &[IndexArray<'_>],
    masks: &[BoolArray<'_>],
) -> Result<Vec<u8>> {
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
    for array in index_arrays {
        zip.start_file(format!("{}.npy", array.name), options)
            .map_err(zip_error)?;
        zip.write_all(&npy_bytes_u32(&array.shape, array.data))
            .map_err(|err| Error::io(path, err))?;
    }
    for mask in masks {
        zip.start_file(format!("{}.npy", mask.name), options)
            .map_err(zip_error)?;
        zip.write_all(&npy_bool_bytes(&mask.shape, mask.data))
            .map_err(|err| Error::io(path, err))?;
    }
    Ok(zip.finish().map_err(zip_error)?.into_inner())
}
