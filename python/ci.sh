#!/usr/bin/env bash
# The Python package's checks, as CI runs them after the Rust tests: a
# virtual environment with the test dependencies, fmt and clippy on the
# binding crate (its own workspace), the package built and installed as
# a user would (`pip install ./python`), ruff, mypy (the hand-written
# stubs against the compiled module), pytest.
# Usage: bash python/ci.sh   (KDRAY_PY_VENV=DIR for another venv folder)
set -euo pipefail
cd "$(dirname "$0")"
VENV=$(realpath -m "${KDRAY_PY_VENV:-../target/py-venv}")
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
"$VENV/bin/pip" install -q --upgrade pip
"$VENV/bin/pip" install -q maturin numpy pytest hypothesis scipy trimesh rtree "dask[array,distributed]" ruff mypy
cargo fmt --manifest-path Cargo.toml -- --check
cargo clippy --manifest-path Cargo.toml --all-targets -- -D warnings
"$VENV/bin/pip" install -q --force-reinstall --no-deps .
"$VENV/bin/ruff" check kdray tests bench
# Outside python/, so `import kdray` is the installed package, not ./kdray.
(cd /tmp && "$VENV/bin/python" -m mypy.stubtest kdray._kdray)
"$VENV/bin/mypy" kdray
# pytest reads its settings from pyproject.toml; run from tests/ for the same reason.
(cd tests && "$VENV/bin/pytest" -q)
