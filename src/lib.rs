//! kdray: a k-d tree acceleration structure for ray tracing and
//! nearest-neighbour search. This facade re-exports the `no_std` kernel
//! ([`kernel`]) and the std tools ([`tools`]: builders, writer, loaders).
//! The README follows; its Rust snippets are this crate's doctests.
//!
#![doc = include_str!("../README.md")]

pub use kdray_kernel as kernel;
pub use kdray_tools as tools;
