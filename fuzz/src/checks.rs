//! Fuzz properties over arbitrary bytes. Decoding never fails: missing
//! bytes read as zero, so every input is a test case.
//!
//! - [`blob`]: arbitrary bytes, or a valid header (correct checksum) and
//!   arbitrary sections: `from_bytes` returns an error or a view, and with
//!   a view tracing rays (single and packets) and the distance queries
//!   (closest point, crossings, inside) never panic.
//! - [`packet_vs_single`]: a small scene, coordinates mostly on a coarse
//!   grid (hits on edges, vertices and split planes) plus raw floats;
//!   packets of hostile rays with inactive lanes: lanes == single rays.
//!   With 1 to 8 bits flipped after (mode bit 1), 1 to 3 are always
//!   refused (the CRC-32C checksum).
//! - [`scene_blob`]: a valid scene blob with bytes overwritten (checksum
//!   resealed or not) or 1 to 8 bits flipped (1 to 3 always refused), or
//!   arbitrary bytes: an error or a scene whose answers are its brute
//!   force's.
//! - [`tree_vs_brute`]: the same scenes with every builder: the tree's
//!   closest hit is the brute-force one bit for bit, any hit agrees; the
//!   closest point to each ray's origin and the crossings along it are
//!   brute force's.
//! - [`deforming`]: the same scenes moved over a few frames, a kept
//!   deforming mesh's tree against brute force each frame.
//! - [`distance`]: query points (NaN, infinities, extremes) and maximum
//!   distances (negative, NaN, infinite): on small scenes built by every
//!   builder the closest point within the maximum and the (winding)
//!   crossings are brute force's; on a scene of instances (uniform
//!   scales, mirrors; or uneven, refused) the top-level walk's closest
//!   point is brute force's; on an edited or arbitrary blob every query
//!   returns.

use kdray::kernel::format::wire::{
    blob_checksum, Header, ENDIAN_CHECK, KIND_TRIANGLES, MAGIC, VERSION,
};
use kdray::kernel::{
    any_hit_brute, closest_hit_brute, closest_point_brute, crossings_brute, first_hits_brute,
    winding_crossings_brute, Batch, Hit, MortonGrid, Node, Packet, Packet4, Packet8, PacketWidth,
    Ray, RayKey, SceneHit, ShallowTree, Streams, Treelet, Trial, Triangle, TriangleTree,
    STREAM_SCRATCH_WORDS,
};
use kdray::tools::blob::{write_triangle_tree, Blob};
use kdray::tools::builders::{build, BuildParams, BuilderKind};

/// Reads the fuzz input front to back; zeros past its end.
pub struct Bytes<'a> {
    data: &'a [u8],
}

impl<'a> Bytes<'a> {
    /// A reader over `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Bytes { data }
    }

    /// The next byte.
    pub fn u8(&mut self) -> u8 {
        let (&b, rest) = self.data.split_first().unwrap_or((&0, &[]));
        self.data = rest;
        b
    }

    /// The next four bytes, little-endian.
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }

    /// What is left.
    pub fn rest(&self) -> &'a [u8] {
        self.data
    }

    /// A vertex coordinate: mostly a multiple of 1/4 in [-8, 8), else raw
    /// finite bits (non-finite raw values become 0: builders refuse them).
    pub fn coord(&mut self) -> f32 {
        let b = self.u8();
        if b < 224 {
            (f32::from(b % 64) - 32.0) / 4.0
        } else {
            let x = f32::from_bits(self.u32());
            if x.is_finite() {
                x
            } else {
                0.0
            }
        }
    }

    /// A ray component: grid values, the special values (NaN, ±0, ±inf,
    /// subnormals, extremes) or raw bits.
    pub fn component(&mut self) -> f32 {
        const SPECIAL: [f32; 12] = [
            0.0,
            -0.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e-45,
            -1e-45,
            1e-39,
            f32::MIN_POSITIVE,
            f32::MAX,
            f32::MIN,
            1.0,
        ];
        let b = self.u8();
        match b {
            0..=159 => (f32::from(b % 80) - 40.0) / 4.0,
            160..=223 => SPECIAL[usize::from(b) % SPECIAL.len()],
            _ => f32::from_bits(self.u32()),
        }
    }

    /// A ray; `tmin`/`tmax` mostly `[0, inf]`.
    pub fn ray(&mut self) -> Ray {
        let origin = [self.component(), self.component(), self.component()];
        let dir = [self.component(), self.component(), self.component()];
        let range = self.u8();
        let (tmin, tmax) = if range < 192 {
            (0.0, f32::INFINITY)
        } else {
            (self.component(), self.component())
        };
        Ray {
            origin,
            tmin,
            dir,
            tmax,
        }
    }

    /// Up to 24 triangles.
    pub fn scene(&mut self) -> Vec<Triangle> {
        let n = usize::from(self.u8() % 24) + 1;
        (0..n)
            .map(|_| Triangle {
                v: std::array::from_fn(|_| std::array::from_fn(|_| self.coord())),
            })
            .collect()
    }

    /// A packet: a lane mask byte (two for more than 8 lanes), then the
    /// active lanes' rays.
    pub fn packet<const N: usize>(&mut self) -> Packet<N> {
        let mut mask = u32::from(self.u8());
        if N > 8 {
            mask |= u32::from(self.u8()) << 8;
        }
        let mut p = Packet::EMPTY;
        for l in 0..N {
            if mask >> l & 1 == 1 {
                p.set_ray(l, &self.ray());
            }
        }
        p
    }
}

