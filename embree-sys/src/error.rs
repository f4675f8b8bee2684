//! Embree's error codes as a typed Rust error.

use crate::sys;

/// What kind of failure Embree (or this wrapper, before calling Embree) reported.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ErrorKind {
    Unknown,
    InvalidArgument,
    InvalidOperation,
    OutOfMemory,
    UnsupportedCpu,
    Cancelled,
}

impl ErrorKind {
    pub(crate) fn from_code(code: sys::RTCError) -> Option<ErrorKind> {
        Some(match code {
            sys::RTC_ERROR_NONE => return None,
            sys::RTC_ERROR_INVALID_ARGUMENT => ErrorKind::InvalidArgument,
            sys::RTC_ERROR_INVALID_OPERATION => ErrorKind::InvalidOperation,
            sys::RTC_ERROR_OUT_OF_MEMORY => ErrorKind::OutOfMemory,
            sys::RTC_ERROR_UNSUPPORTED_CPU => ErrorKind::UnsupportedCpu,
            sys::RTC_ERROR_CANCELLED => ErrorKind::Cancelled,
            _ => ErrorKind::Unknown,
        })
    }

    fn as_str(self) -> &'static str {
        match self {
            ErrorKind::Unknown => "unknown error",
            ErrorKind::InvalidArgument => "invalid argument",
            ErrorKind::InvalidOperation => "invalid operation",
            ErrorKind::OutOfMemory => "out of memory",
            ErrorKind::UnsupportedCpu => "unsupported cpu",
            ErrorKind::Cancelled => "cancelled",
        }
    }
}

/// An error from Embree, with the message its error callback gave where there was one.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("embree: {}{}", kind.as_str(), if message.is_empty() { String::new() } else { format!(": {message}") })]
pub struct Error {
    pub kind: ErrorKind,
    pub message: String,
}

impl Error {
    pub(crate) fn new(kind: ErrorKind, message: impl Into<String>) -> Error {
        Error {
            kind,
            message: message.into(),
        }
    }
}
