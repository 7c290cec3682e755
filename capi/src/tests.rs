//! The C API called from Rust: arguments the library must refuse, and
//! answers equal to the kernel's bit for bit. The C and C++ programs in
//! `tests/` check the same through the header and both libraries.

extern crate std;

use crate::*;
use bytemuck::Zeroable;
use core::ffi::CStr;
use core::ptr;
use kdray_kernel::{include_aligned, Hit, Neighbour, PointTree, Ray, TriangleTree};
use std::string::ToString;
use std::vec::Vec;

static CUBE: &kdray_kernel::Aligned<[u8]> = include_aligned!("../../kernel/golden/cube-v3.kdt");
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
        // SAFETY: every pointer is a live local or a handle this test opened.
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
        let s = kdray_closest_hits(&h, &ray, hits.as_mut_ptr(), usize::MAX / 16, ptr::null());
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
        assert!(
            text.starts_with("blob is not 4-byte aligned (address % 4 = ")
                && text.contains("malloc")
                && !text.contains("kdray_kernel"),
            "{text}"
        );
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
fn single_packet_and_batch_answers_are_the_kernels() {
    let h = open_cube();
    let tree = TriangleTree::from_bytes(&CUBE.bytes).unwrap();
    let rays = rays();
    let mut hits = std::vec![KdrayHit::zeroed(); rays.len()];
    let mut occluded = std::vec![7i32; rays.len()];
    // SAFETY: live slices of `rays.len()` records.
    unsafe {
        assert_eq!(
            kdray_closest_hits(
                &h,
                rays.as_ptr(),
                hits.as_mut_ptr(),
                rays.len(),
                ptr::null()
            ),
            KdrayStatus::Ok
        );
        assert_eq!(
            kdray_any_hits(
                &h,
                rays.as_ptr(),
                occluded.as_mut_ptr(),
                rays.len(),
                ptr::null()
            ),
            KdrayStatus::Ok
        );
    }
    // Every width, and in the Morton order of the origins (room for the
    // sort, and too little): the same answers, each in its ray's slot.
    for (width, room) in [
        (1, 0),
        (4, 1),
        (8, 2 * rays.len()),
        (16, 2 * rays.len()),
        (0, 0),
    ] {
        let mut scratch = std::vec![0u64; room];
        let batch = KdrayBatch {
            width,
            scratch: if room == 0 {
                ptr::null_mut()
            } else {
                scratch.as_mut_ptr()
            },
            scratch_count: room,
        };
        let mut each_hit = std::vec![KdrayHit::zeroed(); rays.len()];
        let mut each = std::vec![7i32; rays.len()];
        // SAFETY: live slices of their lengths.
        unsafe {
            assert_eq!(
                kdray_closest_hits(&h, rays.as_ptr(), each_hit.as_mut_ptr(), rays.len(), &batch),
                KdrayStatus::Ok
            );
            assert_eq!(
                kdray_any_hits(&h, rays.as_ptr(), each.as_mut_ptr(), rays.len(), &batch),
                KdrayStatus::Ok
            );
        }
        assert_eq!(each_hit, hits, "width {width}, scratch {room}");
        assert_eq!(each, occluded, "width {width}, scratch {room}");
    }
    // A width that is none of 0, 1, 4, 8, 16 is refused, output untouched.
    let bad = KdrayBatch {
        width: 3,
        scratch: ptr::null_mut(),
        scratch_count: 0,
    };
    let mut untouched = std::vec![7i32; rays.len()];
    // SAFETY: live slices of their lengths.
    let s = unsafe { kdray_any_hits(&h, rays.as_ptr(), untouched.as_mut_ptr(), rays.len(), &bad) };
    assert_eq!(s, KdrayStatus::BadArgument);
    assert!(untouched.iter().all(|&o| o == 7));
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
        // The first hits: the kernel's, led by the closest.
        let mut first = [KdrayHit::zeroed(); 4];
        let mut want = [Hit::MISS; 4];
        let mut count = 9;
        // SAFETY: live objects, 4 records.
        let s = unsafe { kdray_first_hits(&h, r, first.as_mut_ptr(), 4, &mut count) };
        assert_eq!(
            (s, count),
            (KdrayStatus::Ok, tree.first_hits(&ray, &mut want))
        );
        for (got, want) in first.iter().zip(&want).take(count) {
            assert_eq!(Hit::from(*got).bits(), want.bits(), "ray {i}");
        }
        assert_eq!(count > 0, expected.is_hit(), "ray {i}");
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

/// A `D`-dimensional `S` tree over deterministic points, as a blob.
fn shaped_blob<const D: usize, S: kdray_kernel::Scalar>(
    n: usize,
    point: impl Fn(u64) -> S,
) -> (kdray_tools::blob::Blob, Vec<[S; D]>) {
    let pts: Vec<[S; D]> = (0..n)
        .map(|i| core::array::from_fn(|a| point((i * D + a) as u64)))
        .collect();
    let built = kdray_tools::points::build_points(&pts, &Default::default()).unwrap();
    (kdray_tools::blob::write_point_tree(&built).unwrap(), pts)
}

fn open_points(bytes: &[u8]) -> (KdrayStatus, KdrayPointTree, std::string::String) {
    let mut h = KdrayPointTree {
        opaque: [0; KDRAY_HANDLE_WORDS],
    };
    let mut msg = [0 as core::ffi::c_char; 256];
    // SAFETY: a live handle, blob and message buffer.
    let s =
        unsafe { kdray_points_open(&mut h, bytes.as_ptr(), bytes.len(), msg.as_mut_ptr(), 256) };
    // SAFETY: the library NUL-terminates the message.
    let text = unsafe { CStr::from_ptr(msg.as_ptr()) }
        .to_string_lossy()
        .into_owned();
    (s, h, text)
}

/// Halton-like coordinates in [0, 1): distinct, spread, reproducible.
fn coord(i: u64) -> f64 {
    (i.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn point_trees_of_any_shape_answer_as_the_kernel() {
    let (blob, pts) = shaped_blob::<8, f64>(700, coord);
    let (s, h, _) = open_points(blob.as_bytes());
    assert_eq!(s, KdrayStatus::Ok);
    let (mut dim, mut bytes) = (0, 0);
    // SAFETY: live objects.
    assert_eq!(
        // SAFETY: every pointer is a live local or a handle this test opened.
        unsafe { kdray_points_shape(&h, &mut dim, &mut bytes) },
        KdrayStatus::Ok
    );
    assert_eq!((dim, bytes), (8, 8));
    let tree = blob.point_tree::<8, f64>().unwrap();
    for (qi, q) in [pts[17], [0.5; 8], [3.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 9.0]]
        .iter()
        .enumerate()
    {
        let mut n = KdrayNeighbour64::zeroed();
        let mut knn = [KdrayNeighbour64 {
            index: 7,
            reserved: 7,
            d2: 7.0,
        }; 12];
        let mut within = [KdrayNeighbour64::zeroed(); 700];
        let (mut fk, mut fw) = (99, 99);
        // SAFETY: live objects of the lengths given.
        unsafe {
            assert_eq!(
                kdray_nearest_f64(&h, q.as_ptr(), 8, &mut n),
                KdrayStatus::Ok
            );
            let s = kdray_knn_f64(&h, q.as_ptr(), 8, 12, knn.as_mut_ptr(), &mut fk);
            assert_eq!(s, KdrayStatus::Ok);
            let s = kdray_within_f64(&h, q.as_ptr(), 8, 0.4, within.as_mut_ptr(), 700, &mut fw);
            assert_eq!(s, KdrayStatus::Ok);
        }
        let want = tree.nearest(*q).unwrap();
        assert_eq!(
            (n.index, n.d2.to_bits(), n.reserved),
            (want.index, want.d2.to_bits(), 0)
        );
        let mut wk = [Neighbour::<f64>::NONE; 12];
        assert_eq!(fk, tree.knn(*q, &mut wk));
        for (got, want) in knn.iter().zip(&wk) {
            assert_eq!(
                (got.index, got.d2.to_bits(), got.reserved),
                (want.index, want.d2.to_bits(), 0)
            );
        }
        let mut ww = [Neighbour::<f64>::NONE; 700];
        assert_eq!(Ok(fw), tree.within(*q, 0.4, &mut ww), "query {qi}");
        assert!(within[..fw]
            .iter()
            .map(|n| (n.index, n.d2.to_bits()))
            .eq(ww[..fw].iter().map(|n| (n.index, n.d2.to_bits()))));
    }
}

#[test]
fn a_query_of_another_shape_is_refused() {
    let (blob, _) = shaped_blob::<8, f64>(50, coord);
    let (_, h8, _) = open_points(blob.as_bytes());
    let (blob2, _) = shaped_blob::<2, f32>(50, |i| coord(i) as f32);
    let (s, h2, _) = open_points(blob2.as_bytes());
    assert_eq!(s, KdrayStatus::Ok);
    let q32 = [0.5f32; 17];
    let q64 = [0.5f64; 17];
    let mut n32 = KdrayNeighbour::zeroed();
    let mut n64 = KdrayNeighbour64::zeroed();
    let closed = KdrayPointTree {
        opaque: [0; KDRAY_HANDLE_WORDS],
    };
    // SAFETY: live objects, queries of 17 scalars.
    unsafe {
        use KdrayStatus::{NotOpen, Ok as Fine, WrongShape};
        assert_eq!(kdray_nearest_f64(&h8, q64.as_ptr(), 8, &mut n64), Fine);
        assert_eq!(
            kdray_nearest_f64(&h8, q64.as_ptr(), 3, &mut n64),
            WrongShape
        );
        assert_eq!(
            kdray_nearest_f32(&h8, q32.as_ptr(), 8, &mut n32),
            WrongShape
        );
        assert_eq!(kdray_nearest(&h8, q32.as_ptr(), &mut n32), WrongShape);
        assert_eq!(kdray_nearest_f32(&h2, q32.as_ptr(), 2, &mut n32), Fine);
        assert_eq!(
            kdray_nearest_f64(&h2, q64.as_ptr(), 2, &mut n64),
            WrongShape
        );
        for dim in [0, 17, usize::MAX] {
            assert_eq!(
                kdray_nearest_f32(&h2, q32.as_ptr(), dim, &mut n32),
                WrongShape
            );
            assert_eq!(
                kdray_nearest_f32(&closed, q32.as_ptr(), dim, &mut n32),
                NotOpen
            );
        }
        assert_eq!(
            kdray_nearest_f32(&closed, q32.as_ptr(), 2, &mut n32),
            NotOpen
        );
        let (mut d, mut b) = (0, 0);
        assert_eq!(kdray_points_shape(&closed, &mut d, &mut b), NotOpen);
        assert_eq!(kdray_points_shape(&h2, &mut d, &mut b), Fine);
        assert_eq!((d, b), (2, 4));
        let text = CStr::from_ptr(kdray_status_text(WrongShape as i32));
        assert!(text.to_str().unwrap().contains("dimension"));
    }
    // A dimension the library is not compiled for: refused by name.
    let (blob20, _) = shaped_blob::<20, f32>(40, |i| coord(i) as f32);
    let (s, _, msg) = open_points(blob20.as_bytes());
    assert_eq!(s, KdrayStatus::InvalidBlob);
    assert!(
        msg.contains("20-dimensional") && msg.contains("1 to 16"),
        "{msg}"
    );
}

static SCENE: &kdray_kernel::Aligned<[u8]> = include_aligned!("../tests/data/two-quads-scene.kdt");

#[test]
fn a_scene_answers_as_the_kernel_and_a_tree_handle_is_not_a_scene() {
    let mut h = KdrayScene {
        opaque: [0; KDRAY_HANDLE_WORDS],
    };
    let mut msg = [0 as core::ffi::c_char; 256];
    // A triangle blob is refused, with the kernel's sentence.
    // SAFETY: a live handle, the static blob, a 256-byte message buffer.
    let s = unsafe {
        kdray_scene_open(
            &mut h,
            CUBE.bytes.as_ptr(),
            CUBE.bytes.len(),
            msg.as_mut_ptr(),
            msg.len(),
        )
    };
    assert_eq!(s, KdrayStatus::InvalidBlob);
    // SAFETY: write_message NUL-terminates.
    let text = unsafe { CStr::from_ptr(msg.as_ptr()) }
        .to_str()
        .unwrap()
        .to_string();
    assert!(text.contains("kind"), "{text}");
    // SAFETY: as above.
    let s = unsafe {
        kdray_scene_open(
            &mut h,
            SCENE.bytes.as_ptr(),
            SCENE.bytes.len(),
            msg.as_mut_ptr(),
            msg.len(),
        )
    };
    assert_eq!(s, KdrayStatus::Ok);
    let scene = kdray_kernel::Scene::from_bytes(&SCENE.bytes).unwrap();
    let ray = KdrayRay {
        org_x: 2.5,
        org_y: 0.5,
        org_z: -1.0,
        tnear: 0.0,
        dir_x: 0.0,
        dir_y: 0.0,
        dir_z: 1.0,
        tfar: f32::INFINITY,
    };
    let mut hit = KdraySceneHit::zeroed();
    let mut occluded = 0;
    for mask in [u32::MAX, 0] {
        // SAFETY: live handle and records.
        assert_eq!(
            // SAFETY: every pointer is a live local or a handle this test opened.
            unsafe { kdray_scene_closest_hit(&h, &ray, mask, &mut hit) },
            KdrayStatus::Ok
        );
        let want = scene.closest_hit(&ray.into(), mask);
        assert_eq!(bytemuck::cast::<_, [u32; 5]>(hit), want.bits());
        // SAFETY: as above.
        assert_eq!(
            // SAFETY: every pointer is a live local or a handle this test opened.
            unsafe { kdray_scene_any_hit(&h, &ray, mask, &mut occluded) },
            KdrayStatus::Ok
        );
        assert_eq!(occluded, i32::from(mask != 0));
    }
    assert_eq!(hit.inst_id, KDRAY_MISS);
    // SAFETY: as above.
    unsafe { kdray_scene_closest_hit(&h, &ray, 1, &mut hit) };
    assert_eq!(hit.inst_id, 1);
    // The first hits: the kernel's, led by the closest.
    let mut first = [KdraySceneHit::zeroed(); 4];
    let mut want = [kdray_kernel::SceneHit::MISS; 4];
    let mut count = 9;
    // SAFETY: live handle, 4 records.
    let s = unsafe { kdray_scene_first_hits(&h, &ray, 1, first.as_mut_ptr(), 4, &mut count) };
    assert_eq!(
        (s, count),
        (KdrayStatus::Ok, scene.first_hits(&ray.into(), 1, &mut want))
    );
    assert!(count >= 1 && first[0] == hit);
    for (got, want) in first.iter().zip(&want).take(count) {
        assert_eq!(bytemuck::cast::<_, [u32; 5]>(*got), want.bits());
    }
    // A scene handle is not a tree handle.
    let tree: *const KdrayTriangleTree = (&h as *const KdrayScene).cast();
    let mut th = KdrayHit::zeroed();
    // SAFETY: a readable handle-sized struct.
    assert_eq!(
        // SAFETY: every pointer is a live local or a handle this test opened.
        unsafe { kdray_closest_hit(tree, &ray, &mut th) },
        KdrayStatus::NotOpen
    );
}

#[test]
fn a_scenes_closest_point_is_the_kernels() {
    let mut h = KdrayScene {
        opaque: [0; KDRAY_HANDLE_WORDS],
    };
    // SAFETY: a live handle, the static blob, no message buffer.
    let s = unsafe {
        kdray_scene_open(
            &mut h,
            SCENE.bytes.as_ptr(),
            SCENE.bytes.len(),
            core::ptr::null_mut(),
            0,
        )
    };
    assert_eq!(s, KdrayStatus::Ok);
    let scene = kdray_kernel::Scene::from_bytes(&SCENE.bytes).unwrap();
    // Above the first quad, beside the second, between them, and bad ones.
    let qs: [[f32; 3]; 5] = [
        [0.5, 0.5, 6.0],
        [2.0, 1.0, -0.5],
        [1.0, 0.5, 2.5],
        [f32::NAN, 0.0, 0.0],
        [0.0, f32::INFINITY, 0.0],
    ];
    let mut out = [KdraySceneClosestPoint::zeroed(); 5];
    for (mask, max) in [(u32::MAX, f32::INFINITY), (1, 0.75), (2, 3.0), (0, 1.0)] {
        // SAFETY: live handle, 5 points and 5 records.
        let s = unsafe {
            kdray_scene_closest_points(&h, qs.as_ptr().cast(), 5, mask, max, out.as_mut_ptr())
        };
        assert_eq!(s, KdrayStatus::Ok);
        for (q, o) in qs.iter().zip(&out) {
            let want = scene.closest_point_within(*q, mask, max).unwrap();
            match want {
                Some(c) => {
                    assert_eq!([o.x, o.y, o.z], c.point);
                    assert_eq!((o.prim_id, o.inst_id, o.reserved), (c.prim, c.instance, 0));
                    assert_eq!([o.u, o.v], [c.u, c.v]);
                    assert_eq!(o.distance2.to_bits(), c.distance2.to_bits());
                }
                None => {
                    assert_eq!((o.prim_id, o.inst_id), (KDRAY_MISS, KDRAY_MISS));
                    assert!(o.x.is_nan() && o.u.is_nan());
                    let finite = q.iter().all(|c| c.is_finite());
                    assert_eq!(o.distance2.is_nan(), !finite, "{q:?}");
                }
            }
        }
    }
    assert_eq!(
        (out[0].inst_id, out[0].distance2),
        (KDRAY_MISS, f64::INFINITY)
    );
    let mut one = KdraySceneClosestPoint::zeroed();
    // SAFETY: live handle and records.
    let s = unsafe { kdray_scene_closest_point(&h, qs[0].as_ptr(), u32::MAX, f32::NAN, &mut one) };
    assert_eq!((s, one.inst_id), (KdrayStatus::Ok, KDRAY_MISS));
    // SAFETY: null pointers are refused before any read.
    let s = unsafe { kdray_scene_closest_point(&h, core::ptr::null(), 1, 1.0, &mut one) };
    assert_eq!(s, KdrayStatus::NullPointer);
    // A tree handle is not a scene handle.
    let tree = open_cube();
    let scene_of_tree: *const KdrayScene = (&tree as *const KdrayTriangleTree).cast();
    // SAFETY: a readable handle-sized struct.
    let s = unsafe { kdray_scene_closest_point(scene_of_tree, qs[0].as_ptr(), 1, 1.0, &mut one) };
    assert_eq!(s, KdrayStatus::NotOpen);
    // SAFETY: a static NUL-terminated string.
    let t = unsafe { CStr::from_ptr(kdray_status_text(KdrayStatus::NotSimilar as i32)) };
    assert!(t.to_str().unwrap().contains("unevenly"));

    // A scene with an instance squashed along y: refused for a mask that
    // selects it, nothing written; answered for one that does not.
    use kdray_tools::instances::{build_scene, placement, sphere};
    let squash = placement([0.0, 0.0, 1.0], 0.0, [1.0, 0.5, 1.0], [4.0, 0.0, 0.0]);
    let insts = [
        kdray_kernel::Instance::new(0, kdray_kernel::IDENTITY, 0, 1).unwrap(),
        kdray_kernel::Instance::new(0, squash, 1, 2).unwrap(),
    ];
    let parts = build_scene(
        &[sphere(4, 6)],
        insts.to_vec(),
        Default::default(),
        &Default::default(),
    )
    .unwrap();
    let blob = parts.write().unwrap();
    let mut sh = KdrayScene {
        opaque: [0; KDRAY_HANDLE_WORDS],
    };
    // SAFETY: a live handle and blob, no message buffer.
    let s = unsafe {
        kdray_scene_open(
            &mut sh,
            blob.as_bytes().as_ptr(),
            blob.as_bytes().len(),
            core::ptr::null_mut(),
            0,
        )
    };
    assert_eq!(s, KdrayStatus::Ok);
    let mut untouched = KdraySceneClosestPoint::zeroed();
    for (mask, want) in [
        (u32::MAX, KdrayStatus::NotSimilar),
        (2, KdrayStatus::NotSimilar),
        (1, KdrayStatus::Ok),
    ] {
        untouched.prim_id = 77;
        // SAFETY: live handle and records.
        let s =
            unsafe { kdray_scene_closest_point(&sh, qs[0].as_ptr(), mask, 100.0, &mut untouched) };
        assert_eq!(s, want, "mask {mask}");
        assert_eq!(untouched.prim_id == 77, want == KdrayStatus::NotSimilar);
    }
}

#[test]
fn treelets_give_a_batch_the_same_answers() {
    // A tree of several levels (the cube is one leaf): a soup of small
    // triangles, its blob kept for the handle's life.
    let mut state = 0x9E37_79B9_u32;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        (state >> 8) as f32 / (1 << 24) as f32
    };
    let tris: Vec<kdray_kernel::Triangle> = (0..3000)
        .map(|_| {
            let c = [next(), next(), next()];
            kdray_kernel::Triangle {
                v: core::array::from_fn(|_| core::array::from_fn(|a| c[a] + 0.05 * next())),
            }
        })
        .collect();
    let built = kdray_tools::builders::build(
        &tris,
        kdray_tools::builders::BuilderKind::default(),
        &kdray_tools::builders::BuildParams::default(),
    )
    .unwrap();
    let blob: &'static kdray_tools::blob::Blob = std::boxed::Box::leak(std::boxed::Box::new(
        kdray_tools::blob::write_triangle_tree(&built, &tris).unwrap(),
    ));
    let bytes = blob.as_bytes();
    let mut tree = CLOSED;
    // SAFETY: a live handle and a blob that lives as long as the test.
    let s = unsafe {
        kdray_triangles_open(
            &mut tree,
            bytes.as_ptr(),
            bytes.len(),
            core::ptr::null_mut(),
            0,
        )
    };
    assert_eq!(s, KdrayStatus::Ok);
    let rays = rays();
    let mut want = std::vec![KdrayHit::zeroed(); rays.len()];
    // SAFETY: `rays.len()` records each.
    let s = unsafe {
        kdray_closest_hits(
            &tree,
            rays.as_ptr(),
            want.as_mut_ptr(),
            rays.len(),
            ptr::null(),
        )
    };
    assert_eq!(s, KdrayStatus::Ok);
    let mut needed = 0;
    // SAFETY: asking the count (null lines, capacity 0).
    let s = unsafe { kdray_triangles_treelets(&mut tree, core::ptr::null_mut(), 0, &mut needed) };
    assert_eq!((s, needed > 1), (KdrayStatus::BufferTooSmall, true));
    let lines: &'static mut [kdray_kernel::Treelet] = std::vec![Default::default(); needed].leak();
    let at = lines.as_mut_ptr().cast::<KdrayTreelet>();
    // SAFETY: `needed` records, 64-byte aligned (the kernel's `Treelet`),
    // alive for the test; a misaligned pointer is refused first.
    unsafe {
        let off = at.cast::<u8>().add(4).cast::<KdrayTreelet>();
        let s = kdray_triangles_treelets(&mut tree, off, needed, &mut needed);
        assert_eq!(s, KdrayStatus::Misaligned);
        assert_eq!(
            kdray_triangles_treelets(&mut tree, at, needed, &mut needed),
            KdrayStatus::Ok
        );
    }
    let mut got = std::vec![KdrayHit::zeroed(); rays.len()];
    // SAFETY: as above.
    let s = unsafe {
        kdray_closest_hits(
            &tree,
            rays.as_ptr(),
            got.as_mut_ptr(),
            rays.len(),
            ptr::null(),
        )
    };
    assert_eq!(s, KdrayStatus::Ok);
    assert_eq!(got, want);
}