/// Blob loading and tracing never panic.
pub fn blob(data: &[u8]) {
    let mut r = Bytes::new(data);
    let mode = r.u8();
    let bytes = if mode & 1 == 0 {
        r.rest().to_vec()
    } else {
        // A header the loader accepts up to the sections' contents.
        let (node_count, index_count, item_count) = (r.u8(), r.u8(), r.u8());
        let max_depth = u32::from(r.u8() % 72);
        let bounds_min = [r.coord(), r.coord(), r.coord()];
        let bounds_max = [r.coord(), r.coord(), r.coord()];
        let body = r.rest();
        let header = Header {
            magic: MAGIC,
            endian: ENDIAN_CHECK,
            version: VERSION,
            kind: KIND_TRIANGLES,
            max_depth,
            node_count: u32::from(node_count),
            index_count: u32::from(index_count),
            item_count: u32::from(item_count),
            checksum: 0,
            bounds_min,
            bounds_max,
        };
        let mut b = bytemuck::bytes_of(&header).to_vec();
        b.extend_from_slice(body);
        // Node 1 is the treelet layout's padding: put it in place, or
        // random bodies would nearly all stop at `BadPadding`.
        if let Some(pad) = b.get_mut(72..80) {
            pad.copy_from_slice(bytemuck::bytes_of(&Node::EMPTY_LEAF));
        }
        // The checksum covers the whole blob, its own field read as zero.
        let sum = Header {
            checksum: blob_checksum(&b),
            ..header
        };
        b[..64].copy_from_slice(bytemuck::bytes_of(&sum));
        b
    };
    let mut bytes = bytes;
    let flipped = if mode & 2 != 0 {
        flip_bits(&mut r, &mut bytes)
    } else {
        0
    };
    let blob = Blob::from_bytes(&bytes);
    let Ok(tree) = TriangleTree::from_bytes(blob.as_bytes()) else {
        return;
    };
    assert!(
        flipped == 0 || flipped > 3,
        "{flipped} flipped bits passed the checksum"
    );
    // Rays from the body's bytes (the tail doubles as ray data).
    let mut rays = Bytes::new(&bytes[bytes.len().min(64)..]);
    for _ in 0..8 {
        let ray = rays.ray();
        let _ = (tree.closest_hit(&ray), tree.any_hit(&ray));
        let _ = (
            tree.closest_point_within(ray.origin, ray.tmax),
            tree.contains_voting(ray.origin, 3),
            tree.crossings(ray.origin, ray.dir),
        );
        let p: Packet8 = rays.packet();
        let _ = (
            tree.closest_hit_packet(&p),
            tree.any_hit_packet(&Packet4::from_rays(&[ray])),
        );
    }
}

/// Builds `tris` with `kind`; `None` when the builder refuses them.
fn blob_of(tris: &[Triangle], kind: BuilderKind) -> Option<Blob> {
    let built = build(tris, kind, &BuildParams::default()).ok()?;
    write_triangle_tree(&built, tris).ok()
}

/// Asserts every lane of `p` equals its single ray, bit for bit (inactive
/// lanes: a miss).
pub fn assert_lanes<const N: usize>(
    tree: &TriangleTree,
    p: &Packet<N>,
    hits: [Hit; N],
    any: [bool; N],
) {
    for l in 0..N {
        let r = p.ray(l);
        let (want, want_any) = match p.valid[l] {
            true => (tree.closest_hit(&r), tree.any_hit(&r)),
            false => (Hit::MISS, false),
        };
        assert_eq!(
            hits[l].bits(),
            want.bits(),
            "closest, lane {l} of {N}: {r:?}"
        );
        assert_eq!(any[l], want_any, "any, lane {l} of {N}: {r:?}");
    }
}

