"""The firmware image built for wasm32-unknown-unknown, run in wasmtime:
it imports nothing (a reachable panic would import the undefined
`kdray_firmware_reached_a_panic_path`), validates its embedded blobs, and
traces rays with the answers the kernel's own tests give.

usage: python3 wasm_test.py IMAGE.wasm   (pip install wasmtime)
"""
import struct
import sys

import wasmtime

engine = wasmtime.Engine()
module = wasmtime.Module.from_file(engine, sys.argv[1])
imports = [f"{i.module}.{i.name}" for i in module.imports]
if imports:
    sys.exit(f"the image imports {imports}: a panic path is reachable")
store = wasmtime.Store(engine)
exports = wasmtime.Instance(store, module, []).exports(store)
boot = exports["kdray_fw_boot"]


def trace(store, *args):
    """kdray_fw_trace's u32 (wasm's i32 results arrive signed)."""
    return exports["kdray_fw_trace"](store, *args) & 0xFFFFFFFF




def check(what, got, want):
    if got != want:
        sys.exit(f"{what}: got {got}, want {want}")
    print(f"{what}: {got}")

check("boot (both blobs valid)", boot(store), 0)
# The README's ray: into the cube's z = 0 face at t = 1, its second triangle.
check("closest hit triangle", trace(store, 0, 0.3, 0.6, -1.0, 0.0, 0.0, 1.0), 1)
t = struct.unpack("<f", struct.pack("<I", trace(store, 1, 0.3, 0.6, -1.0, 0.0, 0.0, 1.0)))[0]
check("closest hit t", t, 1.0)
check("occluded from inside the closed cube", trace(store, 2, 0.5, 0.5, 0.5, 0.0, 0.0, 1.0), 1)
check("not occluded, away from the cube", trace(store, 2, 0.3, 0.6, -1.0, 0.0, 0.0, -1.0), 0)
check("miss", trace(store, 0, 0.3, 0.6, -1.0, 0.0, 0.0, -1.0), 0xFFFFFFFF)
# The grid point (0.25, 0.5, 0) is point 1 + 2 * 5 = 11.
check("first hits: floor, inner triangle, roof", trace(store, 4, 0.3, 0.6, -1.0, 0.0, 0.0, 1.0), 1 | 13 << 8 | 2 << 16)
check("nearest grid point", trace(store, 3, 0.26, 0.49, 0.01, 0.0, 0.0, 1.0), 11)
print("wasm image: no imports, rays traced")
