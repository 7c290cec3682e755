//! # kdray-firmware: the proof that no panic path is reachable
//!
//! A `no_std`, `no_main` image that embeds a triangle blob (the kernel's
//! golden cube) and a point blob (`capi/tests/data/grid-100.kdt`),
//! validates them, and runs the closest hit, any hit and k-nearest
//! queries on inputs the optimiser cannot see ([`black_box`]).
//!
//! The panic handler calls a function that exists nowhere, so if any
//! panic path (an index out of bounds, an unwrap, an overflow check, a
//! slice split) survives optimisation in code reachable from these entry
//! points, the link fails with an undefined symbol
//! `kdray_firmware_reached_a_panic_path`. Linking is the proof, in the
//! `release` and the size-optimised `size` profiles; on wasm32 the same
//! symbol would become an import, which the wasm test refuses.
//!
//! The entry points measured (README, "Firmware figures") are the
//! `#[no_mangle]` Rust functions `kdray_fw_validate_*`,
//! `kdray_fw_closest_hit`, `kdray_fw_any_hit`, `kdray_fw_first_hits` and
//! `kdray_fw_knn`; the
//! `extern "C"` wrappers (`kdray_fw_boot`, `kdray_fw_trace`) give the host
//! of a wasm build scalar arguments.
#![no_std]
#![no_main]

use core::hint::black_box;
#[cfg(feature = "knn")]
use kdray_kernel::Neighbour;
use kdray_kernel::{include_aligned, Aligned, Hit, PointTree, Ray, ShallowTree, TriangleTree};

/// The triangle scene, in flash (`kdray build kernel/golden/cube.obj`).
static SCENE: &Aligned<[u8]> = include_aligned!("../../kernel/golden/cube-v3.kdt");
/// The point set (commands in `capi/tests/data/README.md`).
static POINTS: &Aligned<[u8]> = include_aligned!("../../capi/tests/data/grid-100.kdt");

/// The depth the image's trees may have: the single-ray walk keeps one
/// pending far cell per level, so this bounds its stack (README,
/// "Firmware figures"). Blobs for it are built with `--max-depth 24`.
const DEPTH: usize = 24;

/// The image's triangle tree: validated, and no deeper than [`DEPTH`].
pub type Tree = ShallowTree<'static, DEPTH>;

/// How many neighbours the k-nearest entry point returns.
#[cfg(feature = "knn")]
const K: usize = 4;

/// Validates a triangle blob, and its depth against [`DEPTH`]: the
/// boot-time check.
#[no_mangle]
#[inline(never)]
pub fn kdray_fw_validate_triangles(blob: &'static [u8]) -> Option<Tree> {
    Tree::new(TriangleTree::from_bytes(blob).ok()?).ok()
}