/// Every lane of every packet equals its single ray, bitwise.
pub fn packet_vs_single(data: &[u8]) {
    let mut r = Bytes::new(data);
    let tris = r.scene();
    let Some(blob) = blob_of(&tris, BuilderKind::default()) else {
        return;
    };
    let tree = blob.tree().expect("the builder's blob validates");
    while !r.rest().is_empty() {
        // Bits 0 and 2: the width; bit 1: direction signs made to agree,
        // so the lanes walk together (packets with mixed signs go lane by
        // lane).
        let how = r.u8();
        let shared = how & 2 != 0;
        match how & 5 {
            0 => packet_lanes(
                &tree,
                &mut r,
                shared,
                TriangleTree::closest_hit_packet::<8>,
                TriangleTree::any_hit_packet::<8>,
            ),
            1 => packet_lanes(
                &tree,
                &mut r,
                shared,
                TriangleTree::closest_hit_packet::<4>,
                TriangleTree::any_hit_packet::<4>,
            ),
            _ => packet_lanes(
                &tree,
                &mut r,
                shared,
                TriangleTree::closest_hit_packet::<16>,
                TriangleTree::any_hit_packet::<16>,
            ),
        }
    }
}

/// Reads one packet of `N` lanes (signs made to agree when `shared`) and
/// checks its lanes, traced by `closest` and `any`, against single rays.
fn packet_lanes<'t, const N: usize>(
    tree: &TriangleTree<'t>,
    r: &mut Bytes,
    shared: bool,
    closest: fn(&TriangleTree<'t>, &Packet<N>) -> [Hit; N],
    any: fn(&TriangleTree<'t>, &Packet<N>) -> [bool; N],
) {
    let mut p: Packet<N> = r.packet();
    if shared {
        share_signs(&mut p);
    }
    assert_lanes(tree, &p, closest(tree, &p), any(tree, &p));
    // The same rays through the slice entry points, each block's walk
    // forced to each candidate (coherent blocks: packets, single rays;
    // scattered ones: single rays, in turns or packets), and timed.
    let rays: Vec<Ray> = (0..N).map(|l| p.ray(l)).collect();
    let mut hits = vec![Hit::MISS; N];
    let mut occ = vec![false; N];
    for trial in [Trial::First, Trial::Second, Trial::Timed] {
        tree.closest_hits(
            &rays,
            &mut hits,
            Batch {
                trial,
                ..Batch::default()
            },
        );
        tree.any_hits(
            &rays,
            &mut occ,
            Batch {
                trial,
                ..Batch::default()
            },
        );
        for ((ray, h), o) in rays.iter().zip(&hits).zip(&occ) {
            assert_eq!(
                h.bits(),
                tree.closest_hit(ray).bits(),
                "slice {trial:?}: {ray:?}"
            );
            assert_eq!(*o, tree.any_hit(ray), "slice any {trial:?}: {ray:?}");
        }
    }
    // And in the Morton order of their origins (hostile origins: NaN,
    // infinite, far apart), answers in their slots.
    let mut by_origin = vec![false; N];
    let mut scratch = vec![0u64; 2 * N];
    tree.any_hits(
        &rays,
        &mut by_origin,
        Batch {
            width: Some(PacketWidth::Eight),
            scratch: &mut scratch,
            ..Batch::default()
        },
    );
    for (((ray, h), o), b) in rays.iter().zip(&hits).zip(&occ).zip(&by_origin) {
        assert_eq!(h.bits(), tree.closest_hit(ray).bits(), "slice: {ray:?}");
        assert_eq!(*o, tree.any_hit(ray), "slice any: {ray:?}");
        assert_eq!(*b, *o, "by origin: {ray:?}");
    }
    // As ray streams, with room for every stream and with room for few
    // (those go on as single rays from their node).
    for words in [STREAM_SCRATCH_WORDS, 3 * N / 2] {
        let mut scratch = vec![0u64; words];
        let (mut sh, mut so) = (vec![Hit::MISS; N], vec![false; N]);
        for any in [false, true] {
            let batch = Batch {
                scratch: &mut scratch,
                streams: Streams::Always,
                ..Batch::default()
            };
            if any {
                tree.any_hits(&rays, &mut so, batch);
            } else {
                tree.closest_hits(&rays, &mut sh, batch);
            }
        }
        let bits = |h: &[Hit]| h.iter().map(Hit::bits).collect::<Vec<_>>();
        assert_eq!(bits(&sh), bits(&hits), "streams, {words} words");
        assert_eq!(so, occ, "streams any, {words} words");
    }
    // Their keys by origin and direction (what `kdray trace --order
    // morton` sorts closest hits by): below 2^30, or 2^30 for a ray with a
    // non-finite coordinate.
    let grid = MortonGrid::over_rays(&rays, RayKey::OriginDirection);
    for ray in &rays {
        let finite = ray.origin.iter().chain(&ray.dir).all(|c| c.is_finite());
        let key = grid.ray_key(ray);
        assert!(
            if finite {
                key < 1 << 30
            } else {
                key == 1 << 30
            },
            "key {key:x}: {ray:?}"
        );
    }
}

/// Gives every lane's direction lane 0's signs, keeping the magnitudes
/// (NaN, infinities, zeros and subnormals stay).
pub fn share_signs<const N: usize>(p: &mut Packet<N>) {
    for d in &mut p.dir {
        let sign = d[0];
        for x in d.iter_mut() {
            *x = x.copysign(sign);
        }
    }
}

/// The tree of every builder answers as brute force, bitwise.
pub fn tree_vs_brute(data: &[u8]) {
    let mut r = Bytes::new(data);
    let tris = r.scene();
    let blobs: Vec<(BuilderKind, Blob)> = BuilderKind::ALL
        .iter()
        .filter_map(|&k| Some((k, blob_of(&tris, k)?)))
        .collect();
    let trees: Vec<(BuilderKind, TriangleTree)> = blobs
        .iter()
        .map(|(k, b)| (*k, b.tree().expect("the builder's blob validates")))
        .collect();
    let (mut rays, mut wants) = (Vec::new(), Vec::new());
    while !r.rest().is_empty() {
        let ray = r.ray();
        let want = closest_hit_brute(&tris, &ray);
        rays.push(ray);
        wants.push(want);
        let want_any = any_hit_brute(&tris, &ray);
        // The first 4 hits: sorted, each triangle once, led by the closest.
        let mut first = [Hit::MISS; 4];
        let n = first_hits_brute(&tris, &ray, &mut first);
        assert_eq!(
            first[0].bits(),
            want.bits(),
            "first hits lead with the closest"
        );
        for (kind, tree) in &trees {
            let got = tree.closest_hit(&ray);
            assert_eq!(got.bits(), want.bits(), "{kind:?}: {ray:?} {tris:?}");
            assert_eq!(tree.any_hit(&ray), want_any, "{kind:?} any: {ray:?}");
            let mut got = [Hit::MISS; 4];
            assert_eq!(
                tree.first_hits(&ray, &mut got),
                n,
                "{kind:?} first: {ray:?}"
            );
            assert_eq!(
                got.map(|h| h.bits()),
                first.map(|h| h.bits()),
                "{kind:?} first"
            );
            // The ray's origin as a distance query (within its tmax as
            // the maximum distance) and its direction for the crossings.
            let q = ray.origin;
            assert_eq!(
                tree.closest_point_within(q, ray.tmax).map(|c| c.bits()),
                closest_point_brute(&tris, q, ray.tmax).map(|c| c.bits()),
                "{kind:?} closest point: {q:?} within {}",
                ray.tmax
            );
            assert_eq!(
                tree.crossings(q, ray.dir),
                crossings_brute(&tris, q, ray.dir),
                "{kind:?} crossings: {ray:?}"
            );
            // The depth-bounded walk, for the trees it takes (most here).
            if let Ok(shallow) = ShallowTree::<16>::new(*tree) {
                let got = shallow.closest_hit(&ray);
                assert_eq!(got.bits(), want.bits(), "{kind:?} shallow: {ray:?}");
                assert_eq!(shallow.any_hit(&ray), want_any, "{kind:?} shallow any");
            }
        }
    }
    // All the rays walked in turns through the treelets (7 planes a step).
    for (kind, tree) in &trees {
        let mut lines = vec![Treelet::default(); tree.treelet_count()];
        let lined = tree
            .treelets_into(&mut lines)
            .expect("room for every treelet");
        let mut got = vec![Hit::MISS; rays.len()];
        lined.closest_hits(&rays, &mut got, Batch::default());
        for ((ray, want), got) in rays.iter().zip(&wants).zip(&got) {
            assert_eq!(
                got.bits(),
                want.bits(),
                "{kind:?} treelets: {ray:?} {tris:?}"
            );
        }
    }
}

/// A deforming mesh's kept tree (`DeformingMesh`) answers as brute force
/// over each frame's triangles, bitwise, whether the frame refilled the
/// kept planes or rebuilt. Input: a scene, a frame count, then per frame a
/// move for each triangle (none, a shift along an axis, a new vertex, a
/// new coordinate) and four rays.
pub fn deforming(data: &[u8]) {
    use kdray::tools::deforming::DeformingMesh;
    let mut r = Bytes::new(data);
    let mut tris = r.scene();
    let Ok(mut mesh) = DeformingMesh::new(&tris, &BuildParams::default(), DeformingMesh::DRIFT)
    else {
        return; // beyond the coordinate range: refused, as by the builders
    };
    for _ in 0..r.u8() % 4 + 1 {
        for t in &mut tris {
            let b = r.u8();
            let (a, k) = (usize::from(b / 4 % 3), usize::from(b / 12 % 3));
            match b % 4 {
                0 => {}
                1 => {
                    let d = r.coord() / 16.0;
                    for p in &mut t.v {
                        p[a] += d;
                    }
                }
                2 => t.v[k] = [r.coord(), r.coord(), r.coord()],
                _ => t.v[k][a] = r.coord(),
            }
        }
        if mesh.update(&tris).is_err() {
            return; // a move out of range: refused, the tree kept
        }
        let tree = mesh.view(&tris).expect("the kept tree validates");
        for _ in 0..4 {
            let ray = r.ray();
            let want = closest_hit_brute(&tris, &ray);
            assert_eq!(
                tree.closest_hit(&ray).bits(),
                want.bits(),
                "{ray:?} {tris:?}"
            );
            assert_eq!(
                tree.any_hit(&ray),
                any_hit_brute(&tris, &ray),
                "any: {ray:?}"
            );
        }
    }
}

/// A small valid scene blob: two meshes, a dozen instances with
/// rotations, scales and a mirror (built once per process).
fn scene_seed() -> &'static [u8] {
    use kdray::kernel::Instance;
    use kdray::tools::instances::{build_scene, placement, sphere, torus};
    static SEED: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    SEED.get_or_init(|| {
        let meshes = vec![sphere(4, 6), torus(6, 4)];
        let instances = (0..12)
            .filter_map(|k| {
                let s = if k % 5 == 0 {
                    -1.0
                } else {
                    1.0 + k as f32 * 0.1
                };
                let m = placement(
                    [1.0, k as f32, 0.5],
                    k as f32,
                    [s, 1.0, 0.7],
                    [k as f32, 0.0, -(k as f32)],
                );
                Instance::new(k % 2, m, k, 1 << (k % 3))
            })
            .collect();
        build_scene(
            &meshes,
            instances,
            BuilderKind::default(),
            &BuildParams::default(),
        )
        .and_then(|p| {
            p.write()
                .map_err(kdray::tools::instances::SceneBuildError::Write)
        })
        .map(|b| b.as_bytes().to_vec())
        .unwrap_or_default()
    })
}

