//! A cell's triangle as the builders hold it: its index and its box
//! clipped to the cell.

use kdray_kernel::Bounds;

/// One triangle of a cell. Aligned to 32 bytes (4 bytes of padding): a
/// copy is one aligned 32-byte move, where the 28-byte items were copied
/// in three pieces and read back across them (a stalled store forward on
/// every item a partition moved).
#[derive(Clone, Copy, Debug)]
#[repr(align(32))]
pub(super) struct Item {
    /// The triangle.
    pub(super) tri: u32,
    /// Its box, clipped to the cell.
    pub(super) b: Bounds,
}

impl Item {
    /// A placeholder, overwritten before use.
    pub(super) const NONE: Item = Item {
        tri: 0,
        b: Bounds::EMPTY,
    };
}
