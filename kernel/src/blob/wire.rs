//! The blob's wire format: a 64-byte header, then sections of Pod records.
//!
//! ```text
//! offset  size  field
//!      0     8  magic "kdray\0\0\0"
//!      8     4  endianness check 0xFEFF (the blob is little-endian)
//!     12     4  format version (3 for every kind)
//!     16     4  kind: 1 triangle tree, 3 point tree (2: an older 3-D point layout)
//!     20     4  max depth of any node (root = 0)
//!     24     4  node count
//!     28     4  primitive-index count
//!     32     4  item count (triangles or points)
//!     36     4  checksum of the whole blob, this field read as zero
//!     40    24  scene bounds: min x y z, max x y z (f32)
//!     64        sections, each 4-byte aligned and sized by the counts above:
//!               nodes (8 B each), primitive indices (4 B each),
//!               triangles (36 B each); a point tree's sections are
//!               listed in `points::blob`.
//! ```
//!
//! Everything is 4-byte aligned, so a blob in 4-byte aligned memory is read
//! in place: [`Header`] and each section are cast from the bytes, never
//! copied. The checksum is CRC-32C over the whole blob with the checksum
//! field read as zero, so it covers the header's counts and bounds too:
//! any 1 to 3 flipped bits are caught, and it is fast enough to verify on
//! every load (the `crc32` instruction where the processor has it).

use super::crc32c::Crc32c;
use super::error::{BlobError, WriteError};
use super::MAX_DEPTH;
use crate::geometry::Bounds;
use bytemuck::{Pod, Zeroable};

/// The first 8 bytes of every blob.
pub const MAGIC: [u8; 8] = *b"kdray\0\0\0";
/// The endianness check word.
pub const ENDIAN_CHECK: u32 = 0xFEFF;
/// The format version of every blob kind this kernel writes and reads
/// (the CRC-32C checksum; triangle trees in cache-line treelets,
/// `validate`'s module docs). Older versions, all sealed by a word-wise
/// FNV-1a checksum, are refused with [`BlobError::OldVersion`]: 2
/// (triangle trees and scenes) and 1 (point trees, and triangle trees in
/// depth-first order).
pub const VERSION: u32 = 3;
/// The kind of a triangle tree blob.
pub const KIND_TRIANGLES: u32 = 1;
/// The kind of a point tree blob (`points::blob` has its layout; kind 2
/// was an older, 3-D-only one).
pub const KIND_POINTS: u32 = 3;
/// The header's size in bytes.
pub const HEADER_LEN: usize = 64;
/// Where the checksum field sits in the header.
pub const CHECKSUM_OFFSET: usize = 36;

/// The blob header. `repr(C)`, Pod, 64 bytes (layout in the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct Header {
    /// [`MAGIC`].
    pub magic: [u8; 8],
    /// [`ENDIAN_CHECK`].
    pub endian: u32,
    /// [`VERSION`].
    pub version: u32,
    /// [`KIND_TRIANGLES`] or [`KIND_POINTS`].
    pub kind: u32,
    /// The depth of the deepest node (the root has depth 0).
    pub max_depth: u32,
    /// Number of nodes.
    pub node_count: u32,
    /// Number of primitive indices.
    pub index_count: u32,
    /// Number of triangles or points.
    pub item_count: u32,
    /// [`blob_checksum`] of the whole blob.
    pub checksum: u32,
    /// Scene bounds: min x, y, z.
    pub bounds_min: [f32; 3],
    /// Scene bounds: max x, y, z.
    pub bounds_max: [f32; 3],
}

const _: () = assert!(core::mem::size_of::<Header>() == HEADER_LEN);

impl Header {
    /// Checks the header's max depth against the depth the validator
    /// measured (checked loading).
    pub(crate) fn expect_depth(&self, measured: u32) -> Result<(), BlobError> {
        if self.max_depth == measured {
            Ok(())
        } else {
            Err(BlobError::BadHeaderField {
                what: "max_depth",
                found: self.max_depth,
            })
        }
    }

    /// Checks that the header's max depth fits the traversal stack
    /// (unchecked loading, O(1)).
    pub(crate) fn depth_fits_stack(&self) -> Result<(), BlobError> {
        if self.max_depth > MAX_DEPTH {
            return Err(BlobError::TooDeep {
                node: 0,
                depth: self.max_depth,
                max: MAX_DEPTH,
            });
        }
        Ok(())
    }
}

/// CRC-32C (Castagnoli, `blob/crc32c.rs`) of a whole blob, the four bytes at
/// [`CHECKSUM_OFFSET`] read as zero: every error of up to 3 flipped bits
/// anywhere in the blob, header included, changes it.
#[must_use]
pub fn blob_checksum(bytes: &[u8]) -> u32 {
    let (head, rest) = bytes
        .split_at_checked(CHECKSUM_OFFSET)
        .unwrap_or((bytes, &[]));
    let field = rest.len().min(4);
    let (_, tail) = rest.split_at_checked(field).unwrap_or((rest, &[]));
    let zeros = [0u8; 4];
    Crc32c::new()
        .update(head)
        .update(zeros.get(..field).unwrap_or(&[]))
        .update(tail)
        .finish()
}