/// Scene blob loading and tracing never panic, and the built scene
/// answers as its brute force: a valid scene blob, unedited or with bytes
/// overwritten where the input says (the checksum resealed when its first
/// byte is odd, so the structural checks behind it are reached), or
/// arbitrary bytes. Only the unedited scene is held to brute force: an
/// edit resealed under a new checksum can move a top-level split plane or
/// a mesh vertex out of the cells that list it, which leaves the blob
/// well formed (validation checks structure in O(n), not that every box
/// lies in the cells that reference it) and the walk then answers for
/// the tree it was given. Such a blob is what the checksum stops.
pub fn scene_blob(data: &[u8]) {
    use kdray::kernel::Scene;
    let mut r = Bytes::new(data);
    let mode = r.u8();
    let mut bytes = if mode & 2 == 0 {
        scene_seed().to_vec()
    } else {
        r.rest().to_vec()
    };
    let mut edited = mode & 2 != 0;
    let mut flipped = 0;
    if mode & 2 == 0 && !bytes.is_empty() {
        // Bit 6 (not 2: older regression inputs set bits 0 to 5).
        if mode & 0x40 == 0 {
            let edits = r.u8() % 8;
            overwrite(&mut r, &mut bytes, edits, mode & 1 == 1);
            edited |= edits > 0;
        } else {
            flipped = flip_bits(&mut r, &mut bytes);
            edited = true;
        }
    }
    let blob = Blob::from_bytes(&bytes);
    let Ok(scene) = Scene::from_bytes(blob.as_bytes()) else {
        return;
    };
    assert!(
        flipped == 0 || flipped > 3,
        "{flipped} flipped bits passed the checksum"
    );
    for _ in 0..8 {
        let ray = r.ray();
        let mask = r.u32() | 1;
        let mut first = [SceneHit::MISS; 3];
        if edited {
            let _ = (scene.closest_hit(&ray, mask), scene.any_hit(&ray, mask));
            let _ = scene.first_hits(&ray, mask, &mut first);
            continue;
        }
        let mut brute = [SceneHit::MISS; 3];
        let n = scene.first_hits(&ray, mask, &mut first);
        assert_eq!(n, scene.first_hits_brute(&ray, mask, &mut brute), "{ray:?}");
        assert_eq!(first.map(|h| h.bits()), brute.map(|h| h.bits()), "{ray:?}");
        assert_eq!(
            scene.closest_hit(&ray, mask).bits(),
            scene.closest_hit_brute(&ray, mask).bits(),
            "{ray:?}"
        );
        assert_eq!(
            scene.any_hit(&ray, mask),
            scene.any_hit_brute(&ray, mask),
            "{ray:?}"
        );
    }
}

