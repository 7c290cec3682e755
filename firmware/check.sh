#!/usr/bin/env bash
# The no-panic proof and the firmware figures (docs/results.md, "Firmware").
# Links the image for thumbv7em-none-eabihf in the release and size
# profiles (a link error naming kdray_firmware_reached_a_panic_path means
# a panic path is reachable), prints its .text, builds the same image for
# wasm32 and traces rays in it, and, where nightly is installed, prints
# each entry point's largest stack use from the compiler's frame sizes.
set -euo pipefail
cd "$(dirname "$0")"
thumb=thumbv7em-none-eabihf
target=${CARGO_TARGET_DIR:-target}
bin="$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin"
rustup component add llvm-tools >/dev/null 2>&1 || true

text() {
  if [ -x "$bin/llvm-size" ]; then
    "$bin/llvm-size" -A "$target/$thumb/$1/kdray-firmware" | awk '$1 == ".text" {print $2 " bytes"}'
  else
    echo "(llvm-size not installable here)"
  fi
}
for profile in release size; do
  cargo build -q --profile "$profile" --target $thumb --no-default-features
  echo ".text, $profile profile, validation + closest + any hit: $(text "$profile")"
  cargo build -q --profile "$profile" --target $thumb
  echo ".text, $profile profile, with point validation, k-NN and first hits: $(text "$profile")"
done
echo "no-panic image links for $thumb in the release and size profiles"

cargo build -q --release --target wasm32-unknown-unknown
python3 -c "import wasmtime" 2>/dev/null || pip install --quiet wasmtime
python3 wasm_test.py "$target/wasm32-unknown-unknown/release/kdray-firmware.wasm"

if rustup +nightly target add $thumb >/dev/null 2>&1 && [ -x "$bin/llvm-objdump" ]; then
  RUSTFLAGS="-Z emit-stack-sizes -C link-arg=-Tstack-sizes.x -C link-arg=-L$(pwd)" \
    cargo +nightly build -q --profile size --target $thumb --target-dir "$target/stack-sizes"
  python3 stack_sizes.py "$target/stack-sizes/$thumb/size/kdray-firmware" "$bin/llvm-objdump" \
    kdray_fw_validate_triangles kdray_fw_validate_points kdray_fw_closest_hit kdray_fw_any_hit kdray_fw_first_hits kdray_fw_knn
else
  echo "nightly or llvm-objdump not installable here: stack sizes skipped"
fi
