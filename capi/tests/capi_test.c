/* The C API through its header, from C: bad arguments give status codes,
 * packets and streams answer as single rays bit for bit, point queries
 * answer as brute force; the rays, hits and k-nearest results are written
 * for capi/tests/run.sh to compare with the Rust API's (`kdray trace`,
 * `kdray knn`), byte for byte.
 *
 * usage: capi_test TRIANGLE_BLOB POINT_BLOB POINTS_PTS OUT_DIR SCENE_BLOB
 * writes OUT_DIR/{rays.rays, closest.hits, any.hits, queries.pts, knn5.knn}
 */
#include "kdray.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { RAYS = 1000, QUERIES = 64, K = 5 };

static int failures = 0;

#define CHECK(cond, ...)                                                       \
  do {                                                                         \
    if (!(cond)) {                                                             \
      fprintf(stderr, "%s:%d: check failed: %s: ", __FILE__, __LINE__, #cond); \
      fprintf(stderr, __VA_ARGS__);                                            \
      fprintf(stderr, "\n");                                                   \
      failures++;                                                              \
    }                                                                          \
  } while (0)

/* The whole file in malloc'd (so 16-byte aligned) memory. */
static uint8_t *read_file(const char *path, size_t *len) {
  FILE *f = fopen(path, "rb");
  if (!f) {
    fprintf(stderr, "cannot open %s\n", path);
    exit(2);
  }
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  uint8_t *buf = malloc(n > 0 ? (size_t)n : 1);
  if (!buf || fread(buf, 1, (size_t)n, f) != (size_t)n) {
    fprintf(stderr, "cannot read %s\n", path);
    exit(2);
  }
  fclose(f);
  *len = (size_t)n;
  return buf;
}

static void write_file(const char *dir, const char *name, const void *data, size_t len) {
  char path[4096];
  snprintf(path, sizeof path, "%s/%s", dir, name);
  FILE *f = fopen(path, "wb");
  if (!f || fwrite(data, 1, len, f) != len || fclose(f) != 0) {
    fprintf(stderr, "cannot write %s\n", path);
    exit(2);
  }
}

/* xorshift32, mapped to [lo, lo + span). */
static uint32_t rng = 0x2545F491u;
static float uniform(float lo, float span) {
  rng ^= rng << 13;
  rng ^= rng >> 17;
  rng ^= rng << 5;
  return lo + span * ((float)(rng >> 8) / 16777216.0f);
}

static void check_arguments(const uint8_t *blob, size_t len) {
  KdrayTriangleTree tree;
  KdrayHit hit;
  KdrayRay ray = {0.5f, 0.5f, -1.0f, 0.0f, 0.0f, 0.0f, 1.0f, INFINITY};
  char msg[256];

  /* A corrupt byte: refused, with what and where. */
  uint8_t *bad = malloc(len);
  memcpy(bad, blob, len);
  bad[100] ^= 1;
  KdrayStatus s = kdray_triangles_open(&tree, bad, len, msg, sizeof msg);
  CHECK(s == KDRAY_STATUS_INVALID_BLOB, "status %d", (int)s);
  CHECK(strstr(msg, "checksum") != NULL, "message \"%s\"", msg);
  CHECK(kdray_closest_hit(&tree, &ray, &hit) == KDRAY_STATUS_NOT_OPEN, "a failed open leaves no tree");
  free(bad);

  /* Misaligned and truncated blobs are the kernel's errors. */
  uint8_t *shifted = malloc(len + 1);
  memcpy(shifted + 1, blob, len);
  s = kdray_triangles_open(&tree, shifted + 1, len, msg, sizeof msg);
  CHECK(s == KDRAY_STATUS_INVALID_BLOB && strstr(msg, "align") != NULL, "%d \"%s\"", (int)s, msg);
  free(shifted);
  s = kdray_triangles_open(&tree, blob, 10, msg, sizeof msg);
  CHECK(s == KDRAY_STATUS_INVALID_BLOB && strstr(msg, "header") != NULL, "%d \"%s\"", (int)s, msg);

  /* Null pointers and a too-small message buffer (NUL-terminated, cut). */
  s = kdray_triangles_open(&tree, NULL, len, msg, sizeof msg);
  CHECK(s == KDRAY_STATUS_NULL_POINTER, "status %d", (int)s);
  CHECK(strcmp(msg, kdray_status_text(s)) == 0, "message \"%s\"", msg);
  char tiny[6];
  memset(tiny, 'x', sizeof tiny);
  s = kdray_triangles_open(NULL, blob, len, tiny, sizeof tiny);
  CHECK(s == KDRAY_STATUS_NULL_POINTER && strlen(tiny) == 5, "%d \"%s\"", (int)s, tiny);
  CHECK(kdray_triangles_open(&tree, blob, len, NULL, 0) == KDRAY_STATUS_OK, "open");
  CHECK(kdray_closest_hit(&tree, NULL, &hit) == KDRAY_STATUS_NULL_POINTER, "null ray");
  CHECK(kdray_closest_hit(&tree, &ray, NULL) == KDRAY_STATUS_NULL_POINTER, "null hit");
  CHECK(kdray_closest_hit(NULL, &ray, &hit) == KDRAY_STATUS_NULL_POINTER, "null tree");

  /* Misaligned records and an unopened (zeroed) handle. */
  _Alignas(8) uint8_t raw[sizeof(KdrayRay) + 8] = {0};
  CHECK(kdray_closest_hit(&tree, (const KdrayRay *)(raw + 2), &hit) == KDRAY_STATUS_MISALIGNED, "odd ray");
  KdrayTriangleTree zeroed;
  memset(&zeroed, 0, sizeof zeroed);
  CHECK(kdray_closest_hit(&zeroed, &ray, &hit) == KDRAY_STATUS_NOT_OPEN, "zeroed handle");
  CHECK(kdray_closest_hits(&tree, &ray, &hit, SIZE_MAX / 8, NULL) == KDRAY_STATUS_BAD_SIZE, "huge count");

  /* The ray above enters the cube's z = 0 face: t = 1. */
  CHECK(kdray_closest_hit(&tree, &ray, &hit) == KDRAY_STATUS_OK && hit.t == 1.0f, "t %g", hit.t);

  /* Half a unit below the cube's floor: the point straight above, at
     distance 0.5; the cube's centre is inside (negative). */
  const float below[3] = {0.25f, 0.5f, -0.5f}, centre[3] = {0.5f, 0.5f, 0.5f};
  KdrayClosestPoint cp;
  CHECK(kdray_closest_point(&tree, below, INFINITY, &cp) == KDRAY_STATUS_OK && cp.x == 0.25f &&
            cp.y == 0.5f && cp.z == 0.0f && cp.distance2 == 0.25,
        "closest point (%g %g %g) d2 %g", cp.x, cp.y, cp.z, cp.distance2);
  CHECK(kdray_closest_point(&tree, below, 0.1f, &cp) == KDRAY_STATUS_OK && cp.prim_id == KDRAY_MISS,
        "beyond the maximum distance");
  float sd;
  CHECK(kdray_signed_distance(&tree, below, 1, &sd) == KDRAY_STATUS_OK && sd == 0.5f, "sd %g", sd);
  CHECK(kdray_closest_point(&tree, NULL, INFINITY, &cp) == KDRAY_STATUS_NULL_POINTER, "null point");
  CHECK(kdray_signed_distances(&tree, centre, 1, 3, NULL) == KDRAY_STATUS_NULL_POINTER, "null out");
}

/* Packets of N rays (every third lane inactive) against the single-ray hits. */
#define CHECK_PACKETS(N)                                                                     \
  do {                                                                                       \
    for (int p = 0; p + (N) <= RAYS; p += (N)) {                                             \
      KdrayRay##N r;                                                                         \
      KdrayHit##N h;                                                                         \
      int32_t valid[N], occ[N];                                                              \
      for (int l = 0; l < (N); l++) {                                                        \
        const KdrayRay *x = &rays[p + l];                                                    \
        r.org_x[l] = x->org_x, r.org_y[l] = x->org_y, r.org_z[l] = x->org_z;                 \
        r.dir_x[l] = x->dir_x, r.dir_y[l] = x->dir_y, r.dir_z[l] = x->dir_z;                 \
        r.tnear[l] = x->tnear, r.tfar[l] = x->tfar;                                          \
        valid[l] = (p + l) % 3 == 0 ? 0 : -1;                                                \
      }                                                                                      \
      CHECK(kdray_closest_hit##N(valid, &tree, &r, &h) == KDRAY_STATUS_OK, "packet %d", p);  \
      CHECK(kdray_any_hit##N(valid, &tree, &r, occ) == KDRAY_STATUS_OK, "packet %d", p);     \
      for (int l = 0; l < (N); l++) {                                                        \
        KdrayHit want = valid[l] ? closest[p + l] : miss;                                    \
        KdrayHit got = {h.t[l], h.prim_id[l], h.u[l], h.v[l]};                               \
        CHECK(memcmp(&got, &want, sizeof got) == 0, #N "-wide lane of ray %d", p + l);       \
        CHECK(occ[l] == (valid[l] ? occluded[p + l] : 0), #N "-wide any hit, ray %d", p + l); \
      }                                                                                      \
    }                                                                                        \
  } while (0)

static void check_rays(const uint8_t *blob, size_t len, const char *out) {
  static KdrayRay rays[RAYS];
  static KdrayHit closest[RAYS], stream[RAYS], any_records[RAYS];
  static int32_t occluded[RAYS], stream_occluded[RAYS];
  const KdrayHit miss = {INFINITY, KDRAY_MISS, 0.0f, 0.0f};
  KdrayTriangleTree tree;
  char msg[256];
  KdrayStatus s = kdray_triangles_open(&tree, blob, len, msg, sizeof msg);
  if (s != KDRAY_STATUS_OK) {
    fprintf(stderr, "open: %s\n", msg);
    exit(1);
  }
  /* Every other ray starts inside the closed cube, where it must hit. */
  for (int i = 0; i < RAYS; i++) {
    float lo = i % 2 ? -1.0f : 0.2f, span = i % 2 ? 3.0f : 0.6f;
    KdrayRay r = {uniform(lo, span), uniform(lo, span), uniform(lo, span), 0.0f,
                  uniform(-1, 2), uniform(-1, 2), uniform(-1, 2), INFINITY};
    rays[i] = r;
  }
  rays[7].dir_x = NAN;
  rays[11].tnear = 2.0f, rays[11].tfar = 1.0f;
  rays[13].tfar = 0.25f;

  int hits = 0;
  for (int i = 0; i < RAYS; i++) {
    CHECK(kdray_closest_hit(&tree, &rays[i], &closest[i]) == KDRAY_STATUS_OK, "ray %d", i);
    CHECK(kdray_any_hit(&tree, &rays[i], &occluded[i]) == KDRAY_STATUS_OK, "ray %d", i);
    CHECK(occluded[i] == (closest[i].prim_id != KDRAY_MISS), "any hit of ray %d", i);
    if (i % 2 == 0 && i != 7 && i != 11)
      CHECK(closest[i].prim_id != KDRAY_MISS, "ray %d from inside the cube", i);
    hits += closest[i].prim_id != KDRAY_MISS;
    KdrayHit rec = {occluded[i] ? -INFINITY : INFINITY, occluded[i] ? KDRAY_OCCLUDED : KDRAY_MISS, 0, 0};
    any_records[i] = rec;
  }
  CHECK(closest[7].prim_id == KDRAY_MISS && closest[11].prim_id == KDRAY_MISS, "invalid rays miss");
  for (int i = 0; i < RAYS; i++) {
    KdrayHit first[4];
    size_t count = 99;
    CHECK(kdray_first_hits(&tree, &rays[i], first, 4, &count) == KDRAY_STATUS_OK, "first hits of ray %d", i);
    CHECK((count > 0) == (closest[i].prim_id != KDRAY_MISS), "ray %d: first hits iff a closest hit", i);
    CHECK(count == 0 || memcmp(&first[0], &closest[i], sizeof first[0]) == 0, "ray %d: the first hit is the closest", i);
    for (size_t k = 1; k < count; k++)
      CHECK(first[k].t >= first[k - 1].t, "ray %d: first hits sorted by t", i);
  }

  CHECK(kdray_closest_hits(&tree, rays, stream, RAYS, NULL) == KDRAY_STATUS_OK, "stream");
  CHECK(memcmp(stream, closest, sizeof stream) == 0, "stream hits equal single-ray hits");
  {
    /* The tree's treelets in a copy of the handle: the count first, then
       the lines; the scattered stream answers as before, bit for bit. (The
       cube is one leaf and has none; the Rust tests walk a larger tree.) */
    KdrayTriangleTree lined = tree;
    size_t needed = 99;
    KdrayStatus s = kdray_triangles_treelets(&lined, NULL, 0, &needed);
    CHECK(needed > 0 ? s == KDRAY_STATUS_BUFFER_TOO_SMALL : s == KDRAY_STATUS_OK, "treelets: the count");
    if (needed > 0) {
      KdrayTreelet *lines = aligned_alloc(64, needed * sizeof *lines);
      CHECK(lines != NULL, "treelets: memory");
      CHECK(kdray_triangles_treelets(&lined, (KdrayTreelet *)((char *)lines + 4), needed, &needed) ==
                KDRAY_STATUS_MISALIGNED,
            "treelets: a misaligned buffer is refused");
      CHECK(kdray_triangles_treelets(&lined, lines, needed, &needed) == KDRAY_STATUS_OK, "treelets");
      memset(stream, 0, sizeof stream);
      CHECK(kdray_closest_hits(&lined, rays, stream, RAYS, NULL) == KDRAY_STATUS_OK, "stream with treelets");
      CHECK(memcmp(stream, closest, sizeof stream) == 0, "stream hits through treelets equal single-ray hits");
      free(lines);
    }
  }
  CHECK(kdray_any_hits(&tree, rays, stream_occluded, RAYS, NULL) == KDRAY_STATUS_OK, "stream");
  CHECK(memcmp(stream_occluded, occluded, sizeof occluded) == 0, "stream occlusion equals single rays'");
  static uint64_t scratch[2 * RAYS];
  memset(stream_occluded, 0x55, sizeof stream_occluded);
  const KdrayBatch by_origin = {.width = 16, .scratch = scratch, .scratch_count = 2 * RAYS};
  CHECK(kdray_any_hits(&tree, rays, stream_occluded, RAYS, &by_origin) == KDRAY_STATUS_OK, "by origin");
  CHECK(memcmp(stream_occluded, occluded, sizeof occluded) == 0, "occlusion by origin equals single rays'");
  const KdrayBatch odd_width = {.width = 3};
  CHECK(kdray_any_hits(&tree, rays, stream_occluded, RAYS, &odd_width) == KDRAY_STATUS_BAD_ARGUMENT,
        "a packet width of 3 is refused");
  CHECK_PACKETS(4);
  CHECK_PACKETS(8);
  CHECK_PACKETS(16);

  write_file(out, "rays.rays", rays, sizeof rays);
  write_file(out, "closest.hits", closest, sizeof closest);
  write_file(out, "any.hits", any_records, sizeof any_records);
  printf("rays: %d traced, %d hit; packets of 4, 8, 16 and the stream agree\n", RAYS, hits);
}

static float distance2(const float *p, const float *q) {
  float dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
  return dx * dx + dy * dy + dz * dz;
}

static void check_points(const uint8_t *blob, size_t len, const float *pts, size_t n, const char *out) {
  static float queries[QUERIES][3];
  static KdrayNeighbour knn[QUERIES][K];
  KdrayPointTree tree;
  char msg[256];
  KdrayStatus s = kdray_points_open(&tree, blob, len, msg, sizeof msg);
  if (s != KDRAY_STATUS_OK) {
    fprintf(stderr, "open points: %s\n", msg);
    exit(1);
  }
  /* Its shape, and queries of another shape refused. */
  size_t dim = 0, scalar_bytes = 0;
  CHECK(kdray_points_shape(&tree, &dim, &scalar_bytes) == KDRAY_STATUS_OK && dim == 3 && scalar_bytes == 4,
        "shape %zu %zu", dim, scalar_bytes);
  {
    const double q64[3] = {0.5, 0.5, 0.5};
    const float q32[4] = {0.5f, 0.5f, 0.5f, 0.5f};
    KdrayNeighbour64 n64;
    KdrayNeighbour n32;
    CHECK(kdray_nearest_f64(&tree, q64, 3, &n64) == KDRAY_STATUS_WRONG_SHAPE, "f64 query on a float tree");
    CHECK(kdray_nearest_f32(&tree, q32, 4, &n32) == KDRAY_STATUS_WRONG_SHAPE, "4-D query on a 3-D tree");
  }
  /* Queries on the grid's points (ties at equal distance) and between them. */
  for (int i = 0; i < QUERIES; i++) {
    for (int a = 0; a < 3; a++)
      queries[i][a] = i % 4 == 0 ? floorf(uniform(0.0f, 5.0f)) * 0.25f : uniform(-0.25f, 1.5f);
  }
  for (int i = 0; i < QUERIES; i++) {
    const float *q = queries[i];
    size_t found = 0;
    CHECK(kdray_knn(&tree, q, K, knn[i], &found) == KDRAY_STATUS_OK && found == K, "knn %d", i);
    KdrayNeighbour nearest;
    CHECK(kdray_nearest(&tree, q, &nearest) == KDRAY_STATUS_OK, "nearest %d", i);
    CHECK(memcmp(&nearest, &knn[i][0], sizeof nearest) == 0, "nearest is the first of k, query %d", i);
    KdrayNeighbour knn_d[K];
    CHECK(kdray_knn_f32(&tree, q, 3, K, knn_d, &found) == KDRAY_STATUS_OK && found == K &&
              memcmp(knn_d, knn[i], sizeof knn_d) == 0,
          "knn_f32 with dim 3 is knn, query %d", i);

    /* Radius: exactly the points brute force finds, nearest first. */
    KdrayNeighbour within[128];
    float r2 = 0.1f;
    CHECK(kdray_within(&tree, q, r2, within, 128, &found) == KDRAY_STATUS_OK, "within %d", i);
    size_t in_range = 0;
    for (size_t p = 0; p < n; p++)
      in_range += distance2(&pts[3 * p], q) <= r2;
    CHECK(found == in_range, "within %d: %zu, brute force %zu", i, found, in_range);
    for (size_t j = 0; j < found; j++) {
      CHECK(within[j].d2 == distance2(&pts[3 * within[j].index], q), "distance of %u", within[j].index);
      if (j > 0)
        CHECK(within[j - 1].d2 < within[j].d2 ||
                  (within[j - 1].d2 == within[j].d2 && within[j - 1].index < within[j].index),
              "order at %zu", j);
    }
    if (in_range > 1) {
      size_t needed = 0;
      s = kdray_within(&tree, q, r2, within, 1, &needed);
      CHECK(s == KDRAY_STATUS_BUFFER_TOO_SMALL && needed == in_range, "%d %zu", (int)s, needed);
    }
  }
  write_file(out, "queries.pts", queries, sizeof queries);
  write_file(out, "knn5.knn", knn, sizeof knn);
  printf("points: %d queries, k = %d, radius queries equal brute force\n", QUERIES, K);
}

/* A scene's closest point (capi/tests/data/two-quads-scene.kdt: a unit
   quad at z = 5, and the same quad turned a quarter, doubled and moved to
   x in [1, 3], y in [0, 2], z = 0), in 64-byte aligned memory. */
static void check_scene(const char *path) {
  size_t len;
  uint8_t *raw = read_file(path, &len);
  uint8_t *blob = aligned_alloc(64, (len + 63) / 64 * 64);
  if (!blob) {
    fprintf(stderr, "out of memory\n");
    exit(2);
  }
  memcpy(blob, raw, len);
  free(raw);
  KdrayScene scene;
  KdrayStatus s = kdray_scene_open(&scene, blob, len, NULL, 0);
  CHECK(s == KDRAY_STATUS_OK, "open the scene: %d", (int)s);
  const float pts[4][3] = {{0.5f, 0.5f, 6.0f}, {2.0f, 1.0f, -0.5f}, {NAN, 0.0f, 0.0f}, {9.0f, 9.0f, 9.0f}};
  KdraySceneClosestPoint cp[4];
  s = kdray_scene_closest_points(&scene, &pts[0][0], 4, 0xFFFFFFFFu, 5.0f, cp);
  CHECK(s == KDRAY_STATUS_OK, "status %d", (int)s);
  CHECK(cp[0].inst_id == 0 && cp[0].x == 0.5f && cp[0].y == 0.5f && cp[0].z == 5.0f && cp[0].distance2 == 1.0,
        "above the first quad: instance %u at (%g %g %g) d2 %g", cp[0].inst_id, cp[0].x, cp[0].y, cp[0].z,
        cp[0].distance2);
  CHECK(cp[1].inst_id == 1 && fabs(cp[1].distance2 - 0.25) < 1e-6 && fabsf(cp[1].x - 2.0f) < 1e-6f,
        "below the second: instance %u d2 %g", cp[1].inst_id, cp[1].distance2);
  CHECK(cp[2].inst_id == KDRAY_MISS && isnan(cp[2].distance2), "a NaN query has no point");
  CHECK(cp[3].inst_id == KDRAY_MISS && cp[3].prim_id == KDRAY_MISS && isinf(cp[3].distance2),
        "beyond the maximum distance");
  /* One point at a time: the same record; mask 0 selects nothing. */
  KdraySceneClosestPoint one;
  CHECK(kdray_scene_closest_point(&scene, pts[1], 0xFFFFFFFFu, 5.0f, &one) == KDRAY_STATUS_OK &&
            memcmp(&one, &cp[1], sizeof one) == 0,
        "one point: instance %u", one.inst_id);
  CHECK(kdray_scene_closest_point(&scene, pts[1], 0, INFINITY, &one) == KDRAY_STATUS_OK &&
            one.inst_id == KDRAY_MISS,
        "mask 0");
  CHECK(kdray_scene_closest_point(&scene, pts[1], 1, NAN, &one) == KDRAY_STATUS_OK && one.inst_id == KDRAY_MISS,
        "a NaN maximum distance: none");
  CHECK(kdray_scene_closest_point(&scene, NULL, 1, 1.0f, &one) == KDRAY_STATUS_NULL_POINTER, "null point");
  CHECK(kdray_scene_closest_point(&scene, pts[0], 1, 1.0f, NULL) == KDRAY_STATUS_NULL_POINTER, "null out");
  free(blob);
  printf("scene: closest points over instances, masks and bad input\n");
}

int main(int argc, char **argv) {
  if (argc != 6) {
    fprintf(stderr, "usage: %s TRIANGLE_BLOB POINT_BLOB POINTS_PTS OUT_DIR SCENE_BLOB\n", argv[0]);
    return 2;
  }
  printf("kdray %s\n", kdray_version());
  size_t tri_len, pts_blob_len, pts_len;
  uint8_t *tri = read_file(argv[1], &tri_len);
  uint8_t *pts_blob = read_file(argv[2], &pts_blob_len);
  float *pts = (float *)read_file(argv[3], &pts_len);
  check_arguments(tri, tri_len);
  check_rays(tri, tri_len, argv[4]);
  check_points(pts_blob, pts_blob_len, pts, pts_len / 12, argv[4]);
  check_scene(argv[5]);

  /* A triangle blob is not a point tree. */
  char msg[256];
  KdrayPointTree wrong;
  KdrayStatus s = kdray_points_open(&wrong, tri, tri_len, msg, sizeof msg);
  CHECK(s == KDRAY_STATUS_INVALID_BLOB && strstr(msg, "kind") != NULL, "%d \"%s\"", (int)s, msg);

  free(tri);
  free(pts_blob);
  free(pts);
  if (failures) {
    fprintf(stderr, "%d checks failed\n", failures);
    return 1;
  }
  printf("C API checks passed\n");
  return 0;
}
