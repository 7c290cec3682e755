//! Buffers whose length comes from the user or the input (pixels, rays,
//! records of a file), reserved fallibly: a length that does not fit in
//! memory is an error saying what did not fit, not an abort.

use std::cell::Cell;
use std::fmt;

thread_local! {
    /// Set while this thread reserves fallibly (see [`reserving_fallibly`]).
    static FALLIBLE: Cell<bool> = const { Cell::new(false) };
}

/// Whether this thread is inside one of this module's reservations, whose
/// failure is an [`OutOfMemory`] error. The `kdray` binary's allocator
/// ends the process on any other failed allocation, and asks this first.
#[must_use]
pub fn reserving_fallibly() -> bool {
    FALLIBLE.try_with(Cell::get).unwrap_or(false)
}

/// `count` items of `what` (`bytes` in all) could not be allocated.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutOfMemory {
    /// What did not fit ("camera rays").
    pub what: String,
    /// How many of them.
    pub count: usize,
    /// Their bytes (`None` when the count times the size overflows).
    pub bytes: Option<usize>,
}

impl fmt::Display for OutOfMemory {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "out of memory: {} {} ", self.count, self.what)?;
        match self.bytes {
            Some(b) => write!(f, "({:.2} GB)", b as f64 / 1e9)?,
            None => write!(f, "(more bytes than the address space holds)")?,
        }
        write!(f, " do not fit in the memory this process may use")
    }
}

impl std::error::Error for OutOfMemory {}

/// An empty vector with room for `count` items of `T`.
///
/// # Errors
/// [`OutOfMemory`] naming `what` when the room cannot be allocated.
pub fn with_capacity<T>(count: usize, what: &str) -> Result<Vec<T>, OutOfMemory> {
    let mut v = Vec::new();
    FALLIBLE.set(true);
    let reserved = v.try_reserve_exact(count);
    FALLIBLE.set(false);
    reserved.map_err(|_| OutOfMemory {
        what: what.to_string(),
        count,
        bytes: count.checked_mul(std::mem::size_of::<T>()),
    })?;
    Ok(v)
}

/// `count` copies of `value`.
///
/// # Errors
/// As [`with_capacity`].
pub fn filled<T: Clone>(count: usize, value: T, what: &str) -> Result<Vec<T>, OutOfMemory> {
    let mut v = with_capacity(count, what)?;
    v.resize(count, value);
    Ok(v)
}

/// `items` collected into a vector reserved for `count` of them (the
/// iterator's length).
///
/// # Errors
/// As [`with_capacity`].
pub fn collected<T>(
    count: usize,
    items: impl Iterator<Item = T>,
    what: &str,
) -> Result<Vec<T>, OutOfMemory> {
    let mut v = with_capacity(count, what)?;
    v.extend(items);
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_length_past_memory_is_an_error_naming_it() {
        let e = with_capacity::<[u8; 32]>(usize::MAX / 64, "camera rays").unwrap_err();
        assert!(e.to_string().contains("camera rays"), "{e}");
        assert_eq!(e.count, usize::MAX / 64);
        let e = filled(usize::MAX / 2, 0u64, "hits").unwrap_err();
        assert_eq!(e.bytes, None);
        assert_eq!(filled(3, 7u8, "x").unwrap(), [7, 7, 7]);
        assert_eq!(collected(2, 0..2u8, "x").unwrap(), [0, 1]);
    }
}
