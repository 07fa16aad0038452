//! The one libc call the Linux buses need, declared directly (the C library is linked into
//! every Rust program on Linux already).

use std::ffi::{c_int, c_ulong};
use std::os::fd::AsRawFd;

unsafe extern "C" {
    fn ioctl(fd: c_int, request: c_ulong, ...) -> c_int;
}

/// `ioctl(fd, request, arg)` where `arg` is an integer or a pointer passed as one (pointer
/// sized, so right on 32-bit Raspberry Pi OS as on 64-bit); the last OS error on failure.
///
/// # Safety
/// When `request` takes a pointer, `arg` must point to memory of the size and layout the
/// request expects, valid (and writable if the kernel writes it) for the call.
pub(crate) unsafe fn ioctl_arg(file: &impl AsRawFd, request: c_ulong, arg: usize) -> std::io::Result<()> {
    // SAFETY: upheld by the caller as documented above; the fd is open for `file`'s lifetime.
    let rc = unsafe { ioctl(file.as_raw_fd(), request, arg) };
    if rc < 0 { Err(std::io::Error::last_os_error()) } else { Ok(()) }
}