/// A small valid scene blob of instances under similarities: two meshes,
/// sixteen instances rotated, uniformly scaled (one mirrored), two stacked
/// exactly (ties between instances); built once per process.
fn similar_scene_seed() -> &'static [u8] {
    use kdray::kernel::Instance;
    use kdray::tools::instances::{build_scene, placement, sphere, torus};
    static SEED: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    SEED.get_or_init(|| {
        let meshes = vec![sphere(4, 6), torus(6, 4)];
        let mut instances: Vec<Instance> = (0..16)
            .filter_map(|k| {
                let s = 0.5 + (k % 4) as f32 * 0.25;
                let mirror = if k % 5 == 0 { -s } else { s };
                let m = placement(
                    [1.0, k as f32, 0.5],
                    k as f32,
                    [mirror, s, s],
                    [(k % 4) as f32 * 2.0 - 3.0, (k / 4) as f32 * 2.0 - 3.0, 0.0],
                );
                Instance::new(k % 2, m, k, 1 << (k % 3))
            })
            .collect();
        instances.push(instances[3]);
        build_scene(
            &meshes,
            instances,
            BuilderKind::default(),
            &BuildParams::default(),
        )
        .and_then(|p| {
            p.write()
                .map_err(kdray::tools::instances::SceneBuildError::Write)
        })
        .map(|b| b.as_bytes().to_vec())
        .unwrap_or_default()
    })
}