#[test]
fn distance_queries_are_the_kernels_and_bad_arguments_are_codes() {
    let h = open_cube();
    let tree = TriangleTree::from_bytes(&CUBE.bytes).unwrap();
    let pts: Vec<[f32; 3]> = rays()
        .iter()
        .map(|r| [r.org_x, r.org_y, r.org_z])
        .chain([[f32::NAN, 0.0, 0.0], [0.5, 0.5, -2.0]])
        .collect();
    let n = pts.len();
    let mut out = std::vec![KdrayClosestPoint::zeroed(); n];
    let mut signed = std::vec![0f32; n];
    // SAFETY: live handle, `n` points and records.
    unsafe {
        assert_eq!(
            kdray_closest_points(&h, pts.as_ptr().cast(), n, 0.75, out.as_mut_ptr()),
            KdrayStatus::Ok
        );
        assert_eq!(
            kdray_signed_distances(&h, pts.as_ptr().cast(), n, 1, signed.as_mut_ptr()),
            KdrayStatus::Ok
        );
    }
    for (i, q) in pts.iter().enumerate() {
        let want = tree.closest_point_within(*q, 0.75);
        let got = out[i];
        match want {
            Some(c) => assert_eq!(
                (
                    got.x,
                    got.y,
                    got.z,
                    got.prim_id,
                    got.u,
                    got.v,
                    got.distance2
                ),
                (
                    c.point[0],
                    c.point[1],
                    c.point[2],
                    c.prim,
                    c.u,
                    c.v,
                    c.distance2
                ),
                "point {i}"
            ),
            None => assert_eq!(got.prim_id, KDRAY_MISS, "point {i}"),
        }
        let mut one = 0f32;
        // SAFETY: live handle, one point, one float.
        unsafe {
            assert_eq!(
                kdray_signed_distance(&h, q.as_ptr(), 1, &mut one),
                KdrayStatus::Ok
            )
        };
        assert_eq!(one.to_bits(), signed[i].to_bits(), "point {i}");
        let d = tree
            .closest_point(*q)
            .map_or(f32::NAN, |c| c.distance2.sqrt() as f32);
        let want = if tree.contains(*q) { -d } else { d };
        assert_eq!(signed[i].to_bits(), want.to_bits(), "point {i}");
    }
    assert!(out[n - 2].distance2.is_nan());
    assert_eq!(signed[n - 1], 2.0);
    // Null, misaligned, unopened.
    let mut one = KdrayClosestPoint::zeroed();
    let q = [0.0f32; 4];
    // SAFETY: each call is refused before it reads or writes.
    unsafe {
        assert_eq!(
            kdray_closest_point(&h, core::ptr::null(), 1.0, &mut one),
            KdrayStatus::NullPointer
        );
        assert_eq!(
            kdray_closest_point(&h, q.as_ptr().cast::<u8>().add(1).cast(), 1.0, &mut one),
            KdrayStatus::Misaligned
        );
        assert_eq!(
            kdray_closest_point(&CLOSED, q.as_ptr(), 1.0, &mut one),
            KdrayStatus::NotOpen
        );
        assert_eq!(
            kdray_signed_distances(&h, q.as_ptr(), usize::MAX, 1, core::ptr::null_mut()),
            KdrayStatus::NullPointer
        );
        let mut f = 0f32;
        assert_eq!(
            kdray_signed_distances(&h, q.as_ptr(), usize::MAX, 1, &mut f),
            KdrayStatus::BadSize
        );
    }
}