/// Validates a point blob.
#[no_mangle]
#[inline(never)]
pub fn kdray_fw_validate_points(blob: &'static [u8]) -> Option<PointTree<'static>> {
    PointTree::from_bytes(blob).ok()
}

/// The closest hit of one ray.
#[no_mangle]
#[inline(never)]
pub fn kdray_fw_closest_hit(tree: &Tree, ray: &Ray) -> Hit {
    tree.closest_hit(ray)
}

/// Whether one ray hits anything.
#[no_mangle]
#[inline(never)]
pub fn kdray_fw_any_hit(tree: &Tree, ray: &Ray) -> bool {
    tree.any_hit(ray)
}

/// The first hits of one ray (at most 4), nearest first; returns how many.
#[cfg(feature = "first-hits")]
#[no_mangle]
#[inline(never)]
pub fn kdray_fw_first_hits(tree: &Tree, ray: &Ray, out: &mut [Hit; 4]) -> usize {
    tree.first_hits(ray, out)
}

/// The `K` nearest points to `q`, nearest first; returns how many.
#[cfg(feature = "knn")]
#[no_mangle]
#[inline(never)]
pub fn kdray_fw_knn(tree: &PointTree<'_>, q: [f32; 3], out: &mut [Neighbour; K]) -> usize {
    tree.knn(q, out)
}

/// Validates both embedded blobs: 0 if both are accepted, bit 0 set if
/// the triangles are refused, bit 1 if the points are.
#[no_mangle]
pub extern "C" fn kdray_fw_boot() -> u32 {
    let tri = kdray_fw_validate_triangles(black_box(&SCENE.bytes)).is_none();
    let pts = cfg!(feature = "knn") && kdray_fw_validate_points(black_box(&POINTS.bytes)).is_none();
    u32::from(tri) | u32::from(pts) << 1
}

/// Traces the ray `origin + t * dir`, `t` in `[0, inf]`, in the embedded
/// scene. `what` 0: the closest hit's triangle index (`0xFFFF_FFFF` for a
/// miss); 1: the closest hit's `t` as f32 bits; 2: 1 if occluded, else 0;
/// 3: the nearest embedded point to `origin` (`0xFFFF_FFFF` without the
/// `knn` feature or a point); 4 (with the `first-hits` feature): the
/// triangle indices of the first three hits, a byte each from the low one
/// (`0xFF` past the last hit).
/// `0xFFFF_FFFF` if a blob is refused.
#[no_mangle]
pub extern "C" fn kdray_fw_trace(
    what: u32,
    ox: f32,
    oy: f32,
    oz: f32,
    dx: f32,
    dy: f32,
    dz: f32,
) -> u32 {
    let Some(tree) = kdray_fw_validate_triangles(black_box(&SCENE.bytes)) else {
        return u32::MAX;
    };
    let ray = Ray {
        origin: [ox, oy, oz],
        tmin: 0.0,
        dir: [dx, dy, dz],
        tmax: f32::INFINITY,
    };
    match what {
        0 => kdray_fw_closest_hit(&tree, &ray).prim,
        1 => kdray_fw_closest_hit(&tree, &ray).t.to_bits(),
        2 => u32::from(kdray_fw_any_hit(&tree, &ray)),
        #[cfg(feature = "first-hits")]
        4 => {
            let mut hits = [Hit::MISS; 4];
            let n = kdray_fw_first_hits(&tree, &ray, &mut hits);
            (0..3).fold(0, |word, i| {
                let prim = if i < n { hits[i].prim & 0xFF } else { 0xFF };
                word | prim << (8 * i)
            })
        }
        _ => nearest([ox, oy, oz]),
    }
}

/// The index of the nearest embedded point to `q` (by the k-NN entry point).
#[cfg(feature = "knn")]
fn nearest(q: [f32; 3]) -> u32 {
    let Some(points) = kdray_fw_validate_points(black_box(&POINTS.bytes)) else {
        return u32::MAX;
    };
    let mut out = [Neighbour::NONE; K];
    kdray_fw_knn(&points, q, &mut out);
    out[0].index
}

#[cfg(not(feature = "knn"))]
fn nearest(_: [f32; 3]) -> u32 {
    u32::MAX
}

/// The reset entry: boot, then one query of each kind on opaque inputs.
#[no_mangle]
pub extern "C" fn _start() -> ! {
    let booted = kdray_fw_boot();
    let [ox, oy, oz, dx, dy, dz] = black_box([0.3f32, 0.6, -1.0, 0.0, 0.0, 1.0]);
    let mut answers = [booted; 5];
    for (what, a) in (0..4u32).zip(&mut answers[1..]) {
        *a = kdray_fw_trace(black_box(what), ox, oy, oz, dx, dy, dz);
    }
    loop {
        black_box(&answers);
    }
}

#[cfg(not(feature = "panic-loop"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    extern "Rust" {
        // Defined nowhere: any reachable panic is a link error.
        fn kdray_firmware_reached_a_panic_path() -> !;
    }
    // SAFETY: never runs; the image links only if this call is unreachable.
    unsafe { kdray_firmware_reached_a_panic_path() }
}

#[cfg(feature = "panic-loop")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {}
}
