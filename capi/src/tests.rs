//! The C API called from Rust: arguments the library must refuse, and
//! answers equal to the kernel's bit for bit. The C and C++ programs in
//! `tests/` check the same through the header and both libraries.

extern crate std;

use crate::*;
use bytemuck::Zeroable;
use core::ffi::CStr;
use kdray_kernel::{include_aligned, Hit, Neighbour, PointTree, Ray, TriangleTree};
use std::string::ToString;
use std::vec::Vec;

static CUBE: &kdray_kernel::Aligned<[u8]> = include_aligned!("../../kernel/golden/cube-v2.kdt");
static GRID: &kdray_kernel::Aligned<[u8]> = include_aligned!("../tests/data/grid-100.kdt");

const CLOSED: KdrayTriangleTree = KdrayTriangleTree {
    opaque: [0; KDRAY_HANDLE_WORDS],
};

fn open_cube() -> KdrayTriangleTree {
    let mut h = CLOSED;
    // SAFETY: a live handle and the static blob.
    let s = unsafe {
        kdray_triangles_open(
            &mut h,
            CUBE.bytes.as_ptr(),
            CUBE.bytes.len(),
            core::ptr::null_mut(),
            0,
        )
    };
    assert_eq!(s, KdrayStatus::Ok);
    h
}

fn open_grid() -> KdrayPointTree {
    let mut h = KdrayPointTree {
        opaque: [0; KDRAY_HANDLE_WORDS],
    };
    // SAFETY: a live handle and the static blob.
    let s = unsafe {
        kdray_points_open(
            &mut h,
            GRID.bytes.as_ptr(),
            GRID.bytes.len(),
            core::ptr::null_mut(),
            0,
        )
    };
    assert_eq!(s, KdrayStatus::Ok);
    h
}

/// Rays from around and inside the cube in every direction, some invalid.
fn rays() -> Vec<KdrayRay> {
    let mut state = 0x2545_F491_u32;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        (state >> 8) as f32 / (1 << 24) as f32 * 3.0 - 1.0
    };
    // Every other origin inside the closed cube, where every valid ray hits.
    let mut rays: Vec<KdrayRay> = (0..203)
        .map(|i| {
            let inside = |c: f32| if i % 2 == 0 { 0.2 + 0.2 * c } else { c };
            KdrayRay {
                org_x: inside(next()),
                org_y: inside(next()),
                org_z: inside(next()),
                tnear: 0.0,
                dir_x: next(),
                dir_y: next(),
                dir_z: next(),
                tfar: f32::INFINITY,
            }
        })
        .collect();
    rays[5].dir_x = f32::NAN;
    rays[9].tnear = 2.0;
    rays[9].tfar = 1.0;
    rays
}

fn message(
    f: impl FnOnce(*mut core::ffi::c_char, usize) -> KdrayStatus,
) -> (KdrayStatus, std::string::String) {
    let mut buf = [0x55 as core::ffi::c_char; 256];
    let s = f(buf.as_mut_ptr(), buf.len());
    // SAFETY: the library NUL-terminates within the buffer.
    let text = unsafe { CStr::from_ptr(buf.as_ptr()) };
    (s, text.to_str().unwrap().into())
}

#[test]
fn version_is_the_crates() {
    // SAFETY: a static NUL-terminated string.
    let v = unsafe { CStr::from_ptr(kdray_version()) };
    assert_eq!(v.to_str().unwrap(), env!("CARGO_PKG_VERSION"));
    // SAFETY: as above.
    let t = unsafe { CStr::from_ptr(kdray_status_text(1234)) };
    assert_eq!(t.to_str().unwrap(), "unknown status");
}

