//! The builders' tuning thresholds, in one table. Each is a cell size (a
//! count of triangles) or a fraction; each doc says what it switches and
//! what the alternatives measured.
//!
//! | threshold | value | switches |
//! |---|---|---|
//! | [`PARALLEL_MIN`] | 4096 | cells this large tally and partition in parallel chunks |
//! | [`SMALL_MAX`] | 16 | cells below this find their plane by comparisons (`small`) |
//! | [`PERFECT_MIN`] | 16 | the SAH builder clips straddlers exactly from this size up |
//! | [`CUT_MIN`] | 32 | the binned builder cuts straddlers by the plane from this size up |
//! | [`MIN_GAIN`] | 0.1 | the binned builder splits only when it saves this fraction of a leaf |
//! | [`SWEEP_MAX`] | 4096 | the `sweep` builder bins above this size, sweeps events below |
//! | [`SWEEP_NONE`] | `SMALL_MAX` | the `sah` builder bins down to the small cells |
//! | [`FAST_BINS`] | 16 | bins per cell of the `fast` builder |
//! | [`FAST_LEAF_SIZE`] | 2 | cells the `fast` builder makes leaves without pricing |

/// Cells with at least this many triangles may parallelise their own
/// tallies and partitions, in chunks of this size.
pub(super) const PARALLEL_MIN: usize = 4096;

/// Cells with fewer triangles than this are small (module docs).
pub(super) const SMALL_MAX: usize = 16;

/// Cells with fewer triangles do not clip: a straddler's box is cut by the
/// plane ([`cut_box`](super::clip::cut_box)). Clipping there was a third of the binned build and
/// a fifth of the sweep's, and bought little: bunny tree cost, clipping
/// everywhere / from 16 triangles up / from 32: SAH 28.87 / 29.07 / 29.47
/// (263k / 170k / 159k nodes, build ~20% faster at 16), binned 29.22 /
/// 29.36 / 29.74 (never: 32.79); fandisk binned 24.30 / 24.45 / 24.76.
/// The SAH builder's threshold; the binned builder never clips, and cuts
/// triangles by the plane ([`cut_triangle`](super::clip::cut_triangle)) from [`CUT_MIN`].
pub(super) const PERFECT_MIN: usize = 16;

/// Cells of the binned builder with at least this many triangles cut a
/// straddling triangle by the plane (`clip::cut_triangle`), smaller ones
/// cut its box. The binned builder never clips exactly to the child cells
/// (perfect splits are the SAH builder's). Bunny tree cost / build (one
/// thread, no look-ahead, in-process): exact clipping from 16 up 29.37 /
/// 110 ms; from 1024 and cutting triangles from 16, 29.68 / 102 ms; only
/// cutting boxes 32.85 / 93 ms (the SAH builder's tree: 29.07). With the
/// cheaper cut, cutting from 16 / 24 / 32: 29.68 / 29.89 / 30.03 at 83 /
/// 80 / 76 ms (sponza 54.46 / 54.68 / 54.92, SAH 53.68, build -10% at
/// 32; 8 cuts more and builds more nodes: 29.61, +5%). Tried: clipping
/// exactly in cells of 1024 and more bought 0.2% /
/// 0.6% / 0.1% of tree cost on the bunny / sponza / 1M bunny (30.56 vs
/// 30.63, 56.47 vs 56.83, 34.37 vs 34.42) for 4-5% of the build (bunny,
/// one thread, best of 8 interleaved: 42.4 vs 40.4 ms).
pub(super) const CUT_MIN: usize = 32;

/// The binned builder splits a cell only where the split saves at least
/// this fraction of the leaf's cost (so it never looks ahead). Near the
/// leaves, splits saving less were half the tree: bunny / sponza / teapot
/// / 1M bunny tree cost with 0, 5% and 10%: 30.03 / 30.17 / 30.56, 54.92
/// / 55.36 / 56.47, 24.88 / 25.06 / 25.53, 34.03 / 34.12 / 34.37 (the SAH
/// builder's: 28.95, 53.34, 24.45, 33.33), nodes 142k / 104k / 72k on the
/// bunny, build -27% at 10%; the camera and random rays trace as fast
/// (bunny, within 1%). Look-ahead, which this rule replaces, bought 0.04%
/// of tree cost for 7% more nodes and ~10% more build.
pub(super) const MIN_GAIN: f64 = 0.1;

/// The `sweep` builder's cells with at least this many triangles pick
/// their plane by binning (module docs); smaller ones by the exact sweep.
pub(super) const SWEEP_MAX: usize = 4096;

/// The `sah` builder's `sweep_max`: no event cells, binning down to the
/// small cells (module docs).
pub(super) const SWEEP_NONE: usize = SMALL_MAX;

/// Bins per cell of the `fast` builder. Bunny: 8 bins, SAH cost 43.2
/// against 40.2 for 13% less build time.
pub(super) const FAST_BINS: usize = 16;

/// Cells of at most this many triangles are leaves in the `fast` builder.
pub(super) const FAST_LEAF_SIZE: usize = 2;
