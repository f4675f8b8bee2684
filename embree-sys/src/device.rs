//! `RTCDevice`: the Embree instance every scene belongs to.

use std::ffi::{CStr, CString, c_char, c_void};
use std::ptr;
use std::sync::{Arc, Mutex};

use crate::error::{Error, ErrorKind};
use crate::sys;

/// An Embree device. Cheap to clone (shared); released when the last clone and the last scene
/// built from it are dropped.
#[derive(Clone)]
pub struct Device {
    pub(crate) inner: Arc<DeviceInner>,
}

pub(crate) struct DeviceInner {
    pub(crate) handle: sys::RTCDevice,
    /// Where the error callback leaves its message. Boxed so its address is stable: Embree keeps
    /// a raw pointer to it until the callback is unset in `Drop`.
    last_message: Box<Mutex<Option<String>>>,
}

// SAFETY: Embree's API is thread-safe for calls on a device from several threads (its docs:
// "the API is thread safe, as long as the same object is not modified concurrently"); the only
// state this wrapper adds is the message slot, which is behind a mutex.
unsafe impl Send for DeviceInner {}
// SAFETY: see `Send` above; `&DeviceInner` only exposes the handle to Embree calls that Embree
// documents as thread-safe, and the mutex-protected slot.
unsafe impl Sync for DeviceInner {}

/// Called by Embree, possibly from its own worker threads, when an API call fails.
extern "C" fn record_error(user_ptr: *mut c_void, _code: sys::RTCError, message: *const c_char) {
    if user_ptr.is_null() || message.is_null() {
        return;
    }
    // SAFETY: `user_ptr` is the `Mutex` boxed in `DeviceInner`, registered in `Device::with_config`
    // and unregistered before that box is freed; `message` is a NUL-terminated string Embree owns
    // for the duration of this call.
    let (slot, text) = unsafe {
        (
            &*(user_ptr as *const Mutex<Option<String>>),
            CStr::from_ptr(message).to_string_lossy(),
        )
    };
    if let Ok(mut slot) = slot.lock() {
        *slot = Some(text.into_owned());
    }
}

impl Device {
    /// A device with Embree's default configuration.
    pub fn new() -> Result<Device, Error> {
        Device::with_config("")
    }

    /// A device from an Embree configuration string such as `"threads=2,verbose=1"`.
    pub fn with_config(config: &str) -> Result<Device, Error> {
        let config = CString::new(config).map_err(|_| {
            Error::new(
                ErrorKind::InvalidArgument,
                "device configuration contains a NUL byte",
            )
        })?;
        // SAFETY: `config` is a NUL-terminated string that outlives the call.
        let handle = unsafe { sys::rtcNewDevice(config.as_ptr()) };
        if handle.is_null() {
            // SAFETY: Embree documents `rtcGetDeviceError(NULL)` as the error of the last failed
            // device creation on this thread.
            let code = unsafe { sys::rtcGetDeviceError(ptr::null_mut()) };
            let kind = ErrorKind::from_code(code).unwrap_or(ErrorKind::Unknown);
            return Err(Error::new(kind, "rtcNewDevice failed"));
        }
        let inner = DeviceInner {
            handle,
            last_message: Box::new(Mutex::new(None)),
        };
        let slot = &*inner.last_message as *const Mutex<Option<String>> as *mut c_void;
        // SAFETY: `handle` is a live device; `slot` stays valid until `DeviceInner::drop`, which
        // unregisters the callback before the box is freed.
        unsafe { sys::rtcSetDeviceErrorFunction(handle, Some(record_error), slot) };
        Ok(Device {
            inner: Arc::new(inner),
        })
    }

    /// Turns Embree's pending error on this thread, if any, into an `Err`.
    pub(crate) fn check(&self) -> Result<(), Error> {
        // SAFETY: the handle is live for as long as `self`.
        let code = unsafe { sys::rtcGetDeviceError(self.inner.handle) };
        match ErrorKind::from_code(code) {
            None => Ok(()),
            Some(kind) => {
                let message = self
                    .inner
                    .last_message
                    .lock()
                    .ok()
                    .and_then(|mut slot| slot.take())
                    .unwrap_or_default();
                Err(Error::new(kind, message))
            }
        }
    }
}

impl Drop for DeviceInner {
    fn drop(&mut self) {
        // SAFETY: the handle is live; unsetting the callback first means Embree can no longer
        // reach `last_message`, which is freed right after.
        unsafe {
            sys::rtcSetDeviceErrorFunction(self.handle, None, ptr::null_mut());
            sys::rtcReleaseDevice(self.handle);
        }
    }
}

impl std::fmt::Debug for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Device")
            .field("embree_major", &crate::EMBREE_MAJOR)
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embree_errors_reach_check_with_the_callbacks_message() {
        let device = Device::new().unwrap();
        assert_eq!(device.check(), Ok(()));
        // SAFETY: a live device; Embree validates the geometry type and reports an error
        // instead of creating anything, so there is nothing to release.
        let geometry = unsafe { sys::rtcNewGeometry(device.inner.handle, 12345) };
        assert!(geometry.is_null());
        let err = device.check().unwrap_err();
        // Embree 3 files this under RTC_ERROR_UNKNOWN; the message is what names the problem.
        assert!(
            err.message.contains("geometry type"),
            "callback message missing: {err:?}"
        );
        assert_eq!(device.check(), Ok(()), "the error is reported once");
    }
}