/// Writes a blob: the header (its counts and checksum filled in), then the
/// `sections` in order, each a run of records as bytes. `counts` are the
/// node, primitive-index and item counts the header records; every
/// section's byte length is a multiple of 4, as the reader requires.
/// Returns the bytes written: the start of `out`.
///
/// # Errors
/// [`WriteError::TooMany`] for a count above `u32::MAX`,
/// [`WriteError::BufferTooSmall`] when `out` is shorter than the blob.
pub(crate) fn write_blob(
    out: &mut [u8],
    kind: u32,
    max_depth: u32,
    bounds: Bounds,
    counts: [(&'static str, usize); 3],
    sections: &[&[u8]],
) -> Result<usize, WriteError> {
    let [nodes, indices, items] = counts
        .map(|(what, count)| u32::try_from(count).map_err(|_| WriteError::TooMany { what, count }));
    let header = Header {
        magic: MAGIC,
        endian: ENDIAN_CHECK,
        version: VERSION,
        kind,
        max_depth,
        node_count: nodes?,
        index_count: indices?,
        item_count: items?,
        checksum: 0,
        bounds_min: bounds.min,
        bounds_max: bounds.max,
    };
    let need = blob_len(sections)?;
    let have = out.len();
    let Some(blob) = out.get_mut(..need) else {
        return Err(WriteError::BufferTooSmall { need, have });
    };
    // `need` is the header plus every section, so each split below fits;
    // the checked forms turn an impossible miss into an error, not a panic.
    let (head, mut rest) = blob
        .split_at_mut_checked(HEADER_LEN)
        .ok_or(WriteError::TooLarge)?;
    head.copy_from_slice(bytemuck::bytes_of(&header));
    for s in sections {
        let (dst, tail) = rest
            .split_at_mut_checked(s.len())
            .ok_or(WriteError::TooLarge)?;
        dst.copy_from_slice(s);
        rest = tail;
    }
    let sum = blob_checksum(blob);
    if let Some(field) = blob.get_mut(CHECKSUM_OFFSET..CHECKSUM_OFFSET + 4) {
        field.copy_from_slice(&sum.to_le_bytes());
    }
    Ok(need)
}

/// The size in bytes of a blob with these sections: the header and each
/// section's bytes.
///
/// # Errors
/// [`WriteError::TooLarge`] when the sum overflows.
pub(crate) fn blob_len(sections: &[&[u8]]) -> Result<usize, WriteError> {
    sections
        .iter()
        .try_fold(HEADER_LEN, |n, s| n.checked_add(s.len()))
        .ok_or(WriteError::TooLarge)
}

/// Reads the sections after the header in order, each as a slice of Pod
/// records cast in place; every read names its section for the error.
pub(crate) struct Sections<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Sections<'a> {
    /// Checks length, alignment, magic, endianness, kind and version;
    /// returns the header and a reader positioned after it. O(1).
    pub(crate) fn open(bytes: &'a [u8], kind: u32) -> Result<(&'a Header, Self), BlobError> {
        // Length before alignment: an empty slice's address is a dangling
        // 1, and "truncated, has 0 bytes" is what went wrong.
        let Some(head) = bytes.get(..HEADER_LEN) else {
            return Err(BlobError::Truncated {
                what: "header",
                need: HEADER_LEN,
                have: bytes.len(),
            });
        };
        let offset = bytes.as_ptr() as usize % 4;
        if offset != 0 {
            return Err(BlobError::Misaligned { offset });
        }
        // Alignment (4) and length (64) were checked above, so this cannot
        // fail; map the impossible error rather than unwrap.
        let header: &Header =
            bytemuck::try_from_bytes(head).map_err(|_| BlobError::Misaligned { offset })?;
        if header.magic != MAGIC {
            return Err(BlobError::BadMagic);
        }
        if header.endian != ENDIAN_CHECK {
            return Err(BlobError::BadEndianness {
                found: header.endian,
            });
        }
        if header.kind != kind {
            return Err(BlobError::WrongKind {
                expected: kind,
                found: header.kind,
            });
        }
        if (1..VERSION).contains(&header.version) {
            return Err(BlobError::OldVersion {
                found: header.version,
            });
        }
        if header.version != VERSION {
            return Err(BlobError::UnsupportedVersion {
                found: header.version,
            });
        }
        Ok((
            header,
            Sections {
                bytes,
                pos: HEADER_LEN,
            },
        ))
    }

    /// The next `count` records of `T` as the section `what`.
    pub(crate) fn take<T: Pod>(
        &mut self,
        what: &'static str,
        count: u32,
    ) -> Result<&'a [T], BlobError> {
        let len = (count as usize)
            .checked_mul(core::mem::size_of::<T>())
            .ok_or(BlobError::Overflow { what })?;
        let end = self
            .pos
            .checked_add(len)
            .ok_or(BlobError::Overflow { what })?;
        let Some(raw) = self.bytes.get(self.pos..end) else {
            return Err(BlobError::Truncated {
                what,
                need: end,
                have: self.bytes.len(),
            });
        };
        self.pos = end;
        // Every section size is a multiple of 4 and the blob starts 4-byte
        // aligned, so the cast only fails for records aligned above 4.
        bytemuck::try_cast_slice(raw).map_err(|_| BlobError::Misaligned { offset: end % 4 })
    }

    /// Checks that the sections end exactly at the end of the input and
    /// returns the whole blob (what the checksum is over).
    pub(crate) fn finish(self) -> Result<&'a [u8], BlobError> {
        if self.pos != self.bytes.len() {
            return Err(BlobError::TrailingBytes {
                expected: self.pos,
                have: self.bytes.len(),
            });
        }
        Ok(self.bytes)
    }
}

