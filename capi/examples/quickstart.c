/* The C quick start: open a tree blob written by `kdray build`, trace one
 * ray, print its closest hit and whether it is occluded. A blob the
 * library refuses (corrupt, truncated, another kind) is reported and the
 * program returns 1 without tracing: `hit` is read only after a call that
 * returned KDRAY_STATUS_OK has written it.
 *
 * usage: quickstart TREE.kdt      (e.g. kernel/golden/cube-v3.kdt)
 */
#include "kdray.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: %s TREE.kdt\n", argv[0]);
    return 2;
  }
  /* The whole blob in malloc'd memory (aligned for any type, so 4-byte
   * aligned as the library needs); it must outlive the handle. */
  FILE *f = fopen(argv[1], "rb");
  if (!f || fseek(f, 0, SEEK_END) != 0) {
    fprintf(stderr, "cannot open %s\n", argv[1]);
    return 1;
  }
  long len = ftell(f);
  uint8_t *blob = malloc(len > 0 ? (size_t)len : 1);
  if (len < 0 || !blob || fseek(f, 0, SEEK_SET) != 0 ||
      fread(blob, 1, (size_t)len, f) != (size_t)len) {
    fprintf(stderr, "cannot read %s\n", argv[1]);
    return 1;
  }
  fclose(f);

  KdrayTriangleTree scene; /* a handle in your memory; nothing to free */
  char why[256];
  if (kdray_triangles_open(&scene, blob, (size_t)len, why, sizeof why) != KDRAY_STATUS_OK) {
    fprintf(stderr, "%s refused: %s\n", argv[1], why);
    free(blob);
    return 1;
  }

  /* org, tnear, dir, tfar */
  KdrayRay ray = {0.3f, 0.6f, -1.0f, 0.0f, 0.0f, 0.0f, 1.0f, INFINITY};
  KdrayHit hit;
  int32_t occluded;
  if (kdray_closest_hit(&scene, &ray, &hit) != KDRAY_STATUS_OK ||
      kdray_any_hit(&scene, &ray, &occluded) != KDRAY_STATUS_OK) {
    fprintf(stderr, "query refused\n");
    free(blob);
    return 1;
  }
  if (hit.prim_id == KDRAY_MISS) {
    printf("miss\n");
  } else {
    printf("hit triangle %u at t = %g (u = %g, v = %g)\n", (unsigned)hit.prim_id, hit.t, hit.u,
           hit.v);
  }
  printf("occluded: %s\n", occluded ? "yes" : "no");
  free(blob);
  return 0;
}