#[test]
fn a_corrupt_blob_is_refused_with_the_kernels_sentence() {
    let mut bad = CUBE.bytes.to_vec();
    bad[100] ^= 1;
    let expected = TriangleTree::from_bytes(&bad).unwrap_err().to_string();
    let mut h = open_cube();
    // SAFETY: live buffers of the lengths given.
    let (s, text) =
        message(|m, n| unsafe { kdray_triangles_open(&mut h, bad.as_ptr(), bad.len(), m, n) });
    assert_eq!(s, KdrayStatus::InvalidBlob);
    assert_eq!(text, expected);
    assert!(text.contains("checksum"), "{text}");
    // The failed open closed the handle it was given.
    let mut hit = KdrayHit::zeroed();
    // SAFETY: live objects.
    assert_eq!(
        unsafe { kdray_closest_hit(&h, &rays()[0], &mut hit) },
        KdrayStatus::NotOpen
    );

    // A triangle blob is not a point tree, and the message is cut to fit.
    let mut p = open_grid();
    let mut small = [0x55 as core::ffi::c_char; 8];
    // SAFETY: live buffers of the lengths given.
    let s = unsafe {
        kdray_points_open(
            &mut p,
            CUBE.bytes.as_ptr(),
            CUBE.bytes.len(),
            small.as_mut_ptr(),
            small.len(),
        )
    };
    assert_eq!(s, KdrayStatus::InvalidBlob);
    let full = PointTree::from_bytes(&CUBE.bytes).unwrap_err().to_string();
    // SAFETY: NUL-terminated by the library.
    let cut = unsafe { CStr::from_ptr(small.as_ptr()) }.to_str().unwrap();
    assert_eq!(cut, &full[..7]);
}

#[test]
fn bad_arguments_are_error_codes() {
    let h = open_cube();
    let ray = rays()[0];
    let mut hit = KdrayHit::zeroed();
    let null = core::ptr::null::<KdrayTriangleTree>();
    // SAFETY: every pointer is live, null, or misaligned and refused before use.
    unsafe {
        assert_eq!(
            kdray_closest_hit(null, &ray, &mut hit),
            KdrayStatus::NullPointer
        );
        assert_eq!(
            kdray_closest_hit(&h, core::ptr::null(), &mut hit),
            KdrayStatus::NullPointer
        );
        assert_eq!(
            kdray_closest_hit(&h, &ray, core::ptr::null_mut()),
            KdrayStatus::NullPointer
        );
        let words = [0u32; 20];
        let odd = words.as_ptr().cast::<u8>().add(2).cast::<KdrayRay>();
        assert_eq!(
            kdray_closest_hit(&h, odd, &mut hit),
            KdrayStatus::Misaligned
        );
        let odd_tree = words
            .as_ptr()
            .cast::<u8>()
            .add(4)
            .cast::<KdrayTriangleTree>();
        let s = kdray_closest_hit(odd_tree, &ray, &mut hit);
        // `words` may itself sit at an address that is 4 mod 8.
        assert!(
            matches!(s, KdrayStatus::Misaligned | KdrayStatus::NotOpen),
            "{s:?}"
        );
        assert_eq!(
            kdray_closest_hit(&CLOSED, &ray, &mut hit),
            KdrayStatus::NotOpen
        );
        // A point handle is not a triangle handle.
        let p = open_grid();
        let as_tri = (&p as *const KdrayPointTree).cast::<KdrayTriangleTree>();
        assert_eq!(
            kdray_closest_hit(as_tri, &ray, &mut hit),
            KdrayStatus::NotOpen
        );
        let mut hits = [KdrayHit::zeroed(); 2];
        let s = kdray_closest_hits(&h, &ray, hits.as_mut_ptr(), usize::MAX / 16);
        assert_eq!(s, KdrayStatus::BadSize);
        let (s, text) = message(|m, n| {
            let mut t = CLOSED;
            kdray_triangles_open(&mut t, core::ptr::null(), 64, m, n)
        });
        assert_eq!(
            (s, text.as_str()),
            (
                KdrayStatus::NullPointer,
                "a required pointer argument is null"
            )
        );
        // A misaligned blob is the kernel's error, with its sentence.
        let (s, text) = message(|m, n| {
            let mut t = CLOSED;
            kdray_triangles_open(
                &mut t,
                CUBE.bytes.as_ptr().add(1),
                CUBE.bytes.len() - 1,
                m,
                n,
            )
        });
        assert_eq!(s, KdrayStatus::InvalidBlob);
        assert_eq!(
            text,
            TriangleTree::from_bytes(&CUBE.bytes[1..])
                .unwrap_err()
                .to_string()
        );
        assert!(text.contains("align"), "{text}");
        // A point query on a triangle handle.
        let mut n = KdrayNeighbour::zeroed();
        let q = [0.0f32; 3];
        let as_pts = (&h as *const KdrayTriangleTree).cast::<KdrayPointTree>();
        assert_eq!(
            kdray_nearest(as_pts, q.as_ptr(), &mut n),
            KdrayStatus::NotOpen
        );
    }
}

