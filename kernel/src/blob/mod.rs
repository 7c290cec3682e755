//! The blob format: the 8-byte node, the header and sections on the wire,
//! the layout rule every tree obeys, and the errors that name what is wrong.

mod crc32c;
mod error;
pub mod node;
mod validate;
pub mod wire;

pub use error::{BlobError, WriteError};
pub use node::{Node, NodeKind};
pub use validate::{place_line_groups, FIRST_PAIR, LINE_NODES};
pub(crate) use validate::{replay_depth_first, validate_nodes};

/// The deepest a node may be (the root is at depth 0). The traversal stack
/// holds one entry per level, so this is also its capacity; builders cap
/// their depth at it and loaders refuse deeper trees.
pub const MAX_DEPTH: u32 = 64;
