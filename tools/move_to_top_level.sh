#!/usr/bin/env bash
# Move the subpackages of imutherm/ to the top of the repository (issue 13 §1), keeping their history (git mv).
# pyproject.toml maps them back into the imutherm namespace (package-dir "imutherm.thermal" = "thermal", ...).
#
# Idempotent: a package already moved is left alone; files that reached imutherm/<pkg>/ later (e.g. from a
# branch merged after the move) are moved into <pkg>/ one by one. Left-over __pycache__ folders of the old
# places are deleted: an imutherm/<pkg>/ folder holding only __pycache__ would be imported as an empty
# namespace package in place of <pkg>/. Run from anywhere inside the repository; commit afterwards.
#
# Merging the branch that made the move into one that added files under imutherm/<pkg>/:
#   git merge -X find-renames=25% <branch>   # a heavily edited file (cli/__init__.py) is still seen as moved
#   git add <pkg>/<file> ...                  # git's "file location" conflicts: it already put them in <pkg>/
#   bash tools/move_to_top_level.sh           # whatever is left under imutherm/<pkg>/, and the __pycache__
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"

PACKAGES="thermal geometry layouts studies reports imu cli"

for pkg in $PACKAGES; do
    old="imutherm/$pkg"
    if [ -n "$(git ls-files -- "$old")" ]; then
        if [ ! -e "$pkg" ]; then
            git mv "$old" "$pkg"
            echo "moved $old -> $pkg"
        else  # the top-level folder exists: move what is still tracked under the old place, file by file
            git ls-files -z -- "$old" | while IFS= read -r -d '' f; do
                dest="$pkg/${f#"$old"/}"
                if [ -e "$dest" ]; then
                    echo "error: $f and $dest both exist; merge them by hand" >&2
                    exit 1
                fi
                mkdir -p "$(dirname "$dest")"
                git mv "$f" "$dest"
                echo "moved $f -> $dest"
            done
        fi
    fi
    if [ -d "$old" ]; then  # untracked leftovers of the old place
        find "$old" -depth -type d -name __pycache__ -exec rm -rf {} +
        find "$old" -depth -type d -empty -delete
        if [ -d "$old" ]; then
            echo "warning: $old still holds untracked files (not deleted): $(find "$old" -type f | head -5 | tr '\n' ' ')" >&2
        fi
    fi
done
echo "done: $(for p in $PACKAGES; do printf '%s/ ' "$p"; done)at the top; imutherm/ keeps __init__.py and the small modules"