#[test]
fn single_packet_and_stream_answers_are_the_kernels() {
    let h = open_cube();
    let tree = TriangleTree::from_bytes(&CUBE.bytes).unwrap();
    let rays = rays();
    let mut hits = std::vec![KdrayHit::zeroed(); rays.len()];
    let mut occluded = std::vec![7i32; rays.len()];
    // SAFETY: live slices of `rays.len()` records.
    unsafe {
        assert_eq!(
            kdray_closest_hits(&h, rays.as_ptr(), hits.as_mut_ptr(), rays.len()),
            KdrayStatus::Ok
        );
        assert_eq!(
            kdray_any_hits(&h, rays.as_ptr(), occluded.as_mut_ptr(), rays.len()),
            KdrayStatus::Ok
        );
    }
    let mut some = 0;
    for (i, r) in rays.iter().enumerate() {
        let ray = Ray::from(*r);
        let expected = tree.closest_hit(&ray);
        some += usize::from(expected.is_hit());
        let mut one = KdrayHit::zeroed();
        let mut occ = 7;
        // SAFETY: live objects.
        unsafe {
            assert_eq!(kdray_closest_hit(&h, r, &mut one), KdrayStatus::Ok);
            assert_eq!(kdray_any_hit(&h, r, &mut occ), KdrayStatus::Ok);
        }
        assert_eq!(Hit::from(one).bits(), expected.bits(), "ray {i}");
        assert_eq!(Hit::from(hits[i]).bits(), expected.bits(), "ray {i}");
        assert_eq!(occ, i32::from(tree.any_hit(&ray)), "ray {i}");
        assert_eq!(occluded[i], occ, "ray {i}");
    }
    assert!(some > rays.len() / 2, "{some} hits");
    assert!(!Hit::from(hits[5]).is_hit() && !Hit::from(hits[9]).is_hit());
    packets::<4>(&h, &hits, &occluded, kdray_closest_hit4, kdray_any_hit4);
    packets::<8>(&h, &hits, &occluded, kdray_closest_hit8, kdray_any_hit8);
    packets::<16>(&h, &hits, &occluded, kdray_closest_hit16, kdray_any_hit16);
}

type ClosestN<const N: usize> = unsafe extern "C" fn(
    *const i32,
    *const KdrayTriangleTree,
    *const KdrayRayN<N>,
    *mut KdrayHitN<N>,
) -> KdrayStatus;
type AnyN<const N: usize> = unsafe extern "C" fn(
    *const i32,
    *const KdrayTriangleTree,
    *const KdrayRayN<N>,
    *mut i32,
) -> KdrayStatus;