/// A query point: grid values, special values or raw bits per coordinate.
fn query(r: &mut Bytes<'_>) -> [f32; 3] {
    [r.component(), r.component(), r.component()]
}

/// A maximum distance: mostly none (infinite), else any component value
/// (negative, NaN, zero, subnormal, huge).
fn max_distance(r: &mut Bytes<'_>) -> f32 {
    if r.u8() < 128 {
        f32::INFINITY
    } else {
        r.component()
    }
}

/// Distance queries never panic, and on valid trees and scenes they are
/// brute force's bit for bit. The mode byte picks the case (module docs):
/// 0 a small scene built by every builder; 1 a built tree's blob with
/// bytes overwritten (resealed when the next byte is odd); 2 arbitrary
/// bytes as a blob; 3 the instance scenes (unedited, held to brute force;
/// with bit 2 set, edited, only required to return).
pub fn distance(data: &[u8]) {
    use kdray::kernel::Scene;
    let mut r = Bytes::new(data);
    let mode = r.u8();
    match mode % 4 {
        0 => {
            let tris = r.scene();
            let blobs: Vec<Blob> = BuilderKind::ALL
                .iter()
                .filter_map(|&k| blob_of(&tris, k))
                .collect();
            for _ in 0..16 {
                if r.rest().is_empty() {
                    break;
                }
                let (q, max, dir) = (query(&mut r), max_distance(&mut r), query(&mut r));
                let want = closest_point_brute(&tris, q, max).map(|c| c.bits());
                let crossings = crossings_brute(&tris, q, dir);
                let winding = winding_crossings_brute(&tris, q, dir);
                for blob in &blobs {
                    let tree = blob.tree().expect("the builder's blob validates");
                    let got = tree.closest_point_within(q, max).map(|c| c.bits());
                    assert_eq!(got, want, "closest point {q:?} within {max}: {tris:?}");
                    let start = r.u32() % (tris.len() as u32 + 2);
                    let from = tree.closest_point_from(q, max, start).map(|c| c.bits());
                    assert_eq!(from, want, "from {start}: {q:?} within {max}");
                    assert_eq!(tree.crossings(q, dir), crossings, "{q:?} along {dir:?}");
                    assert_eq!(
                        tree.winding_crossings(q, dir),
                        winding,
                        "{q:?} along {dir:?}"
                    );
                    let _ = (tree.contains(q), tree.contains_voting(q, 3));
                }
            }
        }
        1 | 2 => {
            let mut bytes = if mode % 4 == 1 {
                let tris = r.scene();
                blob_of(&tris, BuilderKind::default())
                    .map_or_else(Vec::new, |b| b.as_bytes().to_vec())
            } else {
                r.rest().to_vec()
            };
            if mode % 4 == 1 && !bytes.is_empty() {
                let edits = r.u8() % 8;
                let reseal = r.u8() & 1 == 1;
                overwrite(&mut r, &mut bytes, edits, reseal);
            }
            let blob = Blob::from_bytes(&bytes);
            let Ok(tree) = TriangleTree::from_bytes(blob.as_bytes()) else {
                return;
            };
            let mut qs = Bytes::new(&bytes[bytes.len().min(64)..]);
            for _ in 0..8 {
                let (q, max, dir) = (query(&mut qs), max_distance(&mut qs), query(&mut qs));
                let _ = (
                    tree.closest_point_within(q, max),
                    tree.closest_point_from(q, max, qs.u32()),
                    tree.crossings(q, dir),
                    tree.winding_crossings(q, dir),
                    tree.contains_voting(q, 3),
                );
            }
        }
        _ => {
            let seed = if mode & 8 == 0 {
                similar_scene_seed()
            } else {
                // Uneven scales: refused alike.
                scene_seed()
            };
            let mut bytes = seed.to_vec();
            let edited = mode & 4 != 0 && !bytes.is_empty();
            if edited {
                let edits = r.u8() % 8 + 1;
                let reseal = r.u8() & 1 == 1;
                overwrite(&mut r, &mut bytes, edits, reseal);
            }
            let blob = Blob::from_bytes(&bytes);
            let Ok(scene) = Scene::from_bytes(blob.as_bytes()) else {
                return;
            };
            for _ in 0..8 {
                let (q, max, mask) = (query(&mut r), max_distance(&mut r), r.u32());
                let got = scene.closest_point_within(q, mask, max);
                if edited {
                    continue;
                }
                let limit = f64::from(max) * f64::from(max);
                let want = scene
                    .closest_point_brute(q, mask)
                    .map(|c| c.filter(|c| max >= 0.0 && c.distance2 <= limit));
                assert_eq!(
                    got.map(|c| c.map(|c| c.bits())),
                    want.map(|c| c.map(|c| c.bits())),
                    "{q:?} mask {mask:#x} within {max}"
                );
                assert_eq!(
                    got.is_err(),
                    scene.check_similar(mask).is_err() && q.iter().all(|c| c.is_finite())
                );
            }
        }
    }
}

