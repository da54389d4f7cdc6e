#!/usr/bin/env bash
# The statistics crate as a user outside the repository sees it: a new
# cargo project that depends on crates/stats alone, whose dependency tree
# must hold no training, plotting or parsing crate (dfdx, plotters, pest,
# safetensors, pyo3, parquet, clap), and which builds and runs every ```rust example of
# docs/library.md as a program of its own (each asserts its numbers).
# Usage: bash scripts/library-check.sh   (CI runs it; about 1.5 minutes on 2
# cores: its dependencies build once into target/library-check)
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
project="$work/uses-crossaudit-stats"
mkdir -p "$project/src/bin"
cat > "$project/Cargo.toml" <<EOF
[package]
name = "uses-crossaudit-stats"
version = "0.0.0"
edition = "2021"
publish = false

[dependencies]
crossaudit-stats = { path = "$repo/crates/stats" }

[workspace]
EOF
# Each rust block of docs/library.md becomes src/bin/exampleN.rs.
python3 - "$repo/docs/library.md" "$project/src/bin" <<'EOF'
import re, sys, pathlib
text = pathlib.Path(sys.argv[1]).read_text()
blocks = re.findall(r"```rust\n(.*?)```", text, re.S)
if not blocks:
    sys.exit("docs/library.md has no ```rust example")
for k, code in enumerate(blocks, 1):
    pathlib.Path(sys.argv[2], f"example{k}.rs").write_text(code)
print(f"library-check: {len(blocks)} examples from docs/library.md")
EOF
cd "$project"
# The same lock as the repository's, so the same dependency versions.
cp "$repo/Cargo.lock" Cargo.lock
export CARGO_TARGET_DIR="$repo/target/library-check"
tree=$(cargo tree --edges normal --prefix none)
for banned in dfdx plotters pest safetensors pyo3 parquet clap; do
  if grep -q "^$banned " <<< "$tree"; then
    echo "library-check: crossaudit-stats depends on $banned:" >&2
    cargo tree -i "$banned" >&2
    exit 1
  fi
done
echo "library-check: $(sort -u <<< "$tree" | wc -l) crates in the tree, none of dfdx, plotters, pest, safetensors, pyo3, parquet, clap"
cargo build --release --bins --quiet
for bin in src/bin/example*.rs; do
  name=$(basename "$bin" .rs)
  echo "library-check: running $name"
  "$CARGO_TARGET_DIR/release/$name" > "$work/$name.out"
  tail -n 3 "$work/$name.out"
done
echo "library-check: every example of docs/library.md built and ran outside the repository"
