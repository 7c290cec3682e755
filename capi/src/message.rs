//! The open functions' message: `BlobError`'s sentence (or the status
//! text), truncated to the caller's buffer and always NUL-terminated.

use core::ffi::c_char;
use core::fmt::{self, Write};

/// A `fmt::Write` into a caller's buffer that keeps one byte for the NUL
/// and drops what does not fit (truncation is not an error).
struct Message<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl Write for Message<'_> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let room = self.buf.len().saturating_sub(1).saturating_sub(self.len);
        let take = s.len().min(room);
        if let (Some(dst), Some(src)) = (
            self.buf.get_mut(self.len..self.len + take),
            s.as_bytes().get(..take),
        ) {
            dst.copy_from_slice(src);
            self.len += take;
        }
        Ok(())
    }
}

/// Writes `text` into `out[..cap]`, NUL-terminated and truncated to fit;
/// nothing if `out` is null or `cap` is 0. A message cut inside a UTF-8
/// sequence keeps the partial bytes (the messages are ASCII).
///
/// # Safety
/// If `out` is non-null, it points to `cap` writable bytes.
pub(crate) unsafe fn write_message(out: *mut c_char, cap: usize, text: impl fmt::Display) {
    if out.is_null() || cap == 0 || cap > isize::MAX as usize {
        return;
    }
    // SAFETY: non-null, `cap` writable bytes by the contract, `cap` fits a
    // slice; c_char and u8 have the same layout and any bits are valid.
    let buf = unsafe { core::slice::from_raw_parts_mut(out.cast::<u8>(), cap) };
    let mut m = Message { buf, len: 0 };
    // Message::write_str never fails.
    let _ = write!(m, "{text}");
    let end = m.len;
    if let Some(nul) = m.buf.get_mut(end) {
        *nul = 0;
    }
}