/// Point trees (breadth-first blob, `kdray::kernel::PointTreeN`): points
/// from the input (on a coarse grid, so ties and piles are common) built
/// into a 3-D `f32` or a 2-D `f64` tree; unedited, every query equals
/// brute force bit for bit; with bytes of the blob overwritten (checksum
/// resealed when the mode's bit 0 is set), loading returns an error or a
/// tree, and neither a checked nor an unchecked load ever panics or hangs
/// in a query; with 1 to 8 bits flipped instead (mode bit 3), 1 to 3 are
/// always refused by the checked load.
pub fn point_blob(data: &[u8]) {
    let mut r = Bytes::new(data);
    let mode = r.u8();
    if mode & 4 == 0 {
        point_blob_at::<3, f32>(&mut r, mode, |c| c);
    } else {
        point_blob_at::<2, f64>(&mut r, mode, f64::from);
    }
}

fn point_blob_at<const D: usize, S: kdray::kernel::Scalar>(
    r: &mut Bytes<'_>,
    mode: u8,
    of: impl Fn(f32) -> S,
) {
    use kdray::kernel::{knn_brute, Neighbour, PointTreeN};
    use kdray::tools::blob::write_point_tree;
    use kdray::tools::points::{build_points, PointParams};
    let n = usize::from(r.u8()) * 2;
    let points: Vec<[S; D]> = (0..n)
        .map(|_| std::array::from_fn(|_| of(f32::from(r.u8() % 8) / 2.0)))
        .collect();
    let params = PointParams {
        leaf_size: Some(usize::from(r.u8() % 16) + 1),
        ..PointParams::default()
    };
    let Ok(built) = build_points(&points, &params) else {
        return;
    };
    let Ok(blob) = write_point_tree(&built) else {
        return;
    };
    let mut bytes = blob.as_bytes().to_vec();
    let (edits, flipped) = if mode & 8 == 0 {
        let edits = r.u8() % 4;
        overwrite(r, &mut bytes, edits, mode & 1 == 1);
        (edits, 0)
    } else {
        let flipped = flip_bits(r, &mut bytes);
        (1, flipped)
    };
    let edited = Blob::from_bytes(&bytes);
    let queries: Vec<[S; D]> = (0..8)
        .map(|_| std::array::from_fn(|_| of(r.component())))
        .collect();
    let run = |tree: &PointTreeN<'_, D, S>| {
        let mut out = [Neighbour::NONE; 12];
        for q in &queries {
            let _ = tree.nearest(*q);
            let _ = tree.knn(*q, &mut out[..(r_k(q) % 12) + 1]);
            tree.for_each_within(*q, of(1.0), |_| {});
        }
    };
    if let Ok(tree) = PointTreeN::<D, S>::from_bytes_unchecked(edited.as_bytes()) {
        run(&tree);
    }
    let Ok(tree) = PointTreeN::<D, S>::from_bytes(edited.as_bytes()) else {
        assert!(edits > 0, "a freshly built point blob was refused");
        return;
    };
    assert!(
        flipped == 0 || flipped > 3,
        "{flipped} flipped bits passed the checksum"
    );
    run(&tree);
    if edits == 0 {
        for q in &queries {
            // Each way the answer buffer is kept: stepped up to 32,
            // scanned up to 128, the heap past it.
            for k in [1, 4, 12, 40, 150] {
                let (mut a, mut b) = ([Neighbour::NONE; 150], [Neighbour::NONE; 150]);
                let na = tree.knn(*q, &mut a[..k]);
                let nb = knn_brute(&points, *q, S::INFINITY, &mut b[..k]);
                assert_eq!(na, nb, "{q:?} k={k}");
                assert_eq!(
                    a.map(Neighbour::bits),
                    b.map(Neighbour::bits),
                    "{q:?} k={k}"
                );
            }
        }
    }
}

