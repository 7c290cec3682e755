//! The `kdray` command-line tool: build, inspect and trace k-d trees.
#![deny(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout};
use std::io::Write as _;
use std::sync::atomic::{AtomicBool, Ordering};

/// The build makes and frees a few small lists per cell (hundreds of
/// thousands of cells): glibc's malloc was 11% of a bunny build. mimalloc
/// v2 takes 12-18% off `kdray build` of the bunny (SAH, binned) and 5% off
/// the 1M-triangle one; v3 (the crate's default) was as fast on the bunny
/// but 5-10% slower than glibc on the 1M mesh (it returned and re-faulted
/// memory: page clearing was 23% of the build).
#[global_allocator]
static GLOBAL: Allocator = Allocator;

/// mimalloc, with a failed allocation reported as an error (status 1,
/// "out of memory", the outputs' temporaries removed) instead of Rust's
/// abort (status 134). Buffers sized by the user or the input are
/// reserved fallibly where they are made (`kdray_tools::memory`); this
/// catches the rest, such as a builder's lists for a mesh too large for
/// the memory (or `ulimit -v`) there is.
struct Allocator;

/// Set by the first failed allocation: a second one (while reporting the
/// first) gets Rust's abort.
static FAILED: AtomicBool = AtomicBool::new(false);

/// Reports a failed allocation of `bytes` and ends the process; returns
/// for a fallible reservation (whose caller reports it) and on a failure
/// while reporting one.
fn out_of_memory(bytes: usize) {
    // A reservation that reports its own failure (`kdray_tools::memory`).
    if kdray_tools::memory::reserving_fallibly() || FAILED.swap(true, Ordering::SeqCst) {
        return;
    }
    // Formatted on the stack: nothing here allocates.
    let mut line = [0u8; 256];
    let len = line.len();
    let mut rest = &mut line[..];
    let _ = writeln!(
        rest,
        "kdray: error: out of memory: {bytes} more bytes could not be allocated \
         (the input is too large for the memory this process may use; see `ulimit -v`)"
    );
    let n = len - rest.len();
    let _ = std::io::stderr().write_all(&line[..n]);
    kdray_tools::io::try_remove_temporaries();
    std::process::exit(1);
}

#[allow(unsafe_code)] // the global allocator's contract, passed on to mimalloc
                      // SAFETY: every method forwards its arguments unchanged to mimalloc's
                      // `GlobalAlloc`, whose contract is the same, and returns its pointer; a
                      // null pointer (a failed allocation) is returned as is when
                      // `out_of_memory` returns, so Rust's own handler then aborts.
unsafe impl GlobalAlloc for Allocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's `layout` meets `alloc`'s contract.
        let p = unsafe { mimalloc::MiMalloc.alloc(layout) };
        if p.is_null() {
            out_of_memory(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as `alloc`.
        let p = unsafe { mimalloc::MiMalloc.alloc_zeroed(layout) };
        if p.is_null() {
            out_of_memory(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from this allocator (mimalloc) with `layout`.
        unsafe { mimalloc::MiMalloc.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: `ptr` came from mimalloc with `layout`; `new_size` meets
        // `realloc`'s contract as the caller's does.
        let p = unsafe { mimalloc::MiMalloc.realloc(ptr, layout, new_size) };
        if p.is_null() {
            out_of_memory(new_size);
        }
        p
    }
}

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