/// Every packet of `N` consecutive rays, every third lane inactive,
/// against the single-ray answers.
fn packets<const N: usize>(
    h: &KdrayTriangleTree,
    hits: &[KdrayHit],
    occluded: &[i32],
    closest: ClosestN<N>,
    any: AnyN<N>,
) {
    let rays = rays();
    for (c, chunk) in rays.chunks_exact(N).enumerate() {
        let lane = |f: fn(&KdrayRay) -> f32| core::array::from_fn(|l| f(&chunk[l]));
        let p = KdrayRayN::<N> {
            org_x: lane(|r| r.org_x),
            org_y: lane(|r| r.org_y),
            org_z: lane(|r| r.org_z),
            tnear: lane(|r| r.tnear),
            dir_x: lane(|r| r.dir_x),
            dir_y: lane(|r| r.dir_y),
            dir_z: lane(|r| r.dir_z),
            tfar: lane(|r| r.tfar),
        };
        let valid: [i32; N] = core::array::from_fn(|l| if (c + l) % 3 == 0 { 0 } else { -1 });
        let mut out = KdrayHitN::<N> {
            t: [0.0; N],
            prim_id: [0; N],
            u: [0.0; N],
            v: [0.0; N],
        };
        let mut occ = [7i32; N];
        // SAFETY: live objects of the packet's width.
        unsafe {
            assert_eq!(closest(valid.as_ptr(), h, &p, &mut out), KdrayStatus::Ok);
            assert_eq!(
                any(valid.as_ptr(), h, &p, occ.as_mut_ptr()),
                KdrayStatus::Ok
            );
        }
        for l in 0..N {
            let i = c * N + l;
            let got = Hit {
                t: out.t[l],
                prim: out.prim_id[l],
                u: out.u[l],
                v: out.v[l],
            };
            let (want, want_occ) = if valid[l] == 0 {
                (Hit::MISS, 0)
            } else {
                (hits[i].into(), occluded[i])
            };
            assert_eq!(got.bits(), want.bits(), "{N}-wide lane {l} of packet {c}");
            assert_eq!(occ[l], want_occ, "{N}-wide lane {l} of packet {c}");
        }
    }
}

#[test]
fn point_queries_are_the_kernels() {
    let h = open_grid();
    let tree = PointTree::from_bytes(&GRID.bytes).unwrap();
    for q in [
        [0.0f32, 0.0, 0.0],
        [0.3, 0.55, 0.125],
        [0.5, 0.5, 0.5],
        [2.0, -1.0, 0.4],
        [f32::NAN, 0.0, 0.0],
    ] {
        let mut n = KdrayNeighbour::zeroed();
        let mut knn = [KdrayNeighbour::zeroed(); 7];
        let mut within = [KdrayNeighbour::zeroed(); 100];
        let (mut found_k, mut found_w) = (99, 99);
        // SAFETY: live objects of the lengths given.
        unsafe {
            assert_eq!(kdray_nearest(&h, q.as_ptr(), &mut n), KdrayStatus::Ok);
            assert_eq!(
                kdray_knn(&h, q.as_ptr(), 7, knn.as_mut_ptr(), &mut found_k),
                KdrayStatus::Ok
            );
            let s = kdray_within(
                &h,
                q.as_ptr(),
                0.1,
                within.as_mut_ptr(),
                within.len(),
                &mut found_w,
            );
            assert_eq!(s, KdrayStatus::Ok);
        }
        let bits = |n: &KdrayNeighbour| {
            Neighbour {
                index: n.index,
                d2: n.d2,
            }
            .bits()
        };
        assert_eq!(
            bits(&n),
            tree.nearest(q).unwrap_or(Neighbour::NONE).bits(),
            "{q:?}"
        );
        let mut want = [Neighbour::NONE; 7];
        assert_eq!(found_k, tree.knn(q, &mut want), "{q:?}");
        assert!(
            knn[..found_k]
                .iter()
                .map(bits)
                .eq(want[..found_k].iter().map(|n| n.bits())),
            "{q:?}"
        );
        let mut want = [Neighbour::NONE; 100];
        assert_eq!(Ok(found_w), tree.within(q, 0.1, &mut want), "{q:?}");
        assert!(
            within[..found_w]
                .iter()
                .map(bits)
                .eq(want[..found_w].iter().map(|n| n.bits())),
            "{q:?}"
        );
        if found_w > 1 {
            let mut few = 0;
            // SAFETY: a live buffer of one record.
            let s = unsafe { kdray_within(&h, q.as_ptr(), 0.1, within.as_mut_ptr(), 1, &mut few) };
            assert_eq!((s, few), (KdrayStatus::BufferTooSmall, found_w), "{q:?}");
        }
    }
}