/// A k for query `q`, from its first coordinate's bits.
fn r_k<const D: usize, S: kdray::kernel::Scalar>(q: &[S; D]) -> usize {
    q.first().map_or(0, |c| (c.bits() % 97) as usize)
}

/// Flips 1 to 8 distinct bits of a blob (non-empty) where the input says,
/// the checksum left as it was; returns how many. CRC-32C catches every
/// error of up to 3 bits, so those blobs must be refused.
fn flip_bits(r: &mut Bytes<'_>, bytes: &mut [u8]) -> usize {
    let n = bytes.len() * 8;
    if n == 0 {
        return 0;
    }
    let k = usize::from(r.u8() % 8) + 1;
    let mut bits = [usize::MAX; 8];
    for slot in 0..k {
        // Distinct positions: a repeat would flip a bit back.
        let mut bit = r.u32() as usize % n;
        while bits[..slot].contains(&bit) {
            bit = (bit + 1) % n;
        }
        bits[slot] = bit;
        bytes[bit / 8] ^= 1 << (bit % 8);
    }
    k
}

/// Overwrites `edits` bytes of a blob (non-empty) where the input says,
/// then reseals its checksum if asked, so the structural checks behind it
/// are reached.
fn overwrite(r: &mut Bytes<'_>, bytes: &mut [u8], edits: u8, reseal: bool) {
    for _ in 0..edits {
        let at = r.u32() as usize % bytes.len();
        bytes[at] = r.u8();
    }
    if reseal {
        let sum = blob_checksum(bytes);
        bytes[36..40].copy_from_slice(&sum.to_le_bytes());
    }
}
