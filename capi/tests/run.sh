#!/usr/bin/env bash
# Builds libkdray_capi.a and .so, checks that include/kdray.h is what
# cbindgen makes of the code, compiles the C test, the C quick start and
# the C++ camera example against each library with the system's gcc and g++, runs them,
# and compares their rays' hits byte for byte with the Rust API's
# (`kdray trace`, `kdray knn`). Run from anywhere; CI runs it.
set -euo pipefail
cd "$(dirname "$0")/../.."
target=${CARGO_TARGET_DIR:-target}
out=$target/capi-test
rm -rf "$out" && mkdir -p "$out/static" "$out/dynamic"

cargo build --release -p kdray-capi
cargo build --release --bin kdray
lib=$target/release
kdray=$lib/kdray

if command -v cbindgen >/dev/null; then
  cbindgen --quiet --config capi/cbindgen.toml --crate kdray-capi --output "$out/kdray.h"
  if ! cmp -s "$out/kdray.h" capi/include/kdray.h; then
    diff -u capi/include/kdray.h "$out/kdray.h" | head -40
    echo "capi/include/kdray.h is stale: regenerate it (command in capi/cbindgen.toml)" >&2
    exit 1
  fi
  echo "header: capi/include/kdray.h matches the code"
else
  echo "cbindgen not installed: header check skipped" >&2
fi

# The static library carries std's native dependencies
# (`cargo rustc --crate-type staticlib -- --print native-static-libs`).
native="-lgcc_s -lutil -lrt -lpthread -lm -ldl -lc"
cflags="-std=c11 -O2 -Wall -Wextra -Werror -ffp-contract=off -Icapi/include"
cxxflags="-std=c++17 -O2 -Wall -Wextra -Werror -ffp-contract=off -Icapi/include"
gcc $cflags capi/tests/capi_test.c "$lib/libkdray_capi.a" $native -o "$out/capi_test_static"
gcc $cflags capi/tests/capi_test.c -L"$lib" -l:libkdray_capi.so -Wl,-rpath,"$(cd "$lib" && pwd)" -lm -o "$out/capi_test_dynamic"
g++ $cxxflags capi/examples/camera.cpp "$lib/libkdray_capi.a" $native -o "$out/camera_static"
g++ $cxxflags capi/examples/camera.cpp -L"$lib" -l:libkdray_capi.so -Wl,-rpath,"$(cd "$lib" && pwd)" -o "$out/camera_dynamic"
# The README's C quick start, a whole program: it answers on the golden
# cube and returns 1, without tracing, on a blob the library refuses.
gcc $cflags capi/examples/quickstart.c "$lib/libkdray_capi.a" $native -o "$out/quickstart"
"$out/quickstart" kernel/golden/cube-v3.kdt | grep -q "^hit triangle 1 at t = 1 "
head -c 100 kernel/golden/cube-v3.kdt > "$out/cut.kdt"
if "$out/quickstart" "$out/cut.kdt" 2> "$out/quickstart.err"; then
  echo "quickstart accepted a truncated blob" >&2
  exit 1
fi
grep -q "refused: blob truncated" "$out/quickstart.err"
echo "quickstart: answers on the cube, returns 1 on a refused blob"
# The dynamic builds really load the shared library.
ldd "$out/capi_test_dynamic" | grep libkdray_capi.so >/dev/null
ldd "$out/camera_dynamic" | grep libkdray_capi.so >/dev/null

cube=kernel/golden/cube-v3.kdt
grid=capi/tests/data/grid-100.kdt
for kind in static dynamic; do
  d=$out/$kind
  "$out/capi_test_$kind" "$cube" "$grid" capi/tests/data/grid-100.pts "$d" capi/tests/data/two-quads-scene.kdt
  "$kdray" trace "$cube" "$d/rays.rays" -o "$d/rust-closest.hits" >/dev/null
  "$kdray" trace "$cube" "$d/rays.rays" -o "$d/rust-any.hits" --any-hit >/dev/null
  "$kdray" knn capi/tests/data/grid-100.pts "$d/queries.pts" -k 5 -o "$d/rust-knn5.knn" >/dev/null
  cmp "$d/closest.hits" "$d/rust-closest.hits"
  cmp "$d/any.hits" "$d/rust-any.hits"
  cmp "$d/knn5.knn" "$d/rust-knn5.knn"

  "$out/camera_$kind" "$cube" 48 24 "$d/camera.rays" "$d/camera.hits"
  "$kdray" trace "$cube" "$d/camera.rays" -o "$d/rust-camera.hits" >/dev/null
  cmp "$d/camera.hits" "$d/rust-camera.hits"
  echo "$kind library: C and C++ hits equal the Rust API's byte for byte"
done

# A real mesh when ../shared is present (a user's clone has none).
teapot=../shared/meshes/teapot.obj
if [ -f "$teapot" ]; then
  "$kdray" build "$teapot" -o "$out/teapot.kdt" >/dev/null
  "$out/camera_dynamic" "$out/teapot.kdt" 160 120 "$out/teapot.rays" "$out/teapot.hits" 0.2 4 -9 0.2 1.5 0 >/dev/null
  "$kdray" trace "$out/teapot.kdt" "$out/teapot.rays" -o "$out/rust-teapot.hits" >/dev/null
  cmp "$out/teapot.hits" "$out/rust-teapot.hits"
  echo "teapot camera: C++ hits equal the Rust API's byte for byte"
fi
echo "C API: all checks passed"