/// Checks the header's checksum against the whole blob. O(n).
pub(crate) fn verify_checksum(header: &Header, blob: &[u8]) -> Result<(), BlobError> {
    let computed = blob_checksum(blob);
    if computed == header.checksum {
        Ok(())
    } else {
        Err(BlobError::Checksum {
            stored: header.checksum,
            computed,
        })
    }
}

/// A byte buffer aligned for in-place loading. Wrap `include_bytes!` data
/// in it (or use [`include_aligned!`](crate::include_aligned)) so the
/// blob's sections can be read without a copy:
///
/// ```
/// static SCENE: &kdray_kernel::Aligned<[u8]> =
///     kdray_kernel::include_aligned!("../../golden/cube-v3.kdt");
/// let tree = kdray_kernel::TriangleTree::from_bytes(&SCENE.bytes)?;
/// // Read in place: the tree's triangles are the blob's bytes.
/// assert_eq!(tree.triangles().as_ptr().cast::<u8>(), SCENE.bytes[SCENE.bytes.len() - 14 * 36..].as_ptr());
/// # Ok::<(), kdray_kernel::BlobError>(())
/// ```
#[repr(C)]
pub struct Aligned<B: ?Sized> {
    /// Zero-sized; raises the alignment of `bytes` to a cache line.
    pub _align: [Line; 0],
    /// The bytes, 64-byte aligned: every child pair of a triangle tree then
    /// sits in one cache line.
    pub bytes: B,
}

/// A 64-byte cache line; only its alignment is used ([`Aligned`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
#[repr(C, align(64))]
pub struct Line(pub [u64; 8]);

/// `include_bytes!`, aligned for [`TriangleTree::from_bytes`](crate::TriangleTree::from_bytes):
/// evaluates to a `&'static Aligned<[u8]>`.
#[macro_export]
macro_rules! include_aligned {
    ($path:expr) => {{
        static ALIGNED: &$crate::Aligned<[u8]> = &$crate::Aligned {
            _align: [],
            bytes: *include_bytes!($path),
        };
        ALIGNED
    }};
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOUNDS: Bounds = Bounds {
        min: [0.0; 3],
        max: [1.0; 3],
    };

    #[test]
    fn a_count_beyond_32_bits_is_an_error_not_a_truncation() {
        let mut out = [0u8; HEADER_LEN];
        let too_many = u32::MAX as usize + 1;
        let counts = [("nodes", 1), ("primitive indices", 0), ("points", too_many)];
        assert_eq!(
            write_blob(&mut out, KIND_POINTS, 0, BOUNDS, counts, &[]),
            Err(WriteError::TooMany {
                what: "points",
                count: too_many
            })
        );
    }

    #[test]
    fn a_short_buffer_is_an_error_and_a_long_one_is_used_from_the_start() {
        let section = [7u8; 8];
        let counts = [("nodes", 1), ("primitive indices", 0), ("triangles", 0)];
        let mut short = [0u8; HEADER_LEN + 4];
        assert_eq!(
            write_blob(&mut short, KIND_TRIANGLES, 0, BOUNDS, counts, &[&section]),
            Err(WriteError::BufferTooSmall {
                need: HEADER_LEN + 8,
                have: HEADER_LEN + 4
            })
        );
        let mut long = [0xAAu8; HEADER_LEN + 12];
        let n = write_blob(&mut long, KIND_TRIANGLES, 3, BOUNDS, counts, &[&section]);
        assert_eq!(n, Ok(HEADER_LEN + 8));
        let header: Header = bytemuck::pod_read_unaligned(&long[..HEADER_LEN]);
        assert_eq!(
            (header.kind, header.max_depth, header.node_count),
            (KIND_TRIANGLES, 3, 1)
        );
        assert_eq!(header.checksum, blob_checksum(&long[..HEADER_LEN + 8]));
        assert_eq!(long[HEADER_LEN..HEADER_LEN + 8], section);
        assert_eq!(long[HEADER_LEN + 8..], [0xAA; 4]);
    }
}
